"""Render a reference image with Mitsuba 3 (scalar_rgb): the mean over independent seeds and its standard error.

Usage (with Mitsuba 3 installed, e.g. /work/mitsuba-venv):

    python tests/data/make_mitsuba_reference.py tests/data/envmap_scene.xml tests/data/envmap_scene_mitsuba.npz 64 256

renders the scene RUNS times with SPP samples per pixel and seeds 1000, 1001, ...
and writes a NumPy .npz with ``mean`` (H, W, 3) and ``stderr`` (H, W, 3, the
standard error of the mean over the runs), float32, and ``source`` (a string
saying how it was made).
"""

from __future__ import annotations

import sys

import mitsuba as mi
import numpy as np


def main(scene_file: str, out: str, runs: int, spp: int) -> None:
    mi.set_variant("scalar_rgb")
    scene = mi.load_file(scene_file)
    imgs = np.stack([np.array(mi.render(scene, spp=spp, seed=1000 + s), np.float64)[..., :3] for s in range(runs)])
    np.savez_compressed(out, mean=imgs.mean(axis=0).astype(np.float32),
                        stderr=(imgs.std(axis=0, ddof=1) / np.sqrt(runs)).astype(np.float32),
                        source=f"Mitsuba {mi.__version__} scalar_rgb, {runs} runs x {spp} spp, seeds 1000..{999 + runs}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
