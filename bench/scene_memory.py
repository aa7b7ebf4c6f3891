"""Memory of a rendered big scene, stage by stage, and the device scene's bytes per triangle (issues 13 and 14).

Writes the scene of ``bench/ply_load.py --scene`` (the displaced sphere of
bench/make_big_scene.py as a binary PLY, about ``--triangles`` triangles, with
normals and UVs, on a large ground) unless given a scene file, then in a fresh
child process loads, compiles and renders it once (``--spp`` samples,
``--size`` square, ``--integrator``) and prints, for each stage, the peak
resident memory during the stage and the resident memory after it, both over
the child's resident memory before the load (Linux: VmHWM after resetting it
through /proc/self/clear_refs, and VmRSS; that base is printed too, since
what the process freed but kept before the load is reused by the stages),
and the same two figures for the memory Python and NumPy allocate (tracemalloc:
the arrays themselves, without the OpenCL runtime's or the C heap's share).  The OpenCL runtime (PoCL, its
LLVM, a built program) is loaded before that, by a render of scenes/cornell.json
at 8 x 8 pixels, and reported apart (``runtime``: a fixed cost, not the scene's).
``--route file`` (the default) renders the scene file as the CLI does:
``mcocl.render(path)`` loads and compiles it itself and holds the only
reference; ``--route compiled`` loads and compiles it here and renders the
compiled scene, which the caller keeps (to render it again).  The stages:

- ``load``: :func:`mcocl.render.scene_file.load_scene` (reading the mesh);
- ``compile``: :func:`mcocl.render.compiled.compile_scene` (the BVH and its device table, the shading normals);
- ``tables``: :func:`mcocl.render.device_scene.scene_tables` inside the render;
- ``buffers``: the render runner's creation (the kernel build and the device buffers);
- ``image``: the rest of the render (the samples);
- ``after``: once the render's result is dropped (what the compiled scene keeps, if anyone holds it).

Then the highest peak over the file's size (the scene file and the mesh
files beside it that it names), the device scene: the bytes of the runner's
buffers, in all and per triangle, the largest tables, and the size of the
compiled scene's arrays.  The last line is one JSON object, for notes.

Usage: python bench/scene_memory.py [SCENE] [--triangles N] [--out DIR] [--size PIXELS] [--spp N] [--integrator NAME]
       [--route file|compiled]
"""

from __future__ import annotations

import argparse
import gc
import json
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _status_kb(field: str) -> int:
    """A ``kB`` field of /proc/self/status (Linux)."""
    line = next(x for x in Path("/proc/self/status").read_text().splitlines() if x.startswith(field + ":"))
    return int(line.split()[1])


class _Stages:
    """Peak and resident memory (MB over a base) of consecutive stages, and the peak and present memory that
    tracemalloc sees (the arrays): each mark ends one stage and resets the peaks."""

    def __init__(self, traced: bool = True) -> None:
        gc.collect()
        self.tracing = traced  # False: resident figures only (tracing slows a load and costs memory of its own)
        if traced:
            tracemalloc.start()
        self.base, self.traced = _status_kb("VmRSS"), self._traced()[0]
        self.rows: dict[str, tuple[float, float, float, float]] = {}
        Path("/proc/self/clear_refs").write_text("5")  # resets VmHWM to the present resident size

    def mark(self, name: str) -> None:
        """End the stage ``name``: record its peaks and the memory now."""
        peak, now = _status_kb("VmHWM"), _status_kb("VmRSS")
        t_now, t_peak = self._traced()
        self.rows[name] = (round((peak - self.base) / 1024, 1), round((now - self.base) / 1024, 1),
                           round((t_peak - self.traced) / 2**20, 1), round((t_now - self.traced) / 2**20, 1))
        Path("/proc/self/clear_refs").write_text("5")
        if self.tracing:
            tracemalloc.reset_peak()

    def _traced(self) -> tuple[int, int]:
        """tracemalloc's present and peak bytes (zeros when not tracing)."""
        return tracemalloc.get_traced_memory() if self.tracing else (0, 0)


def _nbytes(obj) -> int:
    """Bytes of the NumPy arrays among ``obj``'s attributes (one level; views counted once by base)."""
    seen, total = set(), 0
    for v in vars(obj).values():
        if isinstance(v, np.ndarray):
            base = v if v.base is None else v.base
            if id(base) not in seen:
                seen.add(id(base))
                total += base.nbytes if isinstance(base, np.ndarray) else v.nbytes
    return total


def measure(path: Path, size: int, spp: int, integrator: str, route: str) -> dict:
    """In this process: load, compile and render ``path`` once and report the memory (see the module docstring)."""
    import mcocl
    from mcocl.render import api, job
    from mcocl.render.compiled import compile_scene
    from mcocl.render.scene_file import load_scene

    found: dict = {}
    tables_fn, runner_fn, load_fn, compile_fn = api.scene_tables, job.RenderJob.runner, api.load_scene, api._compile

    def tables(cs):
        out = tables_fn(cs)
        stages.mark("tables")
        found["tables"] = {k: int(np.asarray(v).nbytes) for k, v in out.items()}
        found["triangles"] = int(out["geometry_counts"][0])
        return out

    def load(*args, **kwargs):
        out = load_fn(*args, **kwargs)
        stages.mark("load")
        return out

    def compile_(*args, **kwargs):
        out = compile_fn(*args, **kwargs)
        stages.mark("compile")
        found["compiled_MB"] = round(_nbytes(out) / 1e6, 1)
        return out

    def runner(self, ctx):
        r = runner_fn(self, ctx)
        stages.mark("buffers")
        found["buffers"] = {k: int(b.size) for k, b in r.buffers.items()}
        return r

    runtime_kb = _status_kb("VmRSS")
    small = compile_scene(Path(__file__).resolve().parents[1] / "scenes" / "cornell.json")
    small.width = small.height = 8
    mcocl.render(small, spp=1, seed=0)
    del small
    gc.collect()
    runtime_mb = round((_status_kb("VmRSS") - runtime_kb) / 1024, 1)
    api.scene_tables, job.RenderJob.runner = tables, runner
    stages = _Stages()
    if route == "file":  # mcocl.render's own loading and compiling (the CLI's way): it holds the scene alone
        api.load_scene, api._compile = load, compile_
        res = mcocl.render(str(path), spp=spp, integrator=integrator, seed=0, progress=False)
        api.load_scene, api._compile = load_fn, compile_fn
        cs = None
    else:  # a compiled scene that the caller holds (and may render again)
        scene = load_scene(path)
        stages.mark("load")
        cs = compile_scene(scene, integrator=integrator)
        del scene
        stages.mark("compile")
        found["compiled_MB"] = round(_nbytes(cs) / 1e6, 1)
        res = mcocl.render(cs, spp=spp, seed=0, progress=False)
    stages.mark("image")
    del res
    gc.collect()
    stages.mark("after")
    api.scene_tables, job.RenderJob.runner = tables_fn, runner_fn
    nt = found["triangles"]
    device = sum(found["buffers"].values())
    biggest = sorted(found["buffers"].items(), key=lambda kv: -kv[1])[:6]
    return {"scene": path.name, "route": route, "file_MB": round(_scene_bytes(path) / 1e6, 1), "triangles": nt,
            "image": f"{size}x{size} {spp} spp {integrator}",
            "opencl_runtime_MB": runtime_mb, "base_MB": round(stages.base / 1024, 1),
            "stages_MB_peak_resident": stages.rows,
            "device_scene_MB": round(device / 1e6, 1), "device_bytes_per_triangle": round(device / max(nt, 1), 1),
            "largest_buffers_MB": {k: round(v / 1e6, 1) for k, v in biggest},
            "compiled_scene_arrays_MB": found["compiled_MB"]}


def _scene_bytes(path: Path) -> int:
    """The bytes of a scene file and of the mesh files next to it that it names (the file size the memory
    is compared with)."""
    text = path.read_text(errors="replace")
    return path.stat().st_size + sum(f.stat().st_size for f in path.parent.iterdir()
                                     if f.is_file() and f != path and f'"{f.name}"' in text)


def _big_scene(triangles: int, out: Path, size: int) -> Path:
    """Write (unless present) the binary PLY sphere and ``OUT/big_ply_scene.json`` around it (bench/ply_load.py)."""
    from make_big_scene import big_scene, displaced_sphere
    from ply_load import write_ply

    out.mkdir(parents=True, exist_ok=True)
    verts, faces = displaced_sphere(triangles)
    ply = out / f"sphere_{len(faces)}_binary.ply"
    if not ply.exists():
        write_ply(ply, verts, faces, True)
    scene = big_scene(ply.name)
    mesh = scene["shapes"][1]
    mesh["ply"] = mesh.pop("obj")
    scene["camera"]["width"] = scene["camera"]["height"] = size
    path = out / "big_ply_scene.json"
    path.write_text(json.dumps(scene, indent=1) + "\n")
    return path


def main() -> None:
    """Write the scene (unless given) and measure it in a child."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path, nargs="?", help="a scene file (default: the big PLY scene)")
    ap.add_argument("--triangles", type=int, default=10**6)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "big_scene")
    ap.add_argument("--size", type=int, default=256, help="the big scene's width and height")
    ap.add_argument("--spp", type=int, default=1)
    ap.add_argument("--integrator", default="mis")
    ap.add_argument("--route", choices=("file", "compiled"), default="file",
                    help="file: mcocl.render(path), which loads and compiles the scene itself (the CLI's way); "
                         "compiled: render a compiled scene that the caller holds")
    ap.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)  # the child's mode
    a = ap.parse_args()
    if a.measure:
        print(json.dumps(measure(a.scene, a.size, a.spp, a.integrator, a.route)))
        return
    path = a.scene or _big_scene(a.triangles, a.out, a.size)
    out = subprocess.run([sys.executable, __file__, str(path), "--measure", "--size", str(a.size), "--spp", str(a.spp),
                          "--integrator", a.integrator, "--route", a.route], check=True, capture_output=True, text=True).stdout
    r = json.loads(out.strip().splitlines()[-1])
    print(f"{r['scene']} ({r['file_MB']} MB with its mesh, route {r['route']}): {r['triangles']} triangles, "
          f"{r['image']}; the OpenCL runtime: {r['opencl_runtime_MB']} MB, "
          f"resident before the load: {r['base_MB']} MB")
    print(f"{'stage':10s} {'peak MB':>9s} {'resident MB':>12s} {'arrays peak':>12s} {'arrays now':>11s}"
          f"   (over the process before the load)")
    for name, (peak, now, t_peak, t_now) in r["stages_MB_peak_resident"].items():
        print(f"{name:10s} {peak:9.1f} {now:12.1f} {t_peak:12.1f} {t_now:11.1f}")
    top = max(row[0] for row in r["stages_MB_peak_resident"].values())
    print(f"peak {top} MB = {top / r['file_MB']:.1f}x the file")
    print(f"device scene {r['device_scene_MB']} MB = {r['device_bytes_per_triangle']} bytes/triangle; "
          f"largest {r['largest_buffers_MB']}; compiled scene arrays {r['compiled_scene_arrays_MB']} MB")
    print(json.dumps(r))


if __name__ == "__main__":
    main()
