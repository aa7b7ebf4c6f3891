"""Mitsuba ``<shape>`` and ``<emitter>`` plugins → mcocl shapes, area emitters and the environment.

Shapes: ``rectangle``, ``cube``, ``disk``, ``cylinder`` (the last two
tessellated: mcocl/render/shapes.py), ``sphere`` (``center``, ``radius``, a
similarity ``to_world``), ``obj`` and ``ply`` (``filename`` relative to the
file it is written in, confined to the scene's folder); ``to_world`` and
``serialized`` (with ``shape_index``: mcocl/render/serialized_reader.py);
``flip_normals`` on all of them, ``face_normals`` on ``obj``, ``ply`` and ``serialized``
(OBJ, PLY and serialized vertex normals shade smoothly unless it is set).  A shape without a BSDF
gets Mitsuba's default, diffuse 0.5, or black when it emits.  Emitters:
``area`` inside a shape (``radiance`` a constant or a ``bitmap``/``checkerboard``
texture) and a top-level ``constant`` (``radiance``), default 1.  ``shapegroup`` and ``instance`` are flattened by
mcocl/render/mitsuba/instance.py into copies of these.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import shapes as shape_lib
from .. import transform as tf
from .bsdf import rgb_json
from .file_search import FileSearch
from .properties import split_children
from .report import Reporter, nearest
from .texture import textured_properties
from .xml_source import Node

SUPPORTED = ("rectangle", "cube", "disk", "cylinder", "sphere", "obj", "ply", "serialized")
MESH_FILES = ("obj", "ply", "serialized")  # plugins that become a "mesh" shape reading the file of the same kind


def translate_radiance(node: Node, rep: Reporter, comments: list[str], resolve=None,
                       files: FileSearch | None = None) -> list[float] | float | dict:
    """The ``radiance`` of an ``area`` or ``constant`` emitter (default 1).

    Given ``resolve`` (an area emitter), a ``<texture name="radiance">`` (nested or by ``<ref>``)
    becomes a textured radiance (mcocl/render/mitsuba/texture.py)."""
    props, objects = split_children(node)
    if resolve is not None:
        textures = textured_properties(objects, resolve, rep, files)
        for o in objects:
            name = o.attrib.get("name") or (resolve(o) if o.tag == "ref" else o).attrib.get("name")
            if name in textures and name != "radiance":
                o.fail(f"an area emitter takes a texture for 'radiance' only, not {name!r}")
        objects = [o for o in objects if (resolve(o) if o.tag == "ref" else o).tag != "texture"]
        if "radiance" in textures:
            for o in objects:
                rep.unsupported(o, f"<{o.tag}> inside an emitter", "a radiance texture", "nothing (ignored)", comments)
            if "radiance" in props:
                props.node("radiance").fail("radiance is given twice (a texture and a value)")
            rep.leftover(node, props.unread(), ("radiance",), comments)
            return textures["radiance"]
    for o in objects:
        rep.unsupported(o, f"<{o.tag}> inside an emitter (textured radiance)", "a constant <rgb> radiance",
                        "the radiance property (default 1)", comments)
    if "radiance" not in props:
        comments.append("radiance: Mitsuba's default 1")
    rgb = props.colour("radiance", 1.0, "emitted")
    if np.any(rgb < 0):
        props.node("radiance").fail("radiance must be >= 0")
    rep.leftover(node, props.unread(), ("radiance",), comments)
    return rgb_json(rgb)


def axis_frame(n: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) taking +z to the unit vector ``n``: columns (s, t, n) of Mitsuba's ``coordinate_system``.

    The branchless orthonormal basis of Duff et al., "Building an Orthonormal
    Basis, Revisited" (JCGT 2017), which Mitsuba 3 uses to orient its cylinder;
    the same basis keeps the tessellation's seam where Mitsuba's parametrisation has it.
    """
    sign = math.copysign(1.0, n[2])  # as Mitsuba's: -0.0 counts as negative
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    s = [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]]
    t = [b, sign + n[1] * n[1] * a, -n[1]]
    return np.array([s, t, list(n)]).T


def cylinder_ops(props) -> list[dict]:
    """Transform operations for a cylinder's ``p0``, ``p1`` and ``radius`` (before its ``to_world``).

    Mitsuba 3 places the unit cylinder by scale(radius, radius, |p1 − p0|),
    then the frame of the axis, then translate(p0); none given: no operations.
    """
    if not any(k in props for k in ("p0", "p1", "radius")):
        return []
    p0 = np.asarray(props.get("p0", ("point",), [0.0, 0.0, 0.0]), float)
    p1 = np.asarray(props.get("p1", ("point",), [0.0, 0.0, 1.0]), float)
    r = props.get("radius", ("float",), 1.0)
    if r <= 0:
        props.node("radius").fail(f"radius must be > 0, got {r:g}")
    length = float(np.linalg.norm(p1 - p0))
    if length == 0.0:
        props.node("p1" if "p1" in props else "p0").fail("p0 and p1 coincide: the cylinder has no axis")
    m = np.eye(4)
    m[:3, :3] = axis_frame((p1 - p0) / length)
    return [{"scale": [r, r, length]}, {"matrix": m.tolist()}, {"translate": p0.tolist()}]


class ShapeTranslator:
    """Turns ``<shape>`` elements into mcocl shape objects; ``material_of`` names their BSDFs."""

    def __init__(self, files: FileSearch, rep: Reporter, material_of, resolve) -> None:
        self.files = files  # where meshes and images are looked for (mcocl/render/mitsuba/file_search.py)
        self.rep = rep
        self.material_of = material_of  # (bsdf Node | None, emits: bool, comments) -> material name
        self.resolve = resolve  # <ref> Node -> referenced Node

    def translate(self, node: Node) -> dict | None:
        """The mcocl shape of ``node``, or ``None`` when lenient mode drops it."""
        kind = node.attrib.get("type", "")
        comments: list[str] = []
        out: dict[str, Any] = {"comment": comments}
        if "id" in node.attrib:
            out["name"] = node.attrib["id"]
        props, objects = split_children(node)
        if kind not in SUPPORTED:
            self.rep.unsupported(node, f"the shape {kind!r}", nearest(kind, SUPPORTED), "nothing (the shape is left out)")
            return None
        out["type"] = "mesh" if kind in MESH_FILES else kind
        if kind in ("disk", "cylinder"):
            comments.append(f"{kind}: tessellated with {shape_lib.SEGMENTS} segments (scenes/README.md)")
        bsdf, emitter = None, None
        for o in objects:
            target = self.resolve(o) if o.tag == "ref" else o
            if target.tag == "bsdf" and bsdf is None:
                bsdf = target
            elif target.tag == "emitter" and emitter is None:
                emitter = target
            else:
                self.rep.unsupported(o, f"<{target.tag}> inside a shape" + (" (a second one)" if target.tag in
                                     ("bsdf", "emitter") else ""), "one <bsdf> and one area <emitter>",
                                     "nothing (ignored)", comments)
        if emitter is not None:
            etype = emitter.attrib.get("type", "")
            if etype != "area":
                self.rep.unsupported(emitter, f"the shape emitter {etype!r}", "area", "no emission", comments)
            else:
                out["emitter"] = {"type": "area", "radiance": translate_radiance(emitter, self.rep, comments,
                                                                                 self.resolve, self.files)}
        out["material"] = self.material_of(bsdf, emitter is not None and "emitter" in out, comments)
        t = props.get("to_world", ("transform",), None)
        if t is not None:
            out["transform"] = t.ops
        if kind == "cylinder":
            ops = cylinder_ops(props)
            if ops:
                out["transform"] = ops + out.get("transform", [])
        if props.get("flip_normals", ("boolean",), False):
            out["flip_normals"] = True
        supported = ["to_world", "flip_normals"] + (["p0", "p1", "radius"] if kind == "cylinder" else [])
        if kind == "sphere":
            supported += ["center", "radius"]
            c = props.get("center", ("point",), None)
            r = props.get("radius", ("float",), None)
            if c is not None:
                out["center"] = c
            if r is not None:
                if r <= 0:
                    props.node("radius").fail(f"radius must be > 0, got {r:g}")
                out["radius"] = r
            if t is not None and tf.uniform_scale_of(t.matrix) is None:
                props.node("to_world").fail("a sphere's to_world may only translate, rotate and scale uniformly")
        elif kind in MESH_FILES:
            supported += ["filename", "face_normals"]
            out[kind] = self._mesh_file(node, props, kind)
            if kind == "serialized":
                supported.append("shape_index")
                index = props.get("shape_index", ("integer",), 0)
                if index < 0:
                    props.node("shape_index").fail(f"shape_index must be >= 0, got {index}")
                out["shape_index"] = index
            if props.get("face_normals", ("boolean",), False):
                out["face_normals"] = True
                comments.append("face_normals: every triangle shades with its face normal")
            else:
                out["compute_normals"] = True
                comments.append("the file's vertex normals shade smoothly; without any, the angle-weighted average "
                                "of the faces' normals (as Mitsuba computes them)")
            if kind in ("obj", "ply"):
                supported.append("flip_tex_coords")
                default = kind == "obj"  # Mitsuba's defaults (src/shapes/obj.cpp, ply.cpp)
                flip = props.get("flip_tex_coords", ("boolean",), default)
                if flip != default:
                    out["flip_tex_coords"] = flip
                comments.append(f"flip_tex_coords {str(flip).lower()}{' (the default)' if flip == default else ''}: "
                                f"the file's UVs are used with v {'flipped to 1 - v' if flip else 'as written'}")
        self.rep.leftover(node, props.unread(), tuple(supported), comments)
        return out

    def _mesh_file(self, node: Node, props, kind: str) -> str:
        if "filename" not in props:
            node.fail(f'a{"n" if kind == "obj" else ""} {kind} shape needs <string name="filename" value="..."/>')
        return self.files.find(props.get("filename", ("string",)), props.node("filename"), "mesh file")


__all__ = ["ShapeTranslator", "translate_radiance"]
