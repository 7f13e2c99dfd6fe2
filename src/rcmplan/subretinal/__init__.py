"""Subretinal injection under intraoperative OCT: the models that do not depend on the
controller.

- `layers`: the retina's ILM and RPE as spheres on the posterior wall, depths, the target.
- `motion`: breathing and cardiac motion of the wall along its normal, whole-eye translation.
- `tissue`: tenting of the ILM ahead of the needle and puncture.
- `ioct`: acquisition timing and a synthetic B-scan with speckle around the needle.
- `segment`: ILM, RPE and needle tip from the image alone.
- `predict`: predictors of the ILM displacement across the iOCT latency (none, hold, fft,
  kalman), by name.
- `trace`: one episode's acquisitions, segmented, and the prediction error across the latency.

Sources of every default: docs/subretinal.md.
"""
