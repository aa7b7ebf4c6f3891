"""Mitsuba 3's memory for a scene, measured as bench/scene_memory.py measures mcocl's (issue 13's 2x goal).

Runs in the Python of Mitsuba's own virtual environment (Mitsuba is not a
dependency of mcocl):

    DRJIT_LIBLLVM_PATH=/path/to/libLLVM.so.19.1 /work/mitsuba-venv/bin/python bench/mitsuba_scene_memory.py \\
        bench/big_scene/big_ply_scene.json --variant llvm_ad_rgb

The runtime (Mitsuba, Dr.Jit, LLVM) is loaded first by rendering a tiny
scene; then the resident memory is the base, the peak is reset (Linux:
/proc/self/clear_refs), the scene (mcocl's JSON, converted by
bench/mitsuba_scene.py) is loaded and rendered at ``--spp``, and the peak
and resident memory over the base are printed with the size of the scene's
files (the JSON and the mesh files it names).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import mitsuba_scene  # noqa: E402


def _status_mb(field: str) -> float:
    """A ``kB`` field of /proc/self/status, in MB."""
    line = next(x for x in Path("/proc/self/status").read_text().splitlines() if x.startswith(field + ":"))
    return int(line.split()[1]) / 1024.0


def _files_mb(scene: Path) -> float:
    """The scene file and the mesh files its shapes name, in MB."""
    shapes = json.loads(scene.read_text()).get("shapes", [])
    meshes = [scene.parent / s[k] for s in shapes for k in ("ply", "obj") if k in s]
    return sum(p.stat().st_size for p in [scene, *meshes]) / 1e6


def main() -> None:
    """Print the peak and resident memory of loading and rendering the scene, over the runtime's base."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--spp", type=int, default=1)
    args = ap.parse_args()
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    tiny = {"type": "scene", "integrator": {"type": "path"},
            "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 8, "height": 8},
                       "sampler": {"type": "independent", "sample_count": 1}},
            "ball": {"type": "sphere"}}
    mi.render(mi.load_dict(tiny))
    base = _status_mb("VmRSS")
    Path("/proc/self/clear_refs").write_text("5")  # VmHWM := VmRSS
    with tempfile.TemporaryDirectory() as meshes:
        t0 = time.perf_counter()
        scene = mitsuba_scene.load(mi, args.scene, meshes, args.spp)
        load_s = time.perf_counter() - t0
        load_peak = _status_mb("VmHWM") - base
        img = mi.render(scene, spp=args.spp)
        dr.eval(img)
        dr.sync_thread()
    peak = _status_mb("VmHWM") - base
    size = _files_mb(args.scene)
    out = {"scene": args.scene.name, "variant": args.variant, "file_MB": round(size, 1), "base_MB": round(base, 1),
           "load_seconds": round(load_s, 2), "load_peak_MB": round(load_peak, 1), "peak_MB": round(peak, 1),
           "resident_MB": round(_status_mb("VmRSS") - base, 1), "peak_over_file": round(peak / size, 2)}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
