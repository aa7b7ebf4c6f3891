"""Time loading a big mesh: OBJ reading, the BVH build, and the device scene's size per triangle.

    python bench/bvh_build.py                         # 10^5 and 10^6 triangles
    python bench/bvh_build.py --n 200000 --repeat 3 --trace
    python bench/bvh_build.py --compare               # also the binned-SAH builds (slow) and SAH ratios

Two inputs: a height-field terrain (a connected mesh: many thin, adjacent
triangles, like scanned or modelled geometry) and a soup of random small
triangles in a cube.  For each size it reports:

- ``obj``: the terrain written as an OBJ file, read by
  :func:`mcocl.render.shapes.read_obj` (wall and CPU seconds), and the whole
  scene load (read, transform, BVH, tables) of a scene file that uses it;
- ``build``: :func:`mcocl.render.bvh.build_bvh` (best of ``--repeat``), the
  tree's size and depth and its SAH cost (with ``--compare``, the ratio to
  the binned-SAH builder along the widest axis and along all three axes);
- ``device``: bytes per triangle of every array the render kernel reads
  (:func:`mcocl.render.job.scene_tables`) for the terrain scene.

Measured (2 shared cores, load 4.6-6.9, so CPU seconds are the figures to
compare; an idle machine's wall time is close to them), 10^6 triangles:
OBJ read 0.23-0.29 CPU-s (0.4-0.55 s wall); build 0.53-0.57 CPU-s
(terrain) and 0.64-0.76 (soup) against 1.86-1.90 / 1.99-2.11 for the binned
build along the widest axis and 3.38-3.58 / 4.08-4.35 along all three; SAH
cost ratio to those 0.925 / 1.014 and 1.154 / 1.034 (10^5: 1.028 / 1.034
and 1.091 / 1.056); 123 bytes per triangle in the kernel's buffers.
With ``--obj-attributes`` (a ``vt`` and a ``vn`` per vertex, corners
``i/i/i``: 104 MB instead of 38) the OBJ read takes 0.79-0.97 CPU-s, the
plain file 0.26-0.28 (0.28-0.30 before ``vt``/``vn`` were read); ``--obj-only``
skips the BVH builds.

With ``--trace`` it also times closest-hit traversal of random rays
through the built tree on the default OpenCL device (rays/s, single run,
after the kernel build); ``bench/trace_bench.py`` is the traversal benchmark
(more ray sets, any-hit, Embree on the same rays).  Timings are wall seconds of one process on a
machine that may be shared: compare CPU seconds when the load is high.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from mcocl.render.bvh import C_TRAV, build_bvh


def terrain_mesh(n_tris: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A k×k height field: vertices (k², 3) and 2(k−1)² faces (n_tris rounded)."""
    k = int(np.sqrt(n_tris / 2)) + 1
    rng = np.random.default_rng(seed)
    x, z = np.meshgrid(np.linspace(-1, 1, k), np.linspace(-1, 1, k))
    y = 0.1 * np.sin(7 * x) * np.cos(5 * z) + 0.01 * rng.normal(size=x.shape)
    v = np.stack([x, y, z], -1).reshape(-1, 3)
    i = np.arange(k * k).reshape(k, k)[:-1, :-1].ravel()
    f = np.concatenate([np.stack([i, i + k, i + 1], 1), np.stack([i + 1, i + k, i + k + 1], 1)])
    return v, f


def terrain(n_tris: int, seed: int = 0) -> np.ndarray:
    """The terrain's triangles, (T, 3, 3)."""
    v, f = terrain_mesh(n_tris, seed)
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


def timed(fn, repeat: int = 1):
    """(result, first run's wall seconds, best wall seconds, best CPU seconds) of ``fn()`` over ``repeat`` runs."""
    first = best = best_cpu = np.inf
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        wall = time.perf_counter() - t0
        first = wall if first == np.inf else first
        best = min(best, wall)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return out, first, best, best_cpu


def write_obj(path: Path, v: np.ndarray, f: np.ndarray, attributes: bool = False) -> None:
    """A plain OBJ file: ``v x y z`` lines, then ``f a b c`` lines (1-based).

    With ``attributes``, one ``vt`` (the x, z position mapped to [0, 1]²) and one
    ``vn`` (the height field's up direction, tilted by the height) per vertex
    follow the ``v`` lines, and the corners are ``i/i/i``.
    """
    text = ("v %.6f %.6f %.6f\n" * len(v)) % tuple(v.ravel())
    if attributes:
        uv = (v[:, [0, 2]] + 1.0) / 2.0
        n = np.stack([-v[:, 1], np.ones(len(v)), v[:, 1]], 1) / np.sqrt(1.0 + 2.0 * v[:, 1:2] ** 2)
        text += ("vt %.6f %.6f\n" * len(v)) % tuple(uv.ravel()) + ("vn %.6f %.6f %.6f\n" * len(v)) % tuple(n.ravel())
        text += ("f %d/%d/%d %d/%d/%d %d/%d/%d\n" * len(f)) % tuple(np.repeat(f + 1, 3).ravel())
    else:
        text += ("f %d %d %d\n" * len(f)) % tuple((f + 1).ravel())
    path.write_text(text)


def bench_obj(n: int, repeat: int, attributes: bool = False) -> None:
    """OBJ reading, whole scene load and device bytes per triangle of the terrain of about ``n`` triangles."""
    from mcocl.render.compiled import load_compiled
    from mcocl.render.job import KERNEL_BUFFERS, scene_tables
    from mcocl.render.shapes import read_obj

    v, f = terrain_mesh(n)
    with tempfile.TemporaryDirectory() as tmp:
        obj = Path(tmp) / "terrain.obj"
        write_obj(obj, v, f, attributes)
        scene = {"camera": {"origin": [0, 2, 3], "target": [0, 0, 0], "fov": 40, "width": 64, "height": 64},
                 "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
                 "shapes": [{"type": "mesh", "material": "m", "obj": "terrain.obj"}]}
        (Path(tmp) / "scene.json").write_text(json.dumps(scene))
        mesh, f_read, t_read, c_read = timed(lambda: read_obj(obj, "bench"), repeat)
        tris = mesh.faces
        cs, _, t_load, c_load = timed(lambda: load_compiled(Path(tmp) / "scene.json"), 1)
        size = obj.stat().st_size
    tables = scene_tables(cs)
    kernel_bytes = sum(tables[name].nbytes for name in KERNEL_BUFFERS if name in tables)
    all_bytes = sum(a.nbytes for a in tables.values())
    print(f"obj{'+vt/vn' if attributes else '':6s} {len(tris):>9d} triangles ({size / 1e6:.1f} MB): read {t_read:5.2f} s wall (first run "
          f"{f_read:5.2f}), {c_read:5.2f} s cpu; whole scene load {t_load:5.2f} s wall, {c_load:5.2f} s cpu")
    per = {name: tables[name].nbytes / len(tris) for name in KERNEL_BUFFERS
           if name in tables and tables[name].nbytes >= len(tris)}
    print(f"device   {kernel_bytes / len(tris):6.1f} bytes/triangle in the kernel's buffers "
          f"({all_bytes / len(tris):.1f} with every table): "
          + ", ".join(f"{k} {b:.1f}" for k, b in sorted(per.items(), key=lambda kv: -kv[1])))


def bench_build(name: str, tris: np.ndarray, args) -> None:
    """Build time and SAH cost of one input (and, with --compare, the binned builders' ratios)."""
    lo, hi = tris.min(axis=1), tris.max(axis=1)
    bvh, first, t, c = timed(lambda: build_bvh(lo, hi, method=args.method, all_axes=args.all_axes), args.repeat)
    cost = sah_cost(bvh)
    print(f"{name:8s} {len(tris):>9d} triangles: build {t:5.2f} s wall (first run {first:5.2f}), {c:5.2f} s cpu "
          f"({len(tris) / t / 1e6:.2f} M tris/s), "
          f"{bvh.num_nodes} nodes, {bvh.num_leaves} leaves ({len(tris) / bvh.num_leaves:.2f} tris/leaf), "
          f"depth {bvh.depth}, SAH cost {cost:.1f}")
    if args.compare:
        for all_axes in (False, True):
            ref, _, tr, cr = timed(lambda a=all_axes: build_bvh(lo, hi, method="binned", all_axes=a), 1)
            rc = sah_cost(ref)
            print(f"         binned ({'all axes' if all_axes else 'widest axis'}): build {tr:6.2f} s wall, "
                  f"{cr:6.2f} s cpu, SAH cost {rc:.1f}; {args.method}/binned SAH ratio {cost / rc:.3f}")
    if args.trace:
        trace(tris, bvh)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", default="100000,1000000", help="triangle counts, comma-separated (default 10^5,10^6)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per timing; the best is reported")
    ap.add_argument("--method", default="ploc", choices=("ploc", "binned"), help="build_bvh(method=...)")
    ap.add_argument("--all-axes", action="store_true", help="method binned: bin all three axes")
    ap.add_argument("--compare", action="store_true", help="also build with the binned builders (slow)")
    ap.add_argument("--trace", action="store_true", help="also time kernel traversal of 10^6 random rays")
    ap.add_argument("--no-obj", action="store_true", help="skip the OBJ and device-size measurements")
    ap.add_argument("--obj-attributes", action="store_true",
                    help="the OBJ file also has a vt and a vn per vertex, corners i/i/i")
    ap.add_argument("--obj-only", action="store_true", help="only the OBJ measurements (no BVH builds)")
    args = ap.parse_args()
    print(f"# numpy {np.__version__}, {os.cpu_count()} CPUs, loadavg {os.getloadavg()[0]:.2f}")
    for n in (int(float(x)) for x in args.n.split(",")):
        if not args.no_obj:
            bench_obj(n, args.repeat, args.obj_attributes)
        if args.obj_only:
            continue
        for name, make in (("terrain", terrain), ("soup", soup)):
            bench_build(name, make(n).astype(np.float32), args)


def trace(tris: np.ndarray, bvh, nrays: int = 1_000_000) -> None:
    """Closest-hit traversal speed through a mesh of these triangles (rays from outside towards it)."""
    from mcocl.render.compiled import compile_scene
    from mcocl.render.raycast import MISS, cast_rays
    from mcocl.render.scene import parse_scene

    scene = {"camera": {"origin": [0, 0, 5], "target": [0, 0, 0], "fov": 40, "width": 1, "height": 1},
             "materials": {"m": {"type": "diffuse", "reflectance": 0.5}}, "shapes": []}
    cs = compile_scene(parse_scene(scene, "bench"))
    # Swap the (empty) geometry for the triangles and the tree built above.
    tv = np.ascontiguousarray(tris, np.float32)  # (T, 3, 3), as compile_scene's tri_vertices
    cs.tri_vertices, cs.bvh_nodes, cs.bvh_prims = tv, bvh.nodes, bvh.prims
    # every triangle belongs to one non-emitting shape of material 0 (the scene tables need one)
    cs.prim_shape = np.zeros(len(tris), np.int32)
    cs.shape_material, cs.shape_emitter = np.zeros(1, np.int32), np.full(1, -1, np.int32)
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
