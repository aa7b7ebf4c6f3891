"""What the ``sobol`` film's batches cost: MSE at a fixed spp for B batches of spp / B samples per pixel.

The ``sobol`` render sampler estimates a pixel's variance from B independent
Owen scramblings (batches) of spp / B samples each (mcocl/render/sobol_film.py);
fewer, larger batches keep more of each net's stratification.  For every scene
and B this renders ``--spp`` spp with ``integrator mis`` (the scene's light
sampler set to ``--light-sampler``) for ``--seeds`` seeds and prints the MSE
per pixel and channel against the reference of bench/render_throughput.py (a
long independent ``mis`` render, cached in ``--out``, its own variance
subtracted), the sampling seconds, and the mean reported variance of the
pixel means beside the MSE (equal in expectation for an honest variance, up
to the reference's bias, which is nil).  B = 1 is one replicate of the whole
``spp``: it has no variance.  ``independent`` is the Philox sampler, for scale.

    PYTHONPATH=. python bench/render_sobol_batches.py --spp 64 256 --batches 16 8 4 2 1 --seeds 4
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from render_throughput import mse, reference, scene_variant  # noqa: E402

from mcocl.render import compile_scene  # noqa: E402
from mcocl.render.api import render  # noqa: E402


def run_config(cs, spp: int, batches: int | None, seeds: int, ref, ref_var) -> dict:
    """MSE, seconds and mean reported variance over ``seeds`` renders; ``batches`` None: the independent sampler."""
    mses, secs, var = [], [], []
    for k in range(seeds):
        if batches is None:
            r = render(cs, spp=spp, seed=100 + k, sampler="independent")
        else:
            r = render(cs, spp=spp, seed=100 + k, sampler="sobol", spp_per_block=spp // batches)
        mses.append(mse(r.mean, ref, ref_var))
        secs.append(r.seconds)
        var.append(float(np.nanmean(r.variance.astype(np.float64))) if batches != 1 else float("nan"))
    return {"mse": statistics.mean(mses), "mse_runs": mses, "seconds_median": statistics.median(secs),
            "mean_reported_variance": statistics.mean(var)}


def main() -> None:
    """Print the table and write ``--out``/sobol_batches.json."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["cornell", "veach_mis", "many_lights"])
    ap.add_argument("--spp", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--batches", type=int, nargs="+", default=[16, 8, 4, 2, 1])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--light-sampler", default="auto")
    ap.add_argument("--reference-seconds", type=float, default=60.0)
    ap.add_argument("--out", default=str(ROOT / "bench-out" / "render"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results: dict = {}
    for name in args.scenes:
        scene = ROOT / "scenes" / f"{name}.json"
        ref, ref_var, how = reference(out, scene, args.reference_seconds)
        cs = compile_scene(scene_variant(scene, "mis", args.light_sampler))
        render(cs, spp=1, seed=999, sampler="sobol")  # build the kernels before timing
        render(cs, spp=1, seed=999)
        results[name] = {"reference": how}
        for spp in args.spp:
            rows = {"independent": run_config(cs, spp, None, args.seeds, ref, ref_var)}
            for b in args.batches:
                rows[f"B={b}"] = run_config(cs, spp, b, args.seeds, ref, ref_var)
            results[name][str(spp)] = rows
            for label, row in rows.items():
                print(f"{name:12s} {spp:4d} spp {label:12s} MSE {row['mse']:.4g}  reported variance "
                      f"{row['mean_reported_variance']:.4g}  {row['seconds_median']:.2f} s", flush=True)
    (out / "sobol_batches.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
