"""Efficiency of ``bdpt`` and ``lt`` against ``mis`` (issue 11's performance targets).

Efficiency = 1 / (MSE x CPU-seconds): the MSE per pixel and channel against
one long ``bdpt`` reference per scene, rendered in the same process with
another seed (its own mean variance, which the splat film reports from
independent batches, is subtracted from the MSE), and the process's CPU time
of the render (PoCL's worker threads included), since the machine this runs
on is shared and wall time depends on the other users.  Each integrator
renders for ``--budget`` wall seconds, ``--runs`` times with different seeds,
after a warm-up render that builds its kernel.

Scenes: ``caustic`` (scenes/caustic.json), ``cornell`` (scenes/cornell.json)
and ``cornell_spheres`` (the Cornell box with a mirror and a glass sphere,
bench/render_throughput.py's), each at ``--size`` pixels wide.  ``lt``
cannot see a mirror or glass seen directly through a pinhole
(kernels/render/lt.cl): its MSE is taken over the pixels that a long ``lt``
reference does not leave exactly black where the ``bdpt`` reference is not
(the other integrators' MSE over all pixels, and over those pixels too).

A second efficiency, 1 / (mean reported variance x CPU-seconds), takes the
render's own variance of the mean (per sample for ``mis``, from independent
batches for ``lt`` and ``bdpt``) instead of the MSE: it needs no reference,
so it is far less noisy than the MSE of a short render against a reference
whose own variance is of the same order (heavy-tailed caustic pixels); it
assumes the integrators unbiased, which tests/test_render_bdpt.py checks
(not so ``lt`` in the pixels it cannot see, where it reports no variance:
its figure is an upper bound).
``bdpt-exact`` is ``bdpt`` with ``roulette=False`` (every connection's
shadow ray traced).

Reading the ratios: in a pixel that sees a caustic through glass or in a
mirror (a specular-diffuse-specular path), only the camera subpath hitting
the emitter (s = 0) samples the path, as in ``mis``, so there ``bdpt`` is
``mis`` at a higher cost per path; such pixels bound its whole-image ratio.
On ``cornell_spheres`` ``bdpt``'s variance per sample is a sixth of
``mis``'s (128 px, 256 spp, sobol: summed over the pixels 0.85 against 4.99),
at 3.4x the CPU time per path; two thirds of it lie in the 7.5 % of pixels
that see the spheres, camera-only paths where both are alike (the caustic
under the glass ball, a third before the specular chains' MIS densities of
kernels/render/bdpt.cl, now 3 %).  ``caustic`` keeps its caustic out of the glass's view (the lamp
stands behind the ball; until December 2026 the camera saw the caustic
through the ball, and those pixels held 99 % of ``bdpt``'s variance).  What
bounded ``bdpt`` next was the lamp's reflection in the ball, a highlight
smaller than a pixel (camera, glass, lamp): at 1024 spp and 128 px the 20
pixels of largest variance held 98 % of ``bdpt``'s variance and half of
``mis``'s, a Fresnel coin flip times the pixel's coverage.  ``bdpt`` now
counts both branches of glass seen directly (kernels/render/bdpt.cl,
"Splitting at the first camera vertex"): at 512 spp its summed per-pixel
variance fell from 39.5 to 3.7, of which paths of at most 2 segments hold
0.83 (36.7 before) and paths of 5 and 6 segments most of the rest (the
caustic seen through the ball that the lamp's position still lets in,
which only s = 0 samples).

    PYTHONPATH=. python bench/bdpt_efficiency.py --scenes caustic cornell cornell_spheres \\
        --budget 10 --ref-budget 120
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mcocl.render.api import render
from mcocl.render.scene_file import load_scene

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
from render_throughput import cornell_spheres  # noqa: E402

INTEGRATORS = ("mis", "mis-independent", "lt", "bdpt", "bdpt-independent", "bdpt-sobol", "bdpt-exact")
# What each name renders: bdpt-exact is bdpt without its Russian roulette on connection shadow rays.
# mis and bdpt are the default sampler's (auto: sobol under a time budget), mis-independent and
# bdpt-independent the independent sampler's, bdpt-sobol the sobol sampler's whatever auto picks.
RENDER_KWARGS = {"mis": {"integrator": "mis"}, "mis-independent": {"integrator": "mis", "sampler": "independent"},
                 "lt": {"integrator": "lt"}, "bdpt": {"integrator": "bdpt"},
                 "bdpt-independent": {"integrator": "bdpt", "sampler": "independent"},
                 "bdpt-sobol": {"integrator": "bdpt", "sampler": "sobol"},
                 "bdpt-exact": {"integrator": "bdpt", "roulette": False}}


def cpu_seconds() -> float:
    """User plus system CPU time of this process, its OpenCL worker threads included."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def scene_at(name: str, width: int, folder: Path):
    """Scene ``name`` with its camera ``width`` pixels wide (the aspect ratio kept)."""
    path = cornell_spheres(folder) if name == "cornell_spheres" else ROOT / "scenes" / f"{name}.json"
    scene = load_scene(path)
    cam = scene.camera
    scene.camera = dataclasses.replace(cam, width=width, height=max(1, round(width * cam.height / cam.width)))
    return scene


def timed(scene, integrator: str, seed: int, budget: float):
    """Render for ``budget`` wall seconds; the result, its CPU seconds and wall seconds."""
    c0, t0 = cpu_seconds(), time.perf_counter()
    r = render(scene, time_budget=budget, seed=seed, **RENDER_KWARGS[integrator])
    return r, cpu_seconds() - c0, time.perf_counter() - t0


def main() -> None:
    """Print, per scene and integrator, paths per second, MSE and efficiency, and the ratios to ``mis``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["caustic", "cornell", "cornell_spheres"])
    ap.add_argument("--integrators", nargs="+", default=["mis", "lt", "bdpt"], choices=INTEGRATORS)
    ap.add_argument("--size", type=int, default=128, help="image width in pixels")
    ap.add_argument("--budget", type=float, default=10.0, help="wall seconds of each timed render")
    ap.add_argument("--ref-budget", type=float, default=120.0, help="wall seconds of the bdpt reference")
    ap.add_argument("--runs", type=int, default=2, help="timed renders per integrator (seeds 1..runs)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes:
            scene = scene_at(name, args.size, Path(tmp))
            npix = scene.camera.width * scene.camera.height
            ref = render(scene, time_budget=args.ref_budget, integrator="bdpt", seed=1000)
            ref_mean = ref.mean.astype(np.float64)
            ref_var = ref.variance.astype(np.float64)
            print(f"== {name} {scene.camera.width}x{scene.camera.height}: bdpt reference {ref.spp} spp in "
                  f"{ref.seconds:.0f} s, mean {ref_mean.mean():.4g}, mean variance {ref_var.mean():.3g}", flush=True)
            seen = np.ones(ref_mean.shape[:2], bool)
            if "lt" in args.integrators:
                lt_ref = render(scene, time_budget=args.ref_budget / 4, integrator="lt", seed=1001)
                blind = (lt_ref.mean.reshape(npix, 3) == 0).all(axis=1) & (ref_mean.reshape(npix, 3) > 0).any(axis=1)
                seen = ~blind.reshape(seen.shape)
                print(f"   pixels lt cannot see (black in a long lt render, not in the reference): {blind.sum()}")
            eff_all, eff_seen, eff_var = {}, {}, {}
            for integrator in args.integrators:
                render(scene, spp=1, seed=0, **RENDER_KWARGS[integrator])  # builds the kernel
                rows = []
                for seed in range(1, args.runs + 1):
                    r, cpu, wall = timed(scene, integrator, seed, args.budget)
                    err = (r.mean.astype(np.float64) - ref_mean) ** 2 - ref_var
                    rows.append((r.spp, cpu, wall, float(err.mean()), float(err[seen].mean()),
                                 float(r.variance.astype(np.float64).mean())))
                spp, cpu, wall, mse, mse_seen, var = (float(np.mean(c)) for c in zip(*rows, strict=True))
                eff_all[integrator] = 1.0 / (mse * cpu)
                eff_seen[integrator] = 1.0 / (mse_seen * cpu)
                eff_var[integrator] = 1.0 / (var * cpu)
                print(f"   {integrator:10s} {spp:7.0f} spp  {spp * npix / cpu / 1e6:6.3f} M paths/cpu-s  "
                      f"{spp * npix / wall / 1e6:6.3f} M paths/s  cpu {cpu:5.1f} s  MSE {mse:.4g}  "
                      f"(seen by lt {mse_seen:.4g})  efficiency {eff_all[integrator]:.4g}  "
                      f"(from its own variance {eff_var[integrator]:.4g})", flush=True)
            for base in (b for b in ("mis", "mis-independent") if b in eff_all):
                for integrator in args.integrators:
                    if not integrator.startswith("mis"):
                        print(f"   {integrator} / {base} efficiency: {eff_all[integrator] / eff_all[base]:.2f}  "
                              f"(pixels lt sees: {eff_seen[integrator] / eff_seen[base]:.2f}; from the own "
                              f"variances: {eff_var[integrator] / eff_var[base]:.2f})", flush=True)


if __name__ == "__main__":
    main()
