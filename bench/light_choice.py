"""Measure the light choice: the environment's share and the light samplers (issue 14, part 3).

Efficiency of a render = 1 / (noise x seconds), with noise the mean (and the
median) over pixels and channels of the variance of the pixel mean that the
renderer reports (its per-pixel sample variance / spp: the mean is an
unbiased estimate of the image's MSE, so no reference image is needed) and
seconds the sampling time (build excluded; one warm-up render first).  Every configuration renders the
same scene with the same spp and seed; relative efficiencies are printed
against the first row of each table.

- ``env``: the environment's share of light samples under the old
  bounding-sphere power rule, a fixed 1/2, 1/(emissive shapes + 1)
  (Mitsuba 3's uniform choice per emitter), 1/8, 1/32 and 0 (``mis``), on the big-mesh scene
  (bench/make_big_scene.py, small mesh) and the many-light scene under a
  dim and a bright sky.
- ``samplers``: ``power``, ``uniform`` and ``bvh`` on the shipped scenes.

``--cpu`` times in CPU seconds of the process (the device's threads
included) instead of the render's wall seconds: steadier on a shared machine.

Usage: python bench/light_choice.py [env|samplers|all] [--spp N] [--size W] [--cpu]
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import tempfile
from pathlib import Path

import numpy as np

from mcocl.render.api import render
from mcocl.render.compiled import CompiledScene, compile_scene
from mcocl.render.emitter_choice import LUMINANCE
from mcocl.render.scene_file import load_scene

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"


def _scene(path: Path, width: int, sky: float | None = None) -> CompiledScene:
    sc = load_scene(path)
    h = max(8, round(width * sc.camera.height / sc.camera.width))
    sc.camera.width, sc.camera.height = width, h
    if sky is not None:
        sc.env_radiance = np.full(3, sky)
    return compile_scene(sc)


def _set_env_share(cs: CompiledScene, share: float) -> CompiledScene:
    """Override the environment's share (the compiled scene keeps it exact on the uniforms' grid)."""
    cs.env_share = share
    cs.buffer_cache.clear()
    return cs


def _old_bbox_share(cs: CompiledScene) -> float:
    """The rule before issue 14: environment power pi L 4 pi R^2 (R: bounding-sphere radius) against the lights'."""
    radius = 0.5 * float(np.linalg.norm(cs.bounds[1].astype(np.float64) - cs.bounds[0]))
    p_env = math.pi * float(cs.env_radiance[:3].astype(np.float64) @ LUMINANCE) * 4 * math.pi * radius**2
    return p_env / (p_env + float(cs.light_power.sum()))


CPU_TIME = False  # --cpu: _measure reports CPU seconds


def _cpu_seconds() -> float:
    """CPU seconds of this process and its threads."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _measure(cs: CompiledScene, spp: int, seed: int = 3) -> tuple[float, float, float]:
    """Mean and median over pixels and channels of the variance of the pixel mean, and the seconds."""
    t = _cpu_seconds()
    r = render(cs, spp=spp, seed=seed)
    cpu = _cpu_seconds() - t
    v = r.variance.astype(np.float64)
    return float(np.mean(v)), float(np.median(v)), cpu if CPU_TIME else r.seconds


def _table(title: str, rows: list[tuple[str, float, float, float]]) -> None:
    """Noise and efficiency relative to the first row; by the mean and by the median pixel variance.

    The mean is what an MSE measures, but on scenes whose small emitters are
    seen directly it is dominated by the pixels those emitters partly cover
    (camera-jitter noise that no light sampler changes: on many_lights.json
    0.0145 of 0.0182 at max depth 2); the median shows the light sampling.
    """
    print(f"\n{title}")
    print(f"{'configuration':<30} {'mean var':>10} {'median var':>10} {'seconds':>8} {'rel. noise':>10} "
          f"{'rel. eff.':>9} {'rel. noise (med)':>16} {'rel. eff. (med)':>15}")
    v0, m0, s0 = rows[0][1:]
    for name, v, m, s in rows:
        print(f"{name:<30} {v:>10.3e} {m:>10.3e} {s:>8.2f} {v0 / v:>10.2f} {(v0 * s0) / (v * s):>9.2f} "
              f"{m0 / m:>16.2f} {(m0 * s0) / (m * s):>15.2f}")


def _big_scene_file(triangles: int = 50_000) -> Path:
    """bench/make_big_scene.py's scene with a smaller mesh, in a temporary folder."""
    from make_big_scene import big_scene, displaced_sphere, write_obj

    tmp = Path(tempfile.mkdtemp())
    verts, faces = displaced_sphere(triangles)
    write_obj(tmp / "sphere.obj", verts, faces)
    (tmp / "big.json").write_text(json.dumps(big_scene("sphere.obj")))
    return tmp / "big.json"


def env_shares(spp: int, width: int) -> None:
    """The environment's share on scenes with a sky."""

    for title, path, sky in (("big-mesh scene (5e4 triangles), sky 0.05", _big_scene_file(), None),
                             ("many_lights.json under a sky of 0.2", SCENES / "many_lights.json", 0.2),
                             ("many_lights.json under a sky of 2", SCENES / "many_lights.json", 2.0)):
        base = _scene(path, width, sky)
        _measure(base, 1)  # warm-up: the build
        shapes = len({int(s) for s in base.prim_shape[base.light_prims]})
        rules = [("old: bounding-sphere power", _old_bbox_share(base)), ("fixed 1/2", 0.5),
                 (f"1/(shapes+1) = 1/{shapes + 1}", 1.0 / (shapes + 1)), ("1/8", 0.125), ("1/32", 1 / 32),
                 ("0 (the mis rule)", 0.0)]
        rows = []
        for name, share in rules:
            rows.append((f"{name} ({share:.3f})", *_measure(_set_env_share(base, share), spp)))
        _table(f"environment share: {title}, {width} px wide, {spp} spp", rows)


def samplers(spp: int, width: int, scenes: list[str]) -> None:
    """power, uniform and bvh on the shipped scenes (and the big-mesh scene, 'big')."""
    for name in scenes:
        path = _big_scene_file() if name == "big" else SCENES / name
        rows = []
        for ls in ("power", "uniform", "bvh"):
            cs = _scene(path, width).with_settings(light_sampler=ls)
            _measure(cs, 1)
            rows.append((ls, *_measure(cs, spp)))
        _table(f"light samplers: {name}, {width} px wide, {spp} spp", rows)


def main() -> int:
    """Run the chosen measurements."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", nargs="?", default="all", choices=("env", "samplers", "all"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=96, help="image width in pixels")
    ap.add_argument("--cpu", action="store_true", help="time in CPU seconds, not the render's wall seconds")
    ap.add_argument("--scenes", default="many_lights.json,veach_mis.json,cornell.json,big",
                    help="samplers: comma-separated shipped scenes, 'big' for the big-mesh scene")
    a = ap.parse_args()
    global CPU_TIME
    CPU_TIME = a.cpu
    if a.what in ("env", "all"):
        env_shares(a.spp, a.size)
    if a.what in ("samplers", "all"):
        samplers(a.spp, a.size, a.scenes.split(","))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
