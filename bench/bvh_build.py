"""Time the binned-SAH BVH build (mcocl/render/bvh.py) for about 10^6 triangles.

    python bench/bvh_build.py              # 10^6 triangles, terrain and soup
    python bench/bvh_build.py --n 200000 --repeat 3 --trace --all-axes

Two inputs: a height-field terrain (a connected mesh: many thin, adjacent
triangles, like scanned or modelled geometry) and a soup of random small
triangles in a cube.  Reports wall time of ``build_bvh`` (best of
``--repeat``), the tree's size and depth, and its SAH cost.  With
``--trace`` it also times closest-hit traversal of random rays through the
built tree on the default OpenCL device (rays/s, single run, after the
kernel build).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from mcocl.render.bvh import C_TRAV, build_bvh


def terrain(n_tris: int, seed: int = 0) -> np.ndarray:
    """A k×k height field as 2(k−1)² triangles (n_tris rounded), (T, 3, 3)."""
    k = int(np.sqrt(n_tris / 2)) + 1
    rng = np.random.default_rng(seed)
    x, z = np.meshgrid(np.linspace(-1, 1, k), np.linspace(-1, 1, k))
    y = 0.1 * np.sin(7 * x) * np.cos(5 * z) + 0.01 * rng.normal(size=x.shape)
    v = np.stack([x, y, z], -1).reshape(-1, 3)
    i = np.arange(k * k).reshape(k, k)[:-1, :-1].ravel()
    f = np.concatenate([np.stack([i, i + k, i + 1], 1), np.stack([i + 1, i + k, i + k + 1], 1)])
    return v[f]


def soup(n_tris: int, seed: int = 0) -> np.ndarray:
    """Random small triangles in [-1, 1]^3, (T, 3, 3)."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1, 1, (n_tris, 1, 3))
    return c + rng.normal(0, 0.01, (n_tris, 3, 3))


def sah_cost(bvh) -> float:
    """SAH cost of the flattened tree: Σ over nodes of (area/root area)·C_trav + Σ leaves area·count."""
    u = bvh.nodes.view(np.uint32)[1:].reshape(-1, 2, 2, 4)
    lo, hi = bvh.nodes[1:].reshape(-1, 2, 2, 4)[:, :, 0, :3], bvh.nodes[1:].reshape(-1, 2, 2, 4)[:, :, 1, :3]
    d = np.maximum(hi - lo, 0).astype(np.float64)
    area = 2 * (d[..., 0] * d[..., 1] + d[..., 1] * d[..., 2] + d[..., 2] * d[..., 0])
    cnt = u[:, :, 1, 3]
    root = bvh.bounds[1] - bvh.bounds[0]
    ra = 2 * (root[0] * root[1] + root[1] * root[2] + root[2] * root[0])
    internal = cnt == 0
    return float(C_TRAV * (1 + area[internal].sum() / ra) + (area * cnt).sum() / ra)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="triangles (default 10^6)")
    ap.add_argument("--repeat", type=int, default=1, help="builds per input; the best time is reported")
    ap.add_argument("--trace", action="store_true", help="also time kernel traversal of 10^6 random rays")
    ap.add_argument("--all-axes", action="store_true", help="bin all three axes (build_bvh(all_axes=True))")
    args = ap.parse_args()
    print(f"# numpy {np.__version__}, {os.cpu_count()} CPUs, loadavg {os.getloadavg()[0]:.2f}")
    for name, make in (("terrain", terrain), ("soup", soup)):
        tris = make(args.n).astype(np.float32)
        lo, hi = tris.min(axis=1), tris.max(axis=1)
        best = best_cpu = np.inf
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            bvh = build_bvh(lo, hi, all_axes=args.all_axes)
            best = min(best, time.perf_counter() - t0)
            best_cpu = min(best_cpu, time.process_time() - c0)
        print(f"{name:8s} {len(tris):>9d} triangles: build {best:6.2f} s wall, {best_cpu:6.2f} s cpu "
              f"({len(tris) / best / 1e6:.2f} M tris/s), "
              f"{bvh.num_nodes} nodes, {bvh.num_leaves} leaves ({len(tris) / bvh.num_leaves:.2f} tris/leaf), "
              f"depth {bvh.depth}, SAH cost {sah_cost(bvh):.1f}")
        if args.trace:
            trace(tris, all_axes=args.all_axes)


def trace(tris: np.ndarray, nrays: int = 1_000_000, all_axes: bool = False) -> None:
    """Closest-hit traversal speed through a mesh of these triangles (rays from outside towards it)."""
    from mcocl.render.compiled import compile_scene
    from mcocl.render.raycast import MISS, cast_rays
    from mcocl.render.scene import parse_scene

    scene = {"camera": {"origin": [0, 0, 5], "target": [0, 0, 0], "fov": 40, "width": 1, "height": 1},
             "materials": {"m": {"type": "diffuse", "reflectance": 0.5}}, "shapes": []}
    cs = compile_scene(parse_scene(scene, "bench"))
    # Swap the (empty) geometry for the triangles: same contract arrays, built by compile_scene's BVH code.
    from mcocl.render.bvh import build_bvh as bb

    tv = np.zeros((len(tris), 3, 4), np.float32)
    tv[:, :, :3] = tris
    b = bb(tris.min(1), tris.max(1), all_axes=all_axes)
    cs.tri_vertices, cs.bvh_nodes, cs.bvh_prims = tv, b.nodes, b.prims
    rng = np.random.default_rng(1)
    o = rng.normal(size=(nrays, 3))
    o = (3 * o / np.linalg.norm(o, axis=1, keepdims=True)).astype(np.float32)
    d = (rng.uniform(-0.8, 0.8, (nrays, 3)) - o).astype(np.float32)
    cast_rays(cs, o[:1000], d[:1000])  # build the kernel, upload the scene
    t0 = time.perf_counter()
    h = cast_rays(cs, o, d, any_hit=False)
    dt = time.perf_counter() - t0
    print(f"         traversal: {nrays / dt / 1e6:.2f} M rays/s closest hit ({(h.prim != MISS).mean():.0%} hit)")


if __name__ == "__main__":
    main()
