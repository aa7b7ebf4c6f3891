"""Mitsuba ``point``, ``spot`` and ``directional`` emitters → entries of mcocl's ``lights`` list.

Mitsuba 3's conventions (its emitter plugin documentation), kept in
mcocl/render/delta_lights.py:

- ``point``: ``intensity`` (default 1) at ``position`` or at ``to_world``'s
  origin (only one of the two);
- ``spot``: ``intensity`` (default 1), ``cutoff_angle`` (default 20°),
  ``beam_width`` (default 3/4 of the cutoff); it sits at ``to_world``'s origin
  and shines along its +z axis (usually written as a ``lookat``);
- ``directional``: ``irradiance`` (default 1) travelling along ``direction``
  or ``to_world``'s +z axis (default +z).
"""

from __future__ import annotations

import numpy as np

from .. import transform as tf
from .bsdf import rgb_json
from .properties import Props, split_children
from .report import Reporter
from .xml_source import Node

DELTA_EMITTERS = ("point", "spot", "directional")


def _to_world(props: Props) -> np.ndarray:
    t = props.get("to_world", ("transform",), None)
    return np.eye(4) if t is None else np.asarray(t.matrix, np.float64)


def _axis(node: Node, m: np.ndarray, what: str) -> list[float]:
    """to_world's +z axis (a direction), normalised."""
    d = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
    n = float(np.linalg.norm(d))
    if not n > 0.0:
        node.fail(f"the to_world transform maps the {what} to the zero vector")
    return [float(x) for x in d / n]


def _colour(props: Props, name: str, comments: list[str]) -> list[float] | float:
    if name not in props:
        comments.append(f"{name}: Mitsuba's default 1")
    rgb = props.colour(name, 1.0, "emitted")
    if np.any(rgb < 0):
        props.node(name).fail(f"{name} must be >= 0")
    return rgb_json(rgb)


def translate_delta_light(node: Node, rep: Reporter) -> dict:
    """The mcocl ``lights`` entry of a top-level ``point``, ``spot`` or ``directional`` emitter."""
    kind = node.attrib.get("type", "")
    props, objects = split_children(node)
    comments: list[str] = []
    for o in objects:
        rep.unsupported(o, f"<{o.tag}> inside a {kind} emitter (textured intensity)", "a constant <rgb>",
                        "the constant property (default 1)", comments)
    out: dict = {"type": kind}
    if kind == "point":
        if "position" in props and "to_world" in props:
            node.fail("a point emitter takes either 'position' or 'to_world', not both")
        pos = props.get("position", ("point",), None)
        if pos is None:
            pos = tf.apply_points(_to_world(props), np.zeros((1, 3)))[0]
        out["position"] = [float(x) for x in pos]
        out["intensity"] = _colour(props, "intensity", comments)
        supported: tuple[str, ...] = ("position", "to_world", "intensity")
    elif kind == "spot":
        m = _to_world(props)
        out["position"] = [float(x) for x in tf.apply_points(m, np.zeros((1, 3)))[0]]
        out["direction"] = _axis(node, m, "spot's axis")
        out["intensity"] = _colour(props, "intensity", comments)
        cutoff = props.get("cutoff_angle", ("float",), None)
        if cutoff is not None:
            if not 0.0 < cutoff <= 180.0:
                props.node("cutoff_angle").fail(f"cutoff_angle must lie in (0, 180] degrees, got {cutoff:g}")
            out["cutoff_angle"] = cutoff
        beam = props.get("beam_width", ("float",), None)
        if beam is not None:
            limit = 20.0 if cutoff is None else cutoff
            if not 0.0 <= beam <= limit:
                props.node("beam_width").fail(f"beam_width must lie in [0, cutoff_angle = {limit:g}] degrees, "
                                              f"got {beam:g}")
            out["beam_width"] = beam
        supported = ("to_world", "intensity", "cutoff_angle", "beam_width")
    else:
        if "direction" in props and "to_world" in props:
            node.fail("a directional emitter takes either 'direction' or 'to_world', not both")
        d = props.get("direction", ("vector",), None)
        if d is None:
            out["direction"] = _axis(node, _to_world(props), "direction")
        else:
            d = np.asarray(d, np.float64)
            if not np.linalg.norm(d) > 0.0:
                props.node("direction").fail("direction must not be the zero vector")
            out["direction"] = [float(x) for x in d / np.linalg.norm(d)]
        out["irradiance"] = _colour(props, "irradiance", comments)
        supported = ("direction", "to_world", "irradiance")
    rep.leftover(node, props.unread(), supported, comments)
    if comments:
        out["comment"] = comments
    return out


__all__ = ["DELTA_EMITTERS", "translate_delta_light"]
