"""Whole-image means of two render settings over many seeds, in units of the spread over seeds.

Why the spread and not the reported variance: a splat film's per-pixel variances are honest pixel by
pixel, but their sum over pixels is not the variance of the image's mean.  Where one light subpath
lands is a choice among pixels (a multinomial), so the pixels of one sample are negatively
correlated, and the summed per-pixel variance over-states the whole image's by 2x to 9x for bdpt and
lt on the Cornell box (measured; mis, whose pixels are independent, 1.0x).  The spread of the
per-seed image means is an independent, honest standard error.

A path length k alone: ``--length k`` renders both settings at max_depth k and k - 1 with the same
seeds and takes the per-seed differences (the walks draw the same numbers for the same vertices, so
for mis and for bdpt without its connection roulette the difference is exactly the length-k part).

    PYTHONPATH=. python bench/bdpt_mean_agreement.py --size 32 --seeds 64 --thin-lens \\
        "integrator=mis spp=8192" "integrator=bdpt spp=2048 sampler=independent"
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
_INT_KEYS = ("spp", "max_depth", "rr_depth", "spp_per_block")
_BOOL_KEYS = ("roulette", "unweighted")


def parse_setting(text: str) -> dict:
    """'integrator=bdpt spp=1024 strategy=2,3 unweighted=1' -> render() keyword arguments."""
    kw: dict = {}
    for item in text.split():
        key, _, value = item.partition("=")
        if key in _INT_KEYS:
            kw[key] = int(value)
        elif key in _BOOL_KEYS:
            kw[key] = bool(int(value))
        elif key == "strategy":
            s, t = value.split(",")
            kw[key] = (int(s), int(t))
        else:
            kw[key] = value
    return kw


def image_means(scene, seeds: range, kw: dict, length: int | None) -> np.ndarray:
    """Per-seed image means (seeds x 3); of path length `length` alone when given."""
    out = []
    for seed in seeds:
        if length is None:
            m = render(scene, seed=seed, **kw).mean
        else:
            m = (render(scene, seed=seed, max_depth=length, **kw).mean.astype(np.float64)
                 - render(scene, seed=seed, max_depth=length - 1, **kw).mean)
        out.append(np.asarray(m, dtype=np.float64).reshape(-1, 3).mean(axis=0))
    return np.array(out)


def main() -> None:
    """Print each setting's mean and every later setting's relative difference and z against the first."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("settings", nargs="+", help="render settings, the first the reference")
    ap.add_argument("--scene", default="cornell.json")
    ap.add_argument("--size", type=int, default=32)
    ap.add_argument("--seeds", type=int, default=32)
    ap.add_argument("--seed0", type=int, default=1000)
    ap.add_argument("--thin-lens", action="store_true", help="aperture radius 0.15, focused at 2.5")
    ap.add_argument("--length", type=int, default=None, help="path length k alone (max_depth k minus k - 1)")
    a = ap.parse_args()
    sc = load_scene(SCENES / a.scene)
    sc.camera.width = sc.camera.height = a.size
    if a.thin_lens:
        sc.camera.aperture_radius, sc.camera.focus_distance = 0.15, 2.5
    scene = compile_scene(sc)
    seeds = range(a.seed0, a.seed0 + a.seeds)
    runs = [image_means(scene, seeds, parse_setting(s), a.length) for s in a.settings]
    ref = runs[0]
    print(f"{a.settings[0]}: mean {ref.mean(axis=0)}")
    for text, x in zip(a.settings[1:], runs[1:]):
        d = x.mean(axis=0) - ref.mean(axis=0)
        se = np.sqrt(ref.var(axis=0, ddof=1) / len(ref) + x.var(axis=0, ddof=1) / len(x))
        print(f"{text}: mean {x.mean(axis=0)} relative difference {d / ref.mean(axis=0)} z {d / se}")


if __name__ == "__main__":
    main()
