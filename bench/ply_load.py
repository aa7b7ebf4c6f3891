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

Usage: python bench/ply_load.py [--triangles N] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_big_scene import displaced_sphere  # noqa: E402

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


def _status_kb(field: str) -> int:
    """A ``kB`` field of /proc/self/status (Linux)."""
    line = next(x for x in Path("/proc/self/status").read_text().splitlines() if x.startswith(field + ":"))
    return int(line.split()[1])


def measure(path: Path) -> dict:
    """In this process: read ``path`` once and report the times and memory (see the module docstring)."""
    from mcocl.render.shapes import read_ply

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


def main() -> None:
    """Write the two files (unless present) and measure each in a child."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=10**6)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "big_scene")
    ap.add_argument("--measure", type=Path, help=argparse.SUPPRESS)  # the child's mode
    a = ap.parse_args()
    if a.measure:
        print(json.dumps(measure(a.measure)))
        return
    a.out.mkdir(parents=True, exist_ok=True)
    verts, faces = displaced_sphere(a.triangles)
    for binary in (True, False):
        path = a.out / f"sphere_{len(faces)}_{'binary' if binary else 'ascii'}.ply"
        if not path.exists():
            write_ply(path, verts, faces, binary)
        env = dict(os.environ)
        out = subprocess.run([sys.executable, __file__, "--measure", str(path)], env=env, check=True,
                             capture_output=True, text=True).stdout
        print(out.strip())


if __name__ == "__main__":
    main()
