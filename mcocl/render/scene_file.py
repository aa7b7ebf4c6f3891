"""Scene files: one entry point for every format mcocl reads.

mcocl's own JSON (``scenes/README.md``) is parsed here; a Mitsuba XML file
(``.xml``) is translated into the same JSON model by
:mod:`mcocl.render.mitsuba`.  Both are validated by
:func:`mcocl.render.scene.parse_scene`, so the two readers share one scene
model and one set of checks.

A JSON file is read first by :func:`mcocl.render.json_arrays.read_json_with_arrays`,
which parses inline mesh arrays with NumPy (issue 13: a scene holds at most
twice its size); whatever that fast path does not vouch for is read again the
exact way (``json.loads``), which words every error as before.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..datafile import decode_utf8, loads_json, read_regular_file
from ..errors import InputError
from .json_arrays import ExactReadNeededError, InlineArray, read_json_with_arrays
from .mitsuba import load_mitsuba
from .scene import Scene, parse_scene


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not valid JSON")


def load_scene(path: str | Path, *, params: dict | None = None, lenient: bool = False,
               mesh_folder: str | Path | None = None) -> Scene:
    """Read and validate a scene file: mcocl JSON, or Mitsuba XML (``.xml``, see :mod:`mcocl.render.mitsuba`).

    Args:
        params: ``$name`` values of an XML file (``-D name=value``).
        lenient: substitute what an XML file uses and mcocl does not support.
        mesh_folder: a folder OBJ files may also come from (by default only
            the scene file's folder and the folders below it).

    Raises:
        InputError: the file cannot be read, is not UTF-8 JSON (or XML), or
            breaks the format; the message names the file and the key path.
    """
    p = Path(path)
    if mesh_folder is not None and not Path(mesh_folder).is_dir():
        raise InputError(f"mesh_folder (--mesh-folder): {mesh_folder} is not a folder")
    if p.suffix.lower() == ".xml":
        return load_mitsuba(p, params=params, lenient=lenient, mesh_folder=mesh_folder)
    if params:
        raise InputError(f"{p}: params (-D name=value) apply to Mitsuba XML scenes only")
    scene = _load_json_fast(p, mesh_folder)
    return scene if scene is not None else parse_scene(_read_json_exact(p), p, mesh_folder)


def _load_json_fast(p: Path, mesh_folder: str | Path | None) -> Scene | None:
    """The scene of ``p`` with its inline arrays parsed by NumPy, or None where the exact reader must read it.

    A function of its own so that the arrays already parsed are let go when it returns None, before the
    exact reader holds the file again.

    Raises:
        InputError: the scene breaks the format (the exact reader's message: the data it checks are the same).
    """
    try:
        data, arrays = read_json_with_arrays(p, str(p), parse_constant=_reject_constant)
        if _arrays_in_meshes(data) != len(arrays):
            return None
        return parse_scene(data, p, mesh_folder)
    except ExactReadNeededError:
        return None


def _arrays_in_meshes(data: Any) -> int:
    """How many :class:`InlineArray` stand as a shape's ``vertices`` or ``faces``, the only places the
    checker takes one (``_Checker.array``); one anywhere else would be printed or dumped as a list, so the
    file must then be read the exact way."""
    shapes = data.get("shapes") if isinstance(data, dict) else None
    if not isinstance(shapes, list):
        return 0
    return sum(isinstance(s.get(k), InlineArray) for s in shapes if isinstance(s, dict) for k in ("vertices", "faces"))


def _read_json_exact(p: Path) -> Any:
    """The JSON document of ``p`` by ``json.loads``, every error worded with the file, line and column."""
    try:
        raw = read_regular_file(p)
    except OSError as e:
        raise InputError(f"{p}: cannot read scene file: {e.strerror or e}") from None
    text = decode_utf8(raw, str(p))
    try:
        data = loads_json(text, str(p), parse_constant=_reject_constant)
    except json.JSONDecodeError as e:
        raise InputError(f"{p}:{e.lineno}:{e.colno}: not valid JSON: {e.msg}") from None
    except ValueError as e:
        raise InputError(f"{p}: not valid JSON: {e}") from None
    return data


__all__ = ["load_scene"]
