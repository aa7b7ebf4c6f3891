"""Render efficiency of ``sampler="sobol"`` against independent sampling on the Cornell box.

Efficiency = 1 / (MSE x seconds), the MSE per pixel and channel against a long
independent reference rendered in the same process (its own variance, which
it reports honestly, is subtracted from the MSE), seconds the sampling time.

    PYTHONPATH=. python bench/render_sobol_efficiency.py --size 64 --spp 256 --ref-spp 8192
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from mcocl.render.api import render
from mcocl.render.scene_file import load_scene


def small_cornell(size: int):
    """scenes/cornell.json at size x size pixels."""
    scene = load_scene("scenes/cornell.json")
    scene.camera = dataclasses.replace(scene.camera, width=size, height=size)
    return scene


def main() -> None:
    """Print MSE, seconds and efficiency of both samplers, and their ratio."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    scene = small_cornell(args.size)
    ref = render(scene, spp=args.ref_spp, seed=1000)
    ref_var = float(np.nanmean(ref.variance))
    print(f"reference: {args.ref_spp} spp independent, {ref.seconds:.1f} s, mean variance {ref_var:.3g}")
    eff = {}
    for sampler in ("independent", "sobol"):
        # warm up with the same build (PoCL compiles at the first launch), then time the seeds
        render(scene, spp=args.spp, seed=0, sampler=sampler)
        mse, secs = [], []
        for seed in range(1, args.seeds + 1):
            r = render(scene, spp=args.spp, seed=seed, sampler=sampler)
            mse.append(float(np.mean((r.mean.astype(np.float64) - ref.mean) ** 2)) - ref_var)
            secs.append(r.seconds)
        m, s = float(np.mean(mse)), float(np.mean(secs))
        eff[sampler] = 1.0 / (m * s)
        print(f"{sampler:12s} {args.spp} spp: MSE {m:.4g}  {s:.2f} s  efficiency {eff[sampler]:.4g}  "
              f"(blocks of {r.spp_per_block} spp)")
    print(f"efficiency ratio sobol / independent: {eff['sobol'] / eff['independent']:.2f}")


if __name__ == "__main__":
    main()
