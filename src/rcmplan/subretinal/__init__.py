"""Subretinal injection under intraoperative OCT: the models, and one episode on the RCM
controller.

- `layers`: the retina's ILM and RPE as spheres on the posterior wall, depths, the target.
- `motion`: breathing and cardiac motion of the wall along its normal, whole-eye translation.
- `tissue`: tenting of the ILM ahead of the needle and puncture.
- `ioct`: acquisition timing and a synthetic B-scan with speckle around the needle.
- `segment`: ILM, RPE and needle tip from the image alone.
- `predict`: predictors of the ILM displacement across the iOCT latency (none, hold, fft,
  kalman), by name.
- `trace`: one episode's acquisitions, segmented, and the prediction error across the latency.
- `episode`, `episode_settings`, `episode_metrics`, `episode_plot`: one injection on the QP
  controller (approach, hover, advance, hold, retract) with motion compensation and a depth
  limit; `rcmplan subretinal`.
- `episode_bscans`: the B-scans of the volumes an episode's controller received, for
  `rcmplan view`.
- `episode_draws`, `episode_batch`, `episode_report`, `episode_curves`: many episodes with
  drawn conditions, every method on each, on the sweep's executors and checkpoints, their
  success rates and curves; `rcmplan subretinal --episodes N`.

Sources of every default: docs/subretinal.md.
"""
