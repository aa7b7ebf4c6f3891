"""Mitsuba ``shapegroup`` and ``instance`` shapes, flattened at load time.

A ``<shape type="shapegroup" id="g">`` holds ``<shape>`` elements that are not
rendered on their own; each ``<shape type="instance">`` with ``<ref id="g"/>``
and a ``to_world`` adds every shape of the group once more, its own transform
followed by the instance's (Mitsuba 3 applies the instance's ``to_world`` to
the group's world-space shapes, so the shape's operations act first:
mcocl/render/transform.py composes a list in order).  Meshes thus become new
vertex arrays (mcocl/render/scene.py transforms them when the scene is read);
a sphere stays an analytic sphere while the composed transform is a
similarity, and is an error naming the sphere otherwise.  Mitsuba's rules hold
here too: a group holds no emitter (Mitsuba does not instance emitters) and no
shapegroup or instance (no nested instancing).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import transform as tf
from .properties import split_children
from .report import Reporter
from .xml_source import Node

GROUP = "shapegroup"
INSTANCE = "instance"


def _label(n: Node) -> str:
    return f"<shape type=\"{n.attrib.get('type', '')}\"> of line {n.line}"


def group_members(group: Node, resolve: Callable[[Node], Node]) -> list[Node]:
    """The ``<shape>`` elements of a ``shapegroup``, checked against Mitsuba's rules.

    Raises:
        InputError: a property or non-shape child, a nested shapegroup or
            instance, or an emitter on one of its shapes (naming the element).
    """
    members = []
    for ch in group.children:
        if ch.tag != "shape":
            what = "a <ref> (write the shape inside the group)" if ch.tag == "ref" else f"<{ch.tag}>"
            ch.fail(f"a shapegroup holds only <shape> elements, not {what}")
        kind = ch.attrib.get("type", "")
        if kind in (GROUP, INSTANCE):
            ch.fail(f"nested instancing: a shapegroup may not hold a {kind} (Mitsuba does not allow it either)")
        for o in ch.children:
            target = resolve(o) if o.tag == "ref" else o
            if target.tag == "emitter":
                o.fail("an emitter inside a shapegroup: Mitsuba does not instance emitters "
                       "(place the emitting shape outside the group)")
        members.append(ch)
    return members


def expand_instance(node: Node, resolve: Callable[[Node], Node], translate: Callable[[Node], dict | None],
                    rep: Reporter) -> list[dict]:
    """The mcocl shapes an ``instance`` element adds: its group's shapes with its ``to_world`` composed on.

    ``translate`` turns one ``<shape>`` into an mcocl shape (None: dropped in
    lenient mode).
    """
    props, objects = split_children(node)
    refs = [o for o in objects if o.tag == "ref"]
    for o in objects:
        if o.tag != "ref":
            o.fail(f"an instance holds one <ref> to a shapegroup and a to_world, not <{o.tag}>")
    if len(refs) != 1:
        (refs[1] if refs else node).fail('an instance needs exactly one <ref id="..."/> to a shapegroup')
    group = resolve(refs[0])
    if group.tag != "shape" or group.attrib.get("type") != GROUP:
        refs[0].fail(f"an instance refers to a shapegroup, but {refs[0].attrib['id']!r} is "
                     f"<{group.tag} type=\"{group.attrib.get('type', '')}\"> (line {group.line})")
    t = props.get("to_world", ("transform",), None)
    ops = t.ops if t is not None else []
    comments = [f"instance of shapegroup {refs[0].attrib['id']!r} (line {group.line}), at line {node.line}: "
                "the instance's to_world follows the shape's own"]
    rep.leftover(node, props.unread(), ("to_world",), comments)
    out = []
    for member in group_members(group, resolve):
        s = translate(member)
        if s is None:
            continue
        if ops:
            s["transform"] = s.get("transform", []) + ops
        if s["type"] == "sphere" and t is not None:
            own = split_children(member)[0].get("to_world", ("transform",), None)
            if tf.uniform_scale_of(t.matrix @ (own.matrix if own is not None else np.eye(4))) is None:
                node.fail(f"the instance's to_world makes the sphere {_label(member)} an ellipsoid: a sphere "
                          "allows only translations, rotations and uniform scales")
        s["comment"] = list(s.get("comment", [])) + comments
        if "id" in node.attrib:
            s["name"] = f"{node.attrib['id']}/{s.get('name', member.attrib.get('type', ''))}"
        out.append(s)
    return out


__all__ = ["GROUP", "INSTANCE", "expand_instance", "group_members"]
