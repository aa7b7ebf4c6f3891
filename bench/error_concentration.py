"""Where a render's error is, and what sample allocation could do about it.

    PYTHONPATH=. python bench/error_concentration.py --scene caustic --spp 64 --seeds 16
    PYTHONPATH=. python bench/error_concentration.py --scene cornell --sampler sobol

For one of bench/render_throughput.py's scenes: ``--seeds`` renders of
``--spp`` spp against its cached reference (the same one that script's Mitsuba
comparison uses; ``--reference-seconds`` of sampling when it must be made).
The script reports:

* the MSE, less the reference's own variance;
* how concentrated the error is: the share of the image's pixels that holds
  50, 80 and 90 % of the squared error, and the pixels with the largest error
  (their reference value, and their per-sample standard deviation from a
  ``--deviation-spp`` render with independent samples);
* the *oracle* gain of adaptive sampling. A pixel's samples in proportion to
  its per-sample deviation s_p minimise sum_p s_p^2 / n_p for a fixed budget,
  and then the MSE at equal samples is (sum_p s_p)^2 / (P sum_p s_p^2) of the
  uniform one's. That is an upper bound: any real scheme must first estimate
  s_p. README, "Efficiency against Mitsuba 3", for caustic.json: an 8-sample
  pilot cannot see its 1.2 % events.

Nothing here is timed: it measures errors, not speed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from render_throughput import REFERENCE_INTEGRATOR, SCENE_FILES, mse, reference  # noqa: E402

from mcocl.render import compile_scene  # noqa: E402
from mcocl.render.api import render  # noqa: E402


def shares(err: np.ndarray, levels: tuple[float, ...] = (0.5, 0.8, 0.9)) -> dict[float, int]:
    """The fewest pixels of the (H, W) squared-error map that hold each share of its sum."""
    flat = np.sort(err.ravel())[::-1]
    c = np.cumsum(flat) / flat.sum()
    return {q: int(np.searchsorted(c, q)) + 1 for q in levels}


def oracle_gain(deviation: np.ndarray) -> float:
    """Uniform over proportional-to-deviation allocation's MSE at equal samples: P sum s^2 / (sum s)^2."""
    s = deviation.ravel().astype(np.float64)
    return float(s.size * np.sum(s * s) / np.sum(s) ** 2) if s.sum() > 0 else 1.0


def main() -> None:
    """Render the seeds, print the concentration of their error and the oracle allocation's gain."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="caustic", choices=sorted(SCENE_FILES))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--sampler", default="independent", choices=("independent", "sobol", "auto"))
    ap.add_argument("--deviation-spp", type=int, default=1024, help="spp of the per-pixel deviation render")
    ap.add_argument("--top", type=int, default=10, help="pixels with the largest error to list")
    ap.add_argument("--reference-seconds", type=float, default=60.0)
    ap.add_argument("--out", default=str(ROOT / "bench-out" / "render"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = SCENE_FILES[args.scene]
    ref, ref_var, how = reference(out, scene, args.reference_seconds, REFERENCE_INTEGRATOR.get(args.scene, "mis"))
    cs = compile_scene(scene)
    ref64 = ref.astype(np.float64)
    sq = np.zeros(ref.shape[:2])
    errors = []
    for k in range(args.seeds):
        r = render(cs, spp=args.spp, seed=1000 + k, sampler=args.sampler)
        errors.append(mse(r.mean, ref, ref_var))
        sq += ((r.mean.astype(np.float64) - ref64) ** 2).mean(axis=-1)
    sq /= args.seeds
    e = np.array(errors)
    pixels = sq.size
    print(f"{args.scene}: {args.seeds} renders of {args.spp} spp, sampler {r.sampler}; reference: {how}")
    print(f"MSE {e.mean():.4g} +- {e.std(ddof=1) / np.sqrt(len(e)):.2g} (median {np.median(e):.4g})")
    for q, n in shares(sq).items():
        print(f"  {q:.0%} of the squared error in {n} of {pixels} pixels ({n / pixels:.3%})")
    dev_r = render(cs, spp=args.deviation_spp, seed=7, sampler="independent")
    dev = np.sqrt(np.nan_to_num(dev_r.variance.astype(np.float64) * dev_r.spp).mean(axis=-1))
    print(f"oracle adaptive sampling (deviations from {args.deviation_spp} spp): "
          f"{oracle_gain(dev):.3g}x lower MSE at equal samples")
    order = np.argsort(sq.ravel())[::-1][:args.top]
    rows, cols = np.unravel_index(order, sq.shape)
    print("largest errors: (row, col)  share  reference  per-sample deviation")
    for i, j in zip(rows, cols):
        print(f"  ({i:4d}, {j:4d})  {sq[i, j] / sq.sum():6.2%}  {ref64[i, j].mean():9.4g}  {dev[i, j]:9.4g}")


if __name__ == "__main__":
    main()
