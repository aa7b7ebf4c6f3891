"""Typed properties of Mitsuba elements: ``<float>``, ``<integer>``, ``<boolean>``, ``<string>``, ``<rgb>``,
``<spectrum>``, ``<point>``, ``<vector>`` and ``<transform>``.

:func:`split_children` separates an object's property children (by ``name``)
from its nested objects; :class:`Props` hands typed values to the plugin
translators and remembers which properties were read, so that anything left
over is reported as unsupported.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from .. import transform as tf
from .spectra import EQUAL_ENERGY_WHITE, spectrum_to_linear_srgb
from .xml_source import Node

PROPERTY_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector", "transform")
TRANSFORM_OPS = ("translate", "rotate", "scale", "matrix", "lookat")
# What a colour property is, as Mitsuba 3 reads its texture: "bounded" (a reflectance: a sampled spectrum is
# weighted by D65 and clipped to [0, 1]), "unbounded" (a conductor's eta/k: weighted by D65, not clipped above)
# or "emitted" (a radiance, irradiance or intensity: no D65; one number is the equal-energy white).
ColourUse = Literal["bounded", "unbounded", "emitted"]


@dataclass(eq=False)
class Spectrum:
    """A ``<spectrum>`` as written: one number (``wavelengths`` empty) or wavelength:value pairs.

    Its RGB depends on the property it gives (:data:`ColourUse`; the rules
    are in mcocl/render/mitsuba/spectra.py).
    """

    wavelengths: np.ndarray
    values: np.ndarray

    def rgb(self, use: ColourUse) -> np.ndarray:
        """Linear sRGB (3,) of this spectrum given as a property of kind ``use``, as Mitsuba 3's RGB variants read it."""
        if self.wavelengths.size == 0:
            v = float(self.values[0])
            return v * EQUAL_ENERGY_WHITE if use == "emitted" else np.full(3, v)
        rgb, _clipped = spectrum_to_linear_srgb(self.wavelengths, self.values, emitted=use == "emitted",
                                                bounded=use == "bounded")
        return rgb


@dataclass
class Transform:
    """A ``<transform>``: mcocl transform operations in the order written, their matrix, and a lone lookat.

    ``ops`` are mcocl JSON operations (``translate``/``rotate``/``scale`` as
    written; ``lookat`` and ``matrix`` as ``matrix`` entries); ``matrix`` is
    their composition with :func:`mcocl.render.transform.compose` (the op
    written first acts first, as in Mitsuba).  ``lookat`` holds
    ``(origin, target, up)`` when the transform is exactly one ``<lookat>``.
    """

    ops: list[dict]
    matrix: np.ndarray
    lookat: tuple[list[float], list[float], list[float]] | None = None


def _numbers(node: Node, text: str, what: str) -> list[float]:
    out = []
    for tok in re.split(r"[,\s]+", text.strip()):
        if not tok:
            continue
        try:
            x = float(tok)
        except ValueError:
            node.fail(f"could not parse {what} value {tok!r} as a number")
        if not math.isfinite(x):
            node.fail(f"{what} value {tok!r} is not finite")
        out.append(x)
    return out


def _check_attrs(node: Node, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> None:
    for k in node.attrib:
        if k not in required and k not in optional:
            node.fail(f"unexpected attribute {k!r} (allowed: {', '.join(required + optional)})")
    for k in required:
        if k not in node.attrib:
            node.fail(f"missing required attribute {k!r}")


def _xyz(node: Node, default: float) -> list[float]:
    """A 3-vector from ``value="x y z"`` (or one number for all three) or ``x``/``y``/``z`` attributes."""
    if "value" in node.attrib:
        if any(k in node.attrib for k in "xyz"):
            node.fail('cannot mix "value" with "x"/"y"/"z"')
        v = _numbers(node, node.attrib["value"], node.tag)
        if len(v) not in (1, 3):
            node.fail(f'"value" must have 1 or 3 numbers, got {len(v)}')
        return v * 3 if len(v) == 1 else v
    return [_numbers(node, node.attrib[k], node.tag)[0] if k in node.attrib else default for k in "xyz"]


def _vector3(node: Node, text: str, what: str) -> list[float]:
    v = _numbers(node, text, what)
    if len(v) != 3:
        node.fail(f"{what} must have 3 numbers, got {len(v)}")
    return v


def default_up(direction: np.ndarray) -> list[float]:
    """The up vector Mitsuba picks for a lookat without one: the first tangent of the orthonormal basis
    around the view direction of Duff et al., "Building an orthonormal basis, revisited" (JCGT 6(1), 2017)."""
    n = direction / np.linalg.norm(direction)
    sign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]]


def look_at(origin: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray | None:
    """Mitsuba's camera-to-world matrix: columns left = up × dir, up' = dir × left, dir, origin (None if degenerate)."""
    d = target - origin
    if np.linalg.norm(d) == 0.0:
        return None
    d = d / np.linalg.norm(d)
    left = np.cross(up, d)
    if np.linalg.norm(left) <= 1e-12 * max(np.linalg.norm(up), 1e-300):
        return None
    left = left / np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, origin
    return m


def _unnormalised_rotation(axis: np.ndarray, degrees: float) -> np.ndarray:
    """Mitsuba's ``<rotate>``: Rodrigues' formula with the axis as given (not normalised)."""
    return tf.rotate(axis, degrees, normalise=False)


def parse_transform(node: Node) -> Transform:
    """A ``<transform>`` element: its operations composed in the order written."""
    ops: list[dict] = []
    mats: list[np.ndarray] = []
    lookat = None
    for op in node.children:
        if op.tag == "translate":
            _check_attrs(op, (), ("value", "x", "y", "z"))
            v = _xyz(op, 0.0)
            ops.append({"translate": v})
            mats.append(tf.translate(np.array(v)))
        elif op.tag == "rotate":
            _check_attrs(op, ("angle",), ("value", "x", "y", "z"))
            axis = _xyz(op, 0.0)
            if not any(axis):
                op.fail("the rotation axis is zero")
            angle = _numbers(op, op.attrib["angle"], "angle")
            if len(angle) != 1:
                op.fail("angle must be one number (degrees)")
            if float(np.dot(axis, axis)) == 1.0:
                ops.append({"rotate": {"axis": axis, "angle": angle[0]}})
                mats.append(tf.rotate(np.array(axis), angle[0]))
            else:
                # Mitsuba does not normalise the axis (its rotate is Rodrigues' formula of the axis as written:
                # <rotate x="1" y="1" angle="30"/> scales and shears too, measured with Mitsuba 3.9.1's
                # ScalarTransform4f.rotate); mcocl's JSON rotate normalises, so write Mitsuba's matrix
                m = _unnormalised_rotation(np.array(axis, np.float64), angle[0])
                ops.append({"matrix": m.tolist()})
                mats.append(m)
        elif op.tag == "scale":
            _check_attrs(op, (), ("value", "x", "y", "z"))
            s = _xyz(op, 1.0)
            if 0.0 in s:
                op.fail("a scale factor of zero flattens the shape")
            ops.append({"scale": s[0] if s[0] == s[1] == s[2] else s})
            mats.append(tf.scale(np.array(s)))
        elif op.tag == "matrix":
            _check_attrs(op, ("value",))
            v = _numbers(op, op.attrib["value"], "matrix")
            if len(v) not in (9, 16):
                op.fail(f"a matrix has 16 numbers (4x4, row-major) or 9 (3x3), got {len(v)}")
            m = np.eye(4)
            n = 4 if len(v) == 16 else 3
            m[:n, :n] = np.array(v).reshape(n, n)
            if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
                op.fail("the last row must be 0 0 0 1 (mcocl takes affine transforms only)")
            if abs(np.linalg.det(m[:3, :3])) < 1e-12:
                op.fail("the matrix is singular")
            ops.append({"matrix": m.tolist()})
            mats.append(m)
        elif op.tag == "lookat":
            _check_attrs(op, ("origin", "target"), ("up",))
            o = _vector3(op, op.attrib["origin"], "origin")
            t = _vector3(op, op.attrib["target"], "target")
            u = _vector3(op, op.attrib["up"], "up") if "up" in op.attrib else [0.0, 0.0, 0.0]
            if not any(u) and o != t:
                u = default_up(np.array(t) - np.array(o))
            m = look_at(np.array(o), np.array(t), np.array(u))
            if m is None:
                op.fail("invalid lookat: the target equals the origin, or up is parallel to the view direction")
            ops.append({"matrix": m.tolist()})
            mats.append(m)
            lookat = (o, t, u)
        else:
            op.fail(f"unexpected element inside <transform> (allowed: {', '.join(TRANSFORM_OPS)})")
        if op.children:
            op.children[0].fail("a transform operation has no child elements")
    single = lookat if len(ops) == 1 and node.children[0].tag == "lookat" else None
    return Transform(ops, tf.compose(mats), single)


def parse_property(node: Node) -> Any:
    """The value of one property element (its ``name`` attribute is read by the caller).

    float → float, integer → int, boolean → bool, string → str, rgb → (3,)
    float64 linear RGB, spectrum → :class:`Spectrum` (its RGB depends on the
    property: :meth:`Props.colour`), point/vector → list of 3 floats,
    transform → :class:`Transform`.
    """
    tag = node.tag
    if tag == "transform":
        _check_attrs(node, ("name",))
        return parse_transform(node)
    if node.children:
        node.children[0].fail(f"<{node.children[0].tag}> cannot be a child of a property")
    if tag in ("point", "vector"):
        _check_attrs(node, ("name",), ("value", "x", "y", "z"))
        if "value" not in node.attrib and not all(k in node.attrib for k in "xyz"):
            node.fail('give value="x y z" or all of x, y, z')
        return _xyz(node, 0.0)
    if tag == "spectrum":
        _check_attrs(node, ("name",), ("value", "filename"))
        if "filename" in node.attrib:
            node.fail('spectra from files are not supported (nearest supported: value="λ1:v1, λ2:v2, ..." or <rgb>)')
        return _spectrum(node, node.attrib.get("value", ""))
    _check_attrs(node, ("name", "value"))
    text = node.attrib["value"]
    if tag == "float":
        v = _numbers(node, text, "float")
        if len(v) != 1:
            node.fail(f"expected one number, got {text!r}")
        return v[0]
    if tag == "integer":
        try:
            return int(text.strip())
        except ValueError:
            node.fail(f"could not parse integer value {text!r}")
    if tag == "boolean":
        if text.strip().lower() not in ("true", "false"):
            node.fail(f'could not parse boolean value {text!r} (must be "true" or "false")')
        return text.strip().lower() == "true"
    if tag == "string":
        return text
    if tag == "rgb":
        v = _numbers(node, text, "rgb")
        if len(v) not in (1, 3):
            node.fail(f"<rgb> takes one or three numbers, got {len(v)}")
        return np.array(v * 3 if len(v) == 1 else v)
    node.fail(f"not a property element (properties: {', '.join(PROPERTY_TAGS)})")
    return None


def _spectrum(node: Node, text: str) -> Spectrum:
    if ":" not in text:
        v = _numbers(node, text, "spectrum")
        if len(v) != 1:
            node.fail('a constant spectrum is one number; a sampled one is "λ1:v1, λ2:v2, ..." (nm:value)')
        return Spectrum(np.empty(0), np.array(v))
    lam, val = [], []
    for pair in re.split(r"[,\s]+", re.sub(r"\s*:\s*", ":", text.strip())):
        parts = pair.split(":")
        if len(parts) != 2:
            node.fail(f"expected wavelength:value pairs, got {pair!r}")
        w, x = _numbers(node, parts[0], "wavelength"), _numbers(node, parts[1], "spectrum")
        lam.append(w[0])
        val.append(x[0])
    if len(lam) < 2 or np.any(np.diff(lam) <= 0):
        node.fail("a sampled spectrum needs at least two wavelengths in increasing order")
    return Spectrum(np.array(lam), np.array(val))


class Props:
    """The property children of one object element, read by name; tracks which were used."""

    def __init__(self, owner: Node, nodes: list[Node]) -> None:
        self.owner = owner
        self.nodes: dict[str, Node] = {}
        for n in nodes:
            name = n.attrib.get("name")
            if not name:
                n.fail('a property needs a name="..." attribute')
            if name in self.nodes:
                n.fail(f"property {name!r} is given twice (first at line {self.nodes[name].line})")
            self.nodes[name] = n
        self.read: set[str] = set()

    def __contains__(self, name: str) -> bool:
        return name in self.nodes

    def node(self, name: str) -> Node:
        """The element of property ``name`` (must exist)."""
        return self.nodes[name]

    def get(self, name: str, kinds: tuple[str, ...], default: Any = None) -> Any:
        """The parsed value of ``name`` if given as one of the element ``kinds``, else ``default``."""
        if name not in self.nodes:
            return default
        n = self.nodes[name]
        self.read.add(name)
        if n.tag == "integer" and "float" in kinds:
            return float(parse_property(n))  # Mitsuba reads an integer wherever a float is expected
        if n.tag not in kinds:
            n.fail(f"property {name!r} must be given as <{'> or <'.join(kinds)}>")
        return parse_property(n)

    def colour(self, name: str, default: float | None, use: ColourUse = "bounded") -> np.ndarray | None:
        """An RGB value from ``<rgb>``, ``<spectrum>`` (converted as a property of kind ``use``) or ``<float>`` (grey).

        A ``<float>`` and the default are grey whatever ``use`` is, as in Mitsuba 3's RGB variants.
        """
        v = self.get(name, ("rgb", "spectrum", "float"), None)
        if v is None:
            return None if default is None else np.full(3, float(default))
        if isinstance(v, Spectrum):
            return v.rgb(use)
        return np.full(3, v) if isinstance(v, float) else v

    def unread(self) -> list[Node]:
        """Property elements nobody asked for, in document order."""
        return [n for k, n in self.nodes.items() if k not in self.read]


def split_children(node: Node) -> tuple[Props, list[Node]]:
    """(the properties of ``node``, its nested object and ``<ref>`` elements)."""
    props = [c for c in node.children if c.tag in PROPERTY_TAGS]
    objects = [c for c in node.children if c.tag not in PROPERTY_TAGS]
    return Props(node, props), objects


__all__ = ["PROPERTY_TAGS", "ColourUse", "Props", "Spectrum", "Transform", "look_at", "parse_property", "parse_transform", "split_children"]
