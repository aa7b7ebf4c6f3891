"""Memory and time of loading a ~100 MB scene in every mesh format the loader reads (issue 13: at most 2x).

Writes, under ``--out`` (default ``/tmp/mcocl_load_memory``; kept, and reused
when present), the displaced sphere of bench/make_big_scene.py at about
``--mb`` megabytes of mesh in each format, with the scene around it
(bench/make_big_scene.py's ``big_scene``):

- ``ply_binary``: binary little-endian PLY, float x y z nx ny nz u v, uchar/int faces (bench/ply_load.py);
- ``ply_binary_xyz``: the same with positions only;
- ``ply_ascii``: the ASCII PLY of bench/ply_load.py;
- ``obj``: Wavefront OBJ with ``v``, ``vt``, ``vn`` and ``f i/i/i`` (bench/ply_load.py);
- ``serialized``: a Mitsuba serialized file (version 4, single precision, normals and UVs; zlib level 1);
- ``xml``: a Mitsuba XML scene naming three meshes of a third of the size each: a binary PLY, an OBJ, a
  serialized file;
- ``xml_xyz``: a Mitsuba XML scene naming the positions-only binary PLY, whose vertex normals the load
  computes (Mitsuba's behaviour for a mesh file without them: mcocl/render/mesh_normals.py);
- ``json_inline``: an mcocl JSON scene whose mesh is inline ``vertices`` and ``faces`` lists.

Each scene is then loaded by :func:`mcocl.render.scene_file.load_scene` in a
fresh child process, and the table gives the load's wall seconds, its peak
resident memory over the child's resident memory before it, and the memory it
still holds after (the scene held), as bench/scene_memory.py measures its
stages (VmHWM reset through /proc/self/clear_refs: Linux), and the peak as a
multiple of the files' size (the scene file and the mesh files it names).
``arrays MB`` is the size of the meshes' arrays the loaded scene holds
(vertices, faces, normals, UVs): the least a load that keeps them can peak at
(a serialized file's are its inflated data, more than twice the file at zlib's
ratios for float meshes).  The last line is one JSON object, for notes.

Usage: python bench/load_memory.py [--mb MB] [--out DIR] [--format NAME ...]
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_big_scene import big_scene, displaced_sphere  # noqa: E402
from ply_load import write_obj, write_ply  # noqa: E402
from scene_memory import _scene_bytes, _Stages  # noqa: E402

FORMATS = ("ply_binary", "ply_binary_xyz", "ply_ascii", "obj", "serialized", "xml", "xml_xyz", "json_inline")
# bytes per triangle of each mesh file (the sphere has about half as many vertices as triangles), to size it
_PROBE_TRIANGLES = 40_000


def _attributes(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The unit normals and spherical UVs of bench/ply_load.py's files, float32."""
    n = verts / np.linalg.norm(verts, axis=1, keepdims=True)
    uv = np.stack([np.arctan2(n[:, 2], n[:, 0]) / (2 * np.pi) + 0.5, np.arccos(np.clip(n[:, 1], -1, 1)) / np.pi], 1)
    return n.astype(np.float32), uv.astype(np.float32)


def write_serialized(path: Path, verts: np.ndarray, faces: np.ndarray) -> None:
    """One mesh as a Mitsuba serialized file (the layout of mcocl/render/serialized_reader.py's docstring):
    version 4, single precision, per-vertex normals and UVs, uint32 indices."""
    n, uv = _attributes(verts)
    body = b"".join([struct.pack("<I", 0x1000 | 0x0001 | 0x0002), b"sphere\0", struct.pack("<QQ", len(verts), len(faces)),
                     verts.astype("<f4").tobytes(), n.astype("<f4").tobytes(), uv.astype("<f4").tobytes(),
                     faces.astype("<u4").tobytes()])
    packed = zlib.compress(body, 1)
    path.write_bytes(struct.pack("<HH", 0x041C, 4) + packed + struct.pack("<QI", 0, 1))


def write_ply_xyz(path: Path, verts: np.ndarray, faces: np.ndarray) -> None:
    """A binary little-endian PLY of float positions and uchar/int faces only."""
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    rec = np.zeros(len(faces), np.dtype([("n", "u1"), ("i", "<i4", 3)]))
    rec["n"], rec["i"] = 3, faces
    with open(path, "wb") as f:
        f.write(head.encode())
        f.write(verts.astype("<f4").tobytes())
        f.write(rec.tobytes())


def write_json_inline(path: Path, verts: np.ndarray, faces: np.ndarray) -> None:
    """The scene with the mesh inline: ``vertices`` (7 significant digits) and ``faces`` lists."""
    scene = big_scene("x")
    mesh = scene["shapes"][1]
    del mesh["obj"]
    mesh["vertices"], mesh["faces"] = "@V@", "@F@"
    text = json.dumps(scene, indent=1)
    with open(path, "w") as f:
        head, rest = text.split('"@V@"')
        mid, tail = rest.split('"@F@"')
        f.write(head + "[")
        _rows(f, verts.astype(np.float32), "[%.7g, %.7g, %.7g]")
        f.write("]" + mid + "[")
        _rows(f, faces, "[%d, %d, %d]")
        f.write("]" + tail + "\n")


def _rows(f, a: np.ndarray, fmt: str) -> None:
    """The rows of ``a`` as JSON arrays separated by commas (np.savetxt: no Python string of them all)."""
    np.savetxt(f, a[:-1], fmt=fmt, newline=",")
    np.savetxt(f, a[-1:], fmt=fmt, newline="")


def _mesh_file(fmt: str, path: Path, verts: np.ndarray, faces: np.ndarray) -> None:
    """Write the mesh in one format (``path``'s suffix is the format's)."""
    if fmt == "ply_binary":
        write_ply(path, verts, faces, True)
    elif fmt == "ply_binary_xyz":
        write_ply_xyz(path, verts, faces)
    elif fmt == "ply_ascii":
        write_ply(path, verts, faces, False)
    elif fmt == "obj":
        write_obj(path, verts, faces)
    elif fmt == "serialized":
        write_serialized(path, verts, faces)
    else:
        write_json_inline(path, verts, faces)


_SUFFIX = {"ply_binary": ".ply", "ply_binary_xyz": ".ply", "ply_ascii": ".ply", "obj": ".obj",
           "serialized": ".serialized", "json_inline": ".json"}
_KEY = {".ply": "ply", ".obj": "obj", ".serialized": "serialized"}


def _sized_mesh(fmt: str, mb: float, out: Path) -> Path:
    """The mesh file of ``fmt`` at about ``mb`` MB (sized from a small probe's bytes per triangle)."""
    path = out / f"{fmt}_{mb:.0f}MB{_SUFFIX[fmt]}"
    if path.exists():
        return path
    probe = out / f"probe{_SUFFIX[fmt]}"
    verts, faces = displaced_sphere(_PROBE_TRIANGLES)
    _mesh_file(fmt, probe, verts, faces)
    per_triangle = probe.stat().st_size / len(faces)
    probe.unlink()
    _mesh_file(fmt, path, *displaced_sphere(int(mb * 1e6 / per_triangle)))
    return path


def _mitsuba_xml(meshes: list[Path]) -> str:
    """A Mitsuba XML scene of a camera, a light and the ``meshes`` side by side."""
    shapes = "".join(
        f'<shape type="{_KEY[m.suffix]}"><string name="filename" value="{m.name}"/>'
        f'<transform name="to_world"><translate x="{2.5 * (k - 1)}"/></transform>'
        f'<bsdf type="diffuse"/></shape>\n' for k, m in enumerate(meshes))
    return ('<scene version="3.0.0">\n<sensor type="perspective"><float name="fov" value="40"/>'
            '<transform name="to_world"><lookat origin="0, 2, 9" target="0, 0, 0" up="0, 1, 0"/></transform>'
            '<film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/></film>'
            '</sensor>\n<emitter type="constant"/>\n' + shapes + "</scene>\n")


def scene_file(fmt: str, mb: float, out: Path) -> Path:
    """The scene of ``fmt`` (written unless present) around ``mb`` MB of mesh."""
    out.mkdir(parents=True, exist_ok=True)
    if fmt == "json_inline":
        return _sized_mesh(fmt, mb, out)
    if fmt in ("xml", "xml_xyz"):
        kinds = ("ply_binary", "obj", "serialized") if fmt == "xml" else ("ply_binary_xyz",)
        meshes = [_sized_mesh(f, mb / len(kinds), out) for f in kinds]
        path = out / f"{fmt}_{mb:g}MB.xml"
        path.write_text(_mitsuba_xml(meshes))
        return path
    mesh = _sized_mesh(fmt, mb, out)
    scene = big_scene(mesh.name)
    shape = scene["shapes"][1]
    shape[_KEY[mesh.suffix]] = shape.pop("obj")
    path = out / f"{fmt}_{mb:g}MB_scene.json"
    path.write_text(json.dumps(scene, indent=1) + "\n")
    return path


_ARRAYS = ("vertices", "faces", "normals", "uvs")  # a loaded mesh shape's arrays


def measure(path: Path) -> dict:
    """In this process: load ``path`` once and report the load's seconds and memory (see the module docstring)."""
    from mcocl.render.scene_file import load_scene

    load_scene(Path(__file__).resolve().parents[1] / "scenes" / "cornell.json")  # the readers' first-use costs
    stages = _Stages(traced=False)
    t0 = time.perf_counter()
    scene = load_scene(path)
    seconds = time.perf_counter() - t0
    stages.mark("load")
    peak, held = (round(x * 2**20 / 1e6, 1) for x in stages.rows["load"][:2])  # MiB -> MB, as the file's size
    mb = _scene_bytes(path) / 1e6
    triangles = sum(len(s.faces) for s in scene.shapes)
    arrays = sum(a.nbytes for s in scene.shapes for a in (getattr(s, k, None) for k in _ARRAYS) if a is not None)
    return {"scene": path.name, "file_MB": round(mb, 1), "triangles": triangles, "load_s": round(seconds, 2),
            "peak_MB": peak, "ratio": round(peak / mb, 2), "retained_MB": held, "retained_ratio": round(held / mb, 2),
            "arrays_MB": round(arrays / 1e6, 1),
            "base_MB": round(stages.base / 1024, 1)}


def main() -> None:
    """Write the scenes (unless present) and measure each load in a child."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mb", type=float, default=100.0, help="megabytes of mesh per scene")
    ap.add_argument("--out", type=Path, default=Path("/tmp/mcocl_load_memory"))
    ap.add_argument("--format", nargs="+", choices=FORMATS, default=list(FORMATS))
    ap.add_argument("--measure", type=Path, help=argparse.SUPPRESS)  # the child's mode
    a = ap.parse_args()
    if a.measure:
        print(json.dumps(measure(a.measure)))
        return
    rows = []
    print(f"{'format':15s} {'file MB':>8s} {'triangles':>10s} {'load s':>7s} {'peak MB':>8s} {'ratio':>6s} "
          f"{'retained MB':>12s} {'arrays MB':>10s}")
    for fmt in a.format:
        path = scene_file(fmt, a.mb, a.out)
        out = subprocess.run([sys.executable, __file__, "--measure", str(path)], check=True, capture_output=True,
                             text=True).stdout
        r = {"format": fmt, **json.loads(out.strip().splitlines()[-1])}
        rows.append(r)
        print(f"{fmt:15s} {r['file_MB']:8.1f} {r['triangles']:10d} {r['load_s']:7.2f} {r['peak_MB']:8.1f} "
              f"{r['ratio']:6.2f} {r['retained_MB']:12.1f} {r['arrays_MB']:10.1f}", flush=True)
    worst = max(rows, key=lambda r: r["ratio"])
    print(f"highest peak: {worst['format']}, {worst['ratio']}x its files (goal: at most 2x)")
    print(json.dumps({"load_memory": rows}))


if __name__ == "__main__":
    main()
