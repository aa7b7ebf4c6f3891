"""Render a Mitsuba XML scene with Mitsuba 3 for a reference image with per-pixel standard errors.

    /work/mitsuba-venv/bin/python bench/mitsuba_reference.py SCENE.xml OUT.npz PASSES SPP

runs PASSES independent renders (``scalar_rgb``, seeds 1000, 1001, ...) of SPP
samples per pixel each and stores their mean and the standard error of the
mean per pixel and channel (float32 ``mean``, ``stderr``; ``passes``,
``spp_per_pass``).  It needs a Python with ``mitsuba`` installed; mcocl's
tests only read its output (tests/data/README.md).
"""

from __future__ import annotations

import sys
import time

import numpy as np


def main(argv: list[str]) -> int:
    """Render argv = [scene, out, passes, spp]; print the time and the mean relative standard error."""
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    scene = mi.load_file(argv[0])
    passes, spp = int(argv[2]), int(argv[3])
    t = time.time()
    imgs = np.stack([np.array(mi.render(scene, spp=spp, seed=1000 + k), dtype=np.float64)[..., :3]
                     for k in range(passes)])
    mean = imgs.mean(axis=0)
    stderr = imgs.std(axis=0, ddof=1) / np.sqrt(passes)
    np.savez_compressed(argv[1], mean=mean.astype(np.float32), stderr=stderr.astype(np.float32), passes=passes,
                        spp_per_pass=spp)
    print(f"{time.time() - t:.1f} s; mean {mean.mean():.5f}, relative stderr {stderr.mean() / mean.mean():.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
