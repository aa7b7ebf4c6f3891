"""Mitsuba texture plugins → mcocl texture objects (mcocl/render/textures.py).

``<texture type="bitmap">`` (``filename`` relative to its XML file and inside
the scene's folder, ``raw``, ``filter_type``, ``wrap_mode``, ``to_uv``) and
``<texture type="checkerboard">`` (``color0``, ``color1`` as constants,
``to_uv``), nested in a BSDF with ``name="<property>"`` or referenced by
``<ref id="..." name="<property>"/>``.  The BSDF properties that take one are
the texturable keys of mcocl/bsdf_registry.py (:data:`TEXTURE_PROPERTIES`).
"""

from __future__ import annotations

from typing import Any

from ...bsdf_registry import BSDFS
from ...render.textures import FILTERS, WRAPS
from .file_search import FileSearch
from .properties import split_children
from .report import Reporter, nearest
from .xml_source import Node

KINDS = ("bitmap", "checkerboard")

# mcocl material type -> the Mitsuba properties (= scene-file keys) that take a texture.
TEXTURE_PROPERTIES = {name: tuple(p.key for p in spec.params if p.texturable) for name, spec in BSDFS.items()}


def translate_texture(node: Node, rep: Reporter, files: FileSearch) -> dict:
    """The mcocl texture object of a ``<texture>`` element."""
    kind = node.attrib.get("type", "")
    if kind not in KINDS:
        node.fail(f"unsupported texture plugin {kind!r} (supported: {', '.join(KINDS)}; nearest: {nearest(kind, KINDS)})")
    props, objects = split_children(node)
    for o in objects:
        o.fail(f"a nested <{o.tag}> inside a {kind} texture is not supported (give constant values)")
    out: dict[str, Any] = {"type": kind}
    comments: list[str] = []
    if kind == "checkerboard":
        for k, default in (("color0", 0.4), ("color1", 0.2)):
            v = props.colour(k, default)
            out[k] = [float(x) for x in v]
        supported: tuple[str, ...] = ("color0", "color1", "to_uv")
    else:
        if "filename" not in props:
            node.fail('a bitmap texture needs <string name="filename" value="..."/>')
        out["filename"] = files.find(props.get("filename", ("string",)), props.node("filename"), "image file")
        for k, choices in (("filter_type", FILTERS), ("wrap_mode", WRAPS)):
            v = props.get(k, ("string",), None)
            if v is not None:
                if v not in choices:
                    props.node(k).fail(f"{k} {v!r} is not supported (one of: {', '.join(choices)})")
                out[k] = v
        raw = props.get("raw", ("boolean",), None)
        if raw is not None:
            out["raw"] = raw
        supported = ("filename", "filter_type", "wrap_mode", "raw", "to_uv")
    t = props.get("to_uv", ("transform",), None)
    if t is not None:
        out["to_uv"] = t.ops
    rep.leftover(node, props.unread(), supported, comments)
    if comments:
        out["comment"] = comments
    return out


def textured_properties(objects: list[Node], resolve, rep: Reporter, files: FileSearch | None) -> dict[str, dict]:
    """The ``<texture>`` children of a BSDF (nested, or ``<ref>`` to one), translated, by property name."""
    out: dict[str, dict] = {}
    for o in objects:
        target = resolve(o) if o.tag == "ref" else o
        if target.tag != "texture":
            continue
        name = o.attrib.get("name") or target.attrib.get("name")
        if not name:
            o.fail('a texture inside a BSDF needs name="<property>" (e.g. name="reflectance")')
        if files is None:
            o.fail("textures are read only from a scene file")
        out[name] = translate_texture(target, rep, files)
    return out


def apply_textures(node: Node, mat: dict, textures: dict[str, dict], nodes: dict[str, Node]) -> None:
    """Put the translated ``textures`` into the material ``mat`` at the keys its type takes them for."""
    allowed = TEXTURE_PROPERTIES.get(mat["type"], ())
    for name, tex in textures.items():
        if name not in allowed:
            where = f"for {', '.join(allowed)}" if allowed else "nowhere"
            nodes[name].fail(f"a texture for {name!r} is not supported on a {node.attrib.get('type')!r} BSDF "
                             f"(mcocl takes textures {where} there; give a constant)")
        mat[name] = tex
        mat["comment"] = [c for c in mat.get("comment", []) if not c.startswith(f"{name}:")]


__all__ = ["TEXTURE_PROPERTIES", "apply_textures", "textured_properties", "translate_texture"]
