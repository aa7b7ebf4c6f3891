"""``mcocl convert``: a Mitsuba XML scene → mcocl's JSON, every choice explained in ``"comment"`` keys.

Also home of the ``-D name=value`` and ``--lenient`` options that ``mcocl render`` shares.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import warnings
from pathlib import Path
from typing import Any

from ..errors import InputError, SceneSubstitutionWarning
from ..output_files import write_atomically
from .paths import check_files

DESCRIPTION = """\
Convert SCENE (a Mitsuba 3 or 0.6 XML file) to mcocl's JSON scene format
(scenes/README.md).  Each object of the output carries "comment" strings that
say which Mitsuba default was taken, how a value was converted (fov axis,
spectra, named IORs, sampler) and what --lenient substituted.  The JSON
renders the same image as the XML.  Mesh, environment-map and bitmap texture
paths are rewritten relative to the output file.
"""

EXAMPLES = """\
examples:
  mcocl convert scenes/xml/cornell.xml -o cornell.json
  mcocl convert scene.xml -D spp=1024 -D resx=512 -o scene.json
  mcocl convert gallery/bathroom.xml --lenient -o bathroom.json
"""


def define(text: str) -> tuple[str, str]:
    """Parse ``name=value`` of a ``-D`` option."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"expected name=value, got {text!r}")
    return name.strip(), value


def add_scene_params_args(p: argparse.ArgumentParser) -> None:
    """``-D name=value`` (repeatable) and ``--lenient``, for commands that read Mitsuba XML scenes."""
    p.add_argument("-D", dest="define", action="append", type=define, default=[], metavar="NAME=VALUE",
                   help="set the XML scene parameter $NAME (overrides its <default>); repeatable")
    p.add_argument("--lenient", action="store_true",
                   help="XML scenes: substitute what mcocl does not support (with a warning) instead of failing")


def print_substitution_warnings(caught: list[warnings.WarningMessage]) -> None:
    """Print each recorded :class:`SceneSubstitutionWarning` on stderr."""
    for w in caught:
        if issubclass(w.category, SceneSubstitutionWarning):
            print(f"WARNING: {w.message}", file=sys.stderr)


def format_json(obj: Any, indent: int = 0) -> str:
    """JSON with one key per line, ``"comment"`` first, and lists of numbers (vectors, matrix rows) on one line."""
    pad, inner = " " * indent, " " * (indent + 2)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        keys = sorted(obj, key=lambda k: k != "comment")  # the comment first, the rest as built
        items = [f"{inner}{json.dumps(k)}: {format_json(obj[k], indent + 2)}" for k in keys]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, list) and obj and not all(isinstance(x, (int, float)) for x in obj):
        flat = all(isinstance(x, list) and all(isinstance(y, (int, float)) for y in x) for x in obj)
        if flat and len(obj) <= 4:
            return "[" + ", ".join(format_json(x) for x in obj) + "]"
        return "[\n" + ",\n".join(inner + format_json(x, indent + 2) for x in obj) + "\n" + pad + "]"
    return json.dumps(obj)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``convert`` parser."""
    p = sub.add_parser("convert", help="convert a Mitsuba XML scene to mcocl's JSON", description=DESCRIPTION,
                       epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", help="Mitsuba XML scene file")
    p.add_argument("-o", "--out", default=None, help="JSON output (default: standard output)")
    p.add_argument("--no-check", action="store_true", help="skip validating the result with mcocl's scene loader")
    p.add_argument("--mesh-folder", default=None, metavar="DIR",
                   help="a folder the scene may read meshes and images from besides its own folder "
                        "(e.g. a <path> folder outside it)")
    add_scene_params_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Convert, validate the result as mcocl would load it, write it."""
    from ..render.mitsuba import read_mitsuba
    from ..render.scene import parse_scene

    src = Path(args.scene)
    if src.suffix.lower() != ".xml":
        raise InputError(f"{src}: convert reads Mitsuba XML scenes (.xml)")
    # before any work, and the scene is never overwritten (issue 10)
    check_files([("--out", args.out)], [("the scene", args.scene), ("--mesh-folder", args.mesh_folder)])
    if args.mesh_folder is not None and not Path(args.mesh_folder).is_dir():
        raise InputError(f"--mesh-folder: {args.mesh_folder} is not a folder")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SceneSubstitutionWarning)
        data = read_mitsuba(src, params=dict(args.define), lenient=args.lenient, mesh_folder=args.mesh_folder)
    print_substitution_warnings(caught)
    if not args.no_check:
        parse_scene(data, src, args.mesh_folder)
    if args.out:
        out_dir = Path(args.out).resolve().parent
        outside = set()
        for shape in data.get("shapes", []):
            for kind in ("obj", "ply", "serialized"):
                if kind in shape:
                    mesh = src.resolve().parent / shape[kind]
                    shape[kind] = Path(os.path.relpath(mesh, out_dir)).as_posix()
                    if shape[kind].startswith("../"):
                        outside.add(str(mesh.parent))
        env = data.get("environment", {})
        images = [env] if env.get("type") == "envmap" else []  # the map's image, like the meshes
        images += [v for m in data.get("materials", {}).values() if isinstance(m, dict)
                   for v in m.values() if isinstance(v, dict) and v.get("type") == "bitmap"]  # bitmap textures
        for holder in images:
            image = src.resolve().parent / holder["filename"]
            holder["filename"] = Path(os.path.relpath(image, out_dir)).as_posix()
            if holder["filename"].startswith("../"):
                outside.add(str(image.parent))
        text = format_json(data) + "\n"
        write_atomically(args.out, lambda tmp: tmp.write_text(text))
        for folder in sorted(outside):
            # a scene file reads meshes only from its own folder unless told otherwise (scene_file.load_scene)
            print(f"note: {args.out} reads meshes or images from {folder}, outside its folder: "
                  f"render it with --mesh-folder {folder}", file=sys.stderr)
        print(f"wrote {args.out} ({len(data.get('shapes', []))} shapes, {len(data.get('materials', {}))} materials)",
              file=sys.stderr)
    else:
        print(format_json(data))
    return 0
