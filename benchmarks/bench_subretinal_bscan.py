"""What one iOCT B-scan costs: `ioct.render_bscan` and `segment.segment_bscan`, per B-scan.

Run alone: python benchmarks/bench_subretinal_bscan.py [--repeats N]; `rows()` for run.py (one
repeat under --quick). The scenes are the kinds an episode renders (`SCENES`, drawn from a fixed
seed): the needle above the window, above the ILM, tenting it and in the retina, at tilts from
0.1 to 1.4 rad, each image with its own speckle seed. Alone it prints one JSON object: the
minimum over N runs (5) of the mean time per B-scan to render and to segment [ms], and a
SHA-256 digest of every image and segmentation, which is the same wherever the results are the
same (run it at two commits to check that a change kept them). The load average is printed too.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import time
from dataclasses import astuple
from typing import Any

import numpy as np

from _common import quick, row
from rcmplan.subretinal.ioct import BScanScene, IoctModel, render_bscan
from rcmplan.subretinal.segment import segment_bscan

SCENES = 60
MODEL = IoctModel()
RADIUS_M, DIAMETER_M = 11e-3, 100e-6


def scenes(n: int = SCENES) -> list[BScanScene]:
    """n scenes, every sixth without a needle, every third tented under the tip."""
    rng = np.random.default_rng(123)
    out = []
    for k in range(n):
        tip = None
        if k % 6:
            tip = (float(rng.uniform(-200e-6, 200e-6)), float(rng.uniform(-250e-6, 150e-6)))
        tent = float(rng.uniform(0.0, 90e-6)) if k % 3 == 0 else 0.0
        tilt = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 1.4))
        out.append(BScanScene(ilm_offset_m=float(rng.uniform(-60e-6, 60e-6)),
                              curvature_radius_m=RADIUS_M, tent_m=tent,
                              tent_x_m=0.0 if tip is None else tip[0], tip_m=tip,
                              needle_tilt_rad=tilt))  # fmt: skip
    return out


def one_pass(batch: list[BScanScene]) -> tuple[float, float, str]:
    """Mean render and segment time per B-scan [s] over the scenes, and the digest."""
    digest = hashlib.sha256()
    render_s = segment_s = 0.0
    for k, scene in enumerate(batch):
        rng = np.random.default_rng(k)
        t0 = time.perf_counter()
        image = render_bscan(MODEL, scene, rng)
        t1 = time.perf_counter()
        seg = segment_bscan(image, MODEL, RADIUS_M, DIAMETER_M)
        t2 = time.perf_counter()
        render_s += t1 - t0
        segment_s += t2 - t1
        digest.update(image.tobytes())
        for value in astuple(seg):
            digest.update(np.asarray(np.nan if value is None else value, dtype=float).tobytes())
    return render_s / len(batch), segment_s / len(batch), digest.hexdigest()


def measure(repeats: int) -> dict[str, Any]:
    """Minimum over `repeats` passes of the per-B-scan times [ms], and the digest."""
    batch = scenes()
    passes = [one_pass(batch) for _ in range(repeats)]
    if len({p[2] for p in passes}) != 1:
        raise RuntimeError("the same scenes and seeds gave different images")
    render_ms = 1e3 * min(p[0] for p in passes)
    segment_ms = 1e3 * min(p[1] for p in passes)
    return {"scenes": len(batch), "repeats": repeats, "render_ms": render_ms,
            "segment_ms": segment_ms, "total_ms": render_ms + segment_ms,
            "digest": passes[0][2], "load_average": os.getloadavg()}  # fmt: skip


def rows() -> list[dict[str, Any]]:
    """Per-B-scan render and segment times."""
    doc = measure(1 if quick() else 5)
    return [row("iOCT B-scan: render_bscan (256 x 96 px)", doc["render_ms"], "ms"),
            row("iOCT B-scan: segment_bscan", doc["segment_ms"], "ms")]  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(json.dumps(measure(args.repeats), indent=1))


if __name__ == "__main__":
    main()
