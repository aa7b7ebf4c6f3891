"""Time reading a big PLY mesh: wall and CPU seconds and peak memory of mcocl.render.shapes.read_ply (issue 13).

Writes the displaced sphere of bench/make_big_scene.py (about ``--triangles``
triangles, with per-vertex normals and UVs) as a binary little-endian and an
ASCII PLY under ``--out``, then reads each in a fresh child process (so that
one's memory does not hide in the other's peak) and prints, per format: the
file's size, the read's wall and CPU time (the least of three reads), the child's peak resident memory
over its resident memory before the read (VmHWM after resetting it through
/proc/self/clear_refs, less VmRSS: Linux), the peak of the allocations that
tracemalloc sees (NumPy's included; tracing slows the read), and the mesh's size
in memory (vertices, faces, normals, UVs).

With ``--scene``, instead: writes the scene of bench/make_big_scene.py around
the binary PLY (``OUT/big_ply_scene.json``) and, in a fresh child, loads,
compiles and renders it once, printing the wall and CPU seconds of each stage:
reading the mesh (``read_ply``, inside the scene load), the rest of the scene
load, the BVH build and the rest of ``compile_scene``, the first image (1 spp,
``--size`` square, mis; with the kernel build) and a second one (the built
program reused: the image alone), and the peak resident memory of the load and
compile (and of the whole run) over the resident memory before, also as a
multiple of the file's size.  The kernel build of the first image comes from
PoCL's and pyopencl's caches when they hold it; ``--cold`` gives the child an
empty PoCL cache folder and no pyopencl cache, so that it is built.
``--repeat N`` runs N such children one after another (the machine is
shared: one run's times say little) and prints each one's line, then a line
of the medians of their times and peaks.

With ``--obj``, instead: writes the same mesh as a Wavefront OBJ with ``v``,
``vt``, ``vn`` and ``f i/i/i`` records and measures ``read_obj`` the same way.

Usage: python bench/ply_load.py [--triangles N] [--out DIR] [--obj] [--scene [--size PIXELS] [--cold] [--repeat N]]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_big_scene import big_scene, displaced_sphere  # noqa: E402

REPEATS = 3
VERTEX_PROPS = ("x", "y", "z", "nx", "ny", "nz", "u", "v")


def write_ply(path: Path, verts: np.ndarray, faces: np.ndarray, binary: bool) -> None:
    """A PLY of float vertices (position, unit normal, spherical UV) and uchar-counted int faces."""
    n = verts / np.linalg.norm(verts, axis=1, keepdims=True)
    uv = np.stack([np.arctan2(n[:, 2], n[:, 0]) / (2 * np.pi) + 0.5, np.arccos(np.clip(n[:, 1], -1, 1)) / np.pi], 1)
    data = np.concatenate([verts, n, uv], axis=1).astype(np.float32)
    head = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", f"element vertex {len(verts)}",
            *[f"property float {p}" for p in VERTEX_PROPS], f"element face {len(faces)}",
            "property list uchar int vertex_indices", "end_header", ""]
    with open(path, "wb") as f:
        f.write("\n".join(head).encode())
        if binary:
            rec = np.zeros(len(faces), np.dtype([("n", "u1"), ("i", "<i4", 3)]))
            rec["n"], rec["i"] = 3, faces
            f.write(data.astype("<f4").tobytes())
            f.write(rec.tobytes())
        else:
            np.savetxt(f, data, fmt="%.7g")
            np.savetxt(f, np.concatenate([np.full((len(faces), 1), 3), faces], axis=1), fmt="%d")


def write_obj(path: Path, verts: np.ndarray, faces: np.ndarray) -> None:
    """An OBJ of the mesh of :func:`write_ply` with ``v``, ``vt``, ``vn`` records and ``f i/i/i`` corners."""
    n = verts / np.linalg.norm(verts, axis=1, keepdims=True)
    uv = np.stack([np.arctan2(n[:, 2], n[:, 0]) / (2 * np.pi) + 0.5, np.arccos(np.clip(n[:, 1], -1, 1)) / np.pi], 1)
    with open(path, "wb") as f:
        f.write(b"# displaced sphere (bench/ply_load.py)\n")
        np.savetxt(f, verts.astype(np.float32), fmt="v %.7g %.7g %.7g")
        np.savetxt(f, uv.astype(np.float32), fmt="vt %.7g %.7g")
        np.savetxt(f, n.astype(np.float32), fmt="vn %.7g %.7g %.7g")
        c = np.repeat(faces + 1, 3, axis=1)
        np.savetxt(f, c, fmt="f %d/%d/%d %d/%d/%d %d/%d/%d")


def _status_kb(field: str) -> int:
    """A ``kB`` field of /proc/self/status (Linux)."""
    line = next(x for x in Path("/proc/self/status").read_text().splitlines() if x.startswith(field + ":"))
    return int(line.split()[1])


def measure(path: Path) -> dict:
    """In this process: read ``path`` once and report the times and memory (see the module docstring)."""
    from mcocl.render.shapes import read_obj, read_ply

    if path.suffix == ".obj":
        read_ply = read_obj  # noqa: F811 (the same measurement of the OBJ reader)
    Path("/proc/self/clear_refs").write_text("5")  # resets the peak (VmHWM) to the present resident size
    before = _status_kb("VmRSS")
    mesh = read_ply(path, "bench")
    peak = _status_kb("VmHWM")
    del mesh
    wall, cpu = [], []
    for _ in range(REPEATS):  # the least of a few reads: the machine is shared
        t0, c0 = time.perf_counter(), time.process_time()
        read_ply(path, "bench")
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    tracemalloc.start()
    mesh = read_ply(path, "bench")
    traced_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    wall, cpu = min(wall), min(cpu)
    held = sum(a.nbytes for a in (mesh.vertices, mesh.faces, mesh.normals, mesh.uvs) if a is not None)
    return {"file": path.name, "triangles": len(mesh.faces), "file_MB": path.stat().st_size / 1e6,
            "wall_s": round(wall, 3), "cpu_s": round(cpu, 3), "peak_rss_growth_MB": round((peak - before) / 1024, 1),
            "traced_peak_MB": round(traced_peak / 1e6, 1),
            "mesh_MB": round(held / 1e6, 1)}


class _Timed:
    """Wraps a module's function to add up the wall and CPU seconds of its calls (the stages of a load)."""

    def __init__(self, module, name: str) -> None:
        self.module, self.name, self.fn = module, name, getattr(module, name)
        self.wall = self.cpu = 0.0
        setattr(module, name, self)

    def __call__(self, *args, **kwargs):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            return self.fn(*args, **kwargs)
        finally:
            self.wall += time.perf_counter() - t0
            self.cpu += time.process_time() - c0


def _stage(fn):
    """``fn()`` and its wall and CPU seconds."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def measure_scene(path: Path, ply: Path, size: int) -> dict:
    """In this process: load, compile and render the scene ``path`` (see the module docstring)."""
    import mcocl
    from mcocl.render import compiled, shapes
    from mcocl.render.scene_file import load_scene

    read, bvh = _Timed(shapes, "read_ply"), _Timed(compiled, "build_bvh")
    Path("/proc/self/clear_refs").write_text("5")
    before = _status_kb("VmRSS")
    scene, load_wall, load_cpu = _stage(lambda: load_scene(path))
    cs, comp_wall, comp_cpu = _stage(lambda: compiled.compile_scene(scene, integrator="mis"))
    load_peak = _status_kb("VmHWM")
    first = _stage(lambda: mcocl.render(cs, spp=1, seed=0))
    again = _stage(lambda: mcocl.render(cs, spp=1, seed=1))
    run_peak = _status_kb("VmHWM")
    size_mb = ply.stat().st_size / 1e6
    r = lambda x: round(x, 3)  # noqa: E731
    return {"file": ply.name, "triangles": cs.num_triangles, "file_MB": round(size_mb, 1),
            "read_mesh_s": [r(read.wall), r(read.cpu)], "rest_of_load_s": [r(load_wall - read.wall), r(load_cpu - read.cpu)],
            "bvh_build_s": [r(bvh.wall), r(bvh.cpu)], "rest_of_compile_s": [r(comp_wall - bvh.wall), r(comp_cpu - bvh.cpu)],
            "first_image_with_build_s": [r(first[1]), r(first[2])], "image_s": [r(again[1]), r(again[2])],
            "image": f"{size}x{size} 1 spp mis", "load_compile_peak_MB": round((load_peak - before) / 1024, 1),
            "load_compile_peak_x_file": round((load_peak - before) / 1024 / size_mb, 2),
            "run_peak_MB": round((run_peak - before) / 1024, 1)}


def _medians(runs: list[dict]) -> dict:
    """The median over ``runs`` of every number and [wall, CPU] pair of measure_scene's results."""
    med = {"median_of_runs": len(runs)}
    for key, value in runs[0].items():
        if isinstance(value, list) and all(isinstance(x, float | int) for x in value):
            med[key] = [round(float(np.median([r[key][i] for r in runs])), 3) for i in range(len(value))]
        elif isinstance(value, int):
            med[key] = int(np.median([r[key] for r in runs]))
        elif isinstance(value, float):
            med[key] = round(float(np.median([r[key] for r in runs])), 3)
    return med


def main() -> None:
    """Write the two files (unless present) and measure each in a child."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=10**6)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "big_scene")
    ap.add_argument("--obj", action="store_true", help="measure an OBJ (v, vt, vn, f) of the mesh instead")
    ap.add_argument("--scene", action="store_true", help="load, compile and render a scene around the binary PLY")
    ap.add_argument("--size", type=int, default=256, help="--scene: the image's width and height")
    ap.add_argument("--cold", action="store_true", help="--scene: build the kernels without the caches")
    ap.add_argument("--repeat", type=int, default=1, help="--scene: children to run, then their medians")
    ap.add_argument("--measure", type=Path, help=argparse.SUPPRESS)  # the child's mode
    a = ap.parse_args()
    if a.measure:
        if a.scene:
            ply = a.measure.parent / json.loads(a.measure.read_text())["shapes"][1]["ply"]
            print(json.dumps(measure_scene(a.measure, ply, a.size)))
        else:
            print(json.dumps(measure(a.measure)))
        return
    a.out.mkdir(parents=True, exist_ok=True)
    verts, faces = displaced_sphere(a.triangles)
    if a.scene:
        ply = a.out / f"sphere_{len(faces)}_binary.ply"
        if not ply.exists():
            write_ply(ply, verts, faces, True)
        scene = big_scene(ply.name)
        mesh = scene["shapes"][1]
        mesh["ply"] = mesh.pop("obj")
        scene["camera"]["width"] = scene["camera"]["height"] = a.size
        path = a.out / "big_ply_scene.json"
        path.write_text(json.dumps(scene, indent=1) + "\n")
        runs = []
        for _ in range(max(1, a.repeat)):
            with tempfile.TemporaryDirectory() as cache:
                env = dict(os.environ, POCL_CACHE_DIR=cache, PYOPENCL_NO_CACHE="1") if a.cold else None
                out = subprocess.run([sys.executable, __file__, "--measure", str(path), "--scene", "--size",
                                      str(a.size)], env=env, check=True, capture_output=True, text=True).stdout
            print(out.strip().splitlines()[-1], flush=True)
            runs.append(json.loads(out.strip().splitlines()[-1]))
        if len(runs) > 1:
            print(json.dumps(_medians(runs)))
        return
    for binary in (False,) if a.obj else (True, False):
        path = a.out / f"sphere_{len(faces)}_{'binary' if binary else 'ascii'}.{'obj' if a.obj else 'ply'}"
        if not path.exists():
            (write_obj(path, verts, faces) if a.obj else write_ply(path, verts, faces, binary))
        env = dict(os.environ)
        out = subprocess.run([sys.executable, __file__, "--measure", str(path)], env=env, check=True,
                             capture_output=True, text=True).stdout
        print(out.strip())


if __name__ == "__main__":
    main()
