"""CPU time per sample of the render samplers ``independent`` and ``sobol``, A/B in one process.

Both samplers render the same scene with the same integrator and the same
blocks (``spp_per_block``), so the difference is the cost of drawing the
sample coordinates (kernels/samplers/sobol_sampler.cl against
kernels/samplers/philox_sampler.cl); repeats alternate between the two so that
a load change on the shared machine hits both.  CPU seconds are the process's
(PoCL's threads included), read around each render; the build is warmed up
first.

    PYTHONPATH=. python bench/render_sobol_cost.py --scene cornell --size 64 --spp 64 --repeats 5
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import statistics
import time
from pathlib import Path

from mcocl.render.api import render
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
SAMPLERS = ("independent", "sobol")


def cpu_seconds() -> float:
    """User + system CPU seconds of this process so far, every thread included."""
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def scene_at(name: str, size: int):
    """scenes/<name>.json with its width set to ``size`` pixels (aspect kept)."""
    scene = load_scene(str(SCENES / f"{name}.json"))
    cam = scene.camera
    height = max(1, round(size * cam.height / cam.width))
    scene.camera = dataclasses.replace(cam, width=size, height=height)
    return scene


def timed_render(scene, sampler: str, args: argparse.Namespace) -> tuple[float, float]:
    """(CPU seconds, wall seconds) of one render."""
    c0, w0 = cpu_seconds(), time.perf_counter()
    render(scene, spp=args.spp, seed=args.seed, sampler=sampler, integrator=args.integrator,
           spp_per_block=args.spp_per_block or None, lanes=args.lanes)
    return cpu_seconds() - c0, time.perf_counter() - w0


def main() -> None:
    """Print per-sample CPU and wall times of both samplers and their ratio (medians of the repeats)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="cornell", help="a scene of scenes/, without .json")
    ap.add_argument("--integrator", default="mis", choices=("path", "nee", "mis"))
    ap.add_argument("--size", type=int, default=64, help="image width in pixels")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--spp-per-block", type=int, default=16, help="the same for both samplers (a power of two); 0: each sampler's default")
    ap.add_argument("--lanes", type=int, default=None)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    scene = scene_at(args.scene, args.size)
    samples = args.spp * scene.camera.width * scene.camera.height
    for sampler in SAMPLERS:  # the first launch compiles
        render(scene, spp=args.spp_per_block or 1, seed=0, sampler=sampler, integrator=args.integrator,
               spp_per_block=args.spp_per_block or None, lanes=args.lanes)
    cpu: dict[str, list[float]] = {s: [] for s in SAMPLERS}
    wall: dict[str, list[float]] = {s: [] for s in SAMPLERS}
    for rep in range(args.repeats):
        for sampler in SAMPLERS if rep % 2 == 0 else SAMPLERS[::-1]:
            c, w = timed_render(scene, sampler, args)
            cpu[sampler].append(c)
            wall[sampler].append(w)
    print(f"{args.scene} {scene.camera.width}x{scene.camera.height} {args.integrator}, {args.spp} spp "
          f"(blocks of {args.spp_per_block}), {args.repeats} interleaved repeats, medians:")
    for sampler in SAMPLERS:
        c, w = statistics.median(cpu[sampler]), statistics.median(wall[sampler])
        print(f"  {sampler:12s} {c:7.3f} cpu-s  {w:7.3f} s  {1e9 * c / samples:7.1f} cpu-ns/sample  "
              f"(cpu-s: {' '.join(f'{x:.3f}' for x in cpu[sampler])})")
    ratio = statistics.median(cpu["sobol"]) / statistics.median(cpu["independent"])
    print(f"  sobol / independent CPU time: {ratio:.3f}")


if __name__ == "__main__":
    main()
