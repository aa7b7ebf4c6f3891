"""Make the Mitsuba 3 reference image of tests/data/mitsuba/ (see tests/data/README.md).

Run with Mitsuba 3.9.1's Python (the scalar_rgb variant needs nothing else):

    /work/mitsuba-venv/bin/python tests/data/mitsuba/make_reference.py

Writes smooth_sphere.ply (a latitude-longitude unit sphere with its exact
vertex normals, binary PLY) and renders smooth_gaussian.xml PASSES times with
seeds 0.. PASSES-1 at SPP samples per pixel each.  smooth_gaussian.npz holds
the mean image, the per-pixel standard error of the mean over the passes and
the standard error of each 8 x 8 block's mean, also over the passes (Mitsuba's
Gaussian filter splats a sample into neighbouring pixels, so its pixels are
correlated and a block's error is not the pixels' errors added in quadrature).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
PASSES, SPP, BLOCK = 32, 512, 8


def sphere_mesh(rings: int = 16, segments: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """A unit latitude-longitude sphere: vertices and outward-wound triangles."""
    theta = np.linspace(0.0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    v = np.concatenate([[[0.0, 1.0, 0.0]], ring, [[0.0, -1.0, 0.0]]])
    at = lambda r, s: 1 + r * segments + s % segments  # noqa: E731
    f = []
    for s in range(segments):
        f += [[0, at(0, s), at(0, s + 1)], [len(v) - 1, at(rings - 2, s + 1), at(rings - 2, s)]]
        for r in range(rings - 2):
            f += [[at(r, s), at(r + 1, s), at(r + 1, s + 1)], [at(r, s), at(r + 1, s + 1), at(r, s + 1)]]
    f = np.array(f)
    tri = v[f]
    inward = np.einsum("ij,ij->i", np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), tri.mean(1)) < 0
    f[inward] = f[inward][:, [0, 2, 1]]
    return v, f


def write_ply(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    """Binary little-endian PLY with x, y, z, nx, ny, nz (the normals are the positions: a unit sphere)."""
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    verts = np.concatenate([v, v], axis=1).astype("<f4").tobytes()
    faces = np.zeros(len(f), [("n", "u1"), ("i", "<i4", 3)])
    faces["n"], faces["i"] = 3, f
    path.write_bytes(head + verts + faces.tobytes())


def main() -> None:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    v, f = sphere_mesh()
    write_ply(HERE / "smooth_sphere.ply", v, f)
    scene = mi.load_file(str(HERE / "smooth_gaussian.xml"))
    passes = np.stack([np.array(mi.render(scene, seed=k, spp=SPP))[..., :3] for k in range(PASSES)])
    h, w = passes.shape[1:3]
    blocks = passes.reshape(PASSES, h // BLOCK, BLOCK, w // BLOCK, BLOCK, 3).mean((2, 4))
    np.savez_compressed(
        HERE / "smooth_gaussian.npz", mean=passes.mean(0).astype(np.float32),
        stderr=(passes.std(0, ddof=1) / np.sqrt(PASSES)).astype(np.float32),
        block_stderr=(blocks.std(0, ddof=1) / np.sqrt(PASSES)).astype(np.float32),
        passes=np.int64(PASSES), spp=np.int64(SPP), mitsuba=np.str_(mi.__version__))
    print(f"mitsuba {mi.__version__}: {PASSES} x {SPP} spp, mean {passes.mean():.5f}", file=sys.stderr)


if __name__ == "__main__":
    main()
