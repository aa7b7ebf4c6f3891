"""Mitsuba BSDF plugins → mcocl materials (scenes/README.md, "Mitsuba XML", table of BSDFs).

Supported exactly: ``diffuse``; ``conductor`` with ``material="none"`` (a
perfect mirror times ``specular_reflectance``); ``roughconductor`` with
``material="none"``, ``distribution`` ``"ggx"`` or ``"beckmann"`` (the default) and an isotropic ``alpha``;
``dielectric`` with numeric or named ``int_ior``/``ext_ior`` (Mitsuba's
defaults: BK7 1.5046 inside, air 1.000277 outside); ``plastic`` (linear, a
specular reflectance of 1; polypropylene 1.49 inside, air outside);
``twosided`` around one BSDF that has mcocl's ``twosided`` key (diffuse,
conductors, plastic) sets that key; around a dielectric it changes nothing
(glass is two-sided already).  Any other BSDF registered
in mcocl/bsdf_registry.py is read property by property, each property named
like its scene-file key.  Everything else is an error naming the nearest
alternative, or with ``lenient`` the substitute listed in :data:`SUBSTITUTES`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...bsdf_registry import BSDFS
from .properties import split_children
from .report import Reporter, nearest
from .spectra import named_ior, nearest_ior_names
from .xml_source import Node

# Every registered BSDF (mcocl/bsdf_registry.py).  The five below have their own
# translators (Mitsuba's properties differ from mcocl's keys); any other is read
# by :func:`_registered`, property name = scene-file key.
SUPPORTED = tuple(BSDFS)

# Unsupported BSDF plugin → (nearest supported alternative, lenient substitute).
SUBSTITUTES = {
    "roughplastic": ("plastic", "a smooth plastic with the same diffuse_reflectance and iors"),
    "principled": ("diffuse", "a diffuse BSDF with its base_color (default 0.5)"),
    "roughdielectric": ("dielectric", "a smooth dielectric with the same int_ior/ext_ior"),
    "thindielectric": ("dielectric", "a smooth (thick) dielectric with the same int_ior/ext_ior"),
    "twosided": ("one nested BSDF, the same on both sides", "its first nested BSDF on both sides"),
    "mask": ("its nested BSDF", "its nested BSDF (opacity ignored)"),
    "bumpmap": ("its nested BSDF", "its nested BSDF (bumps ignored)"),
    "normalmap": ("its nested BSDF", "its nested BSDF (normal map ignored)"),
    "blendbsdf": ("one of its two BSDFs", "its first nested BSDF"),
}
NESTED = ("mask", "bumpmap", "normalmap", "blendbsdf")

_COLOUR_TAGS = ("rgb", "spectrum", "float")


def _ior(props, name: str, default_name: str, comments: list[str]) -> float:
    if name not in props:
        comments.append(f"{name}: Mitsuba's default {default_name!r} = {named_ior(default_name)}")
        return float(named_ior(default_name))
    n = props.node(name)
    v = props.get(name, ("float", "string"))
    if isinstance(v, float):
        return v
    ior = named_ior(v)
    if ior is None:
        n.fail(f"unknown index of refraction {v!r} (closest names: {', '.join(nearest_ior_names(v)) or 'none'}; "
               "or give a number)")
    comments.append(f"{name}: {v!r} = {ior} (Mitsuba's table)")
    return float(ior)


def rgb_json(v: np.ndarray) -> Any:
    """An RGB value as JSON: one number when grey."""
    vals = [float(x) for x in v]
    return vals[0] if vals[0] == vals[1] == vals[2] else vals


def translate_bsdf(node: Node, rep: Reporter, resolve) -> dict:
    """The mcocl material of a ``<bsdf>`` element.

    ``resolve(ref_node)`` returns the element a ``<ref id>`` points to (for
    BSDFs nested in ``twosided`` and friends).
    """
    kind = node.attrib.get("type")
    if not kind:
        node.fail('a <bsdf> needs a type="..." attribute')
    props, objects = split_children(node)
    comments: list[str] = []
    if kind == "twosided":
        return _twosided(node, objects, rep, resolve, comments)
    if kind in NESTED:
        alt, sub = SUBSTITUTES[kind]
        inner = [resolve(o) if o.tag == "ref" else o for o in objects if o.tag in ("bsdf", "ref")]
        rep.unsupported(node, f"the {kind!r} BSDF", alt, sub if inner else None, comments)
        mat = translate_bsdf(inner[0], rep, resolve)
        mat["comment"] = comments + mat.get("comment", [])
        return mat
    for o in objects:
        what = "textures" if o.tag in ("texture", "ref") else f"a nested <{o.tag}>"
        rep.unsupported(o, f"{what} in a BSDF", "a constant <rgb> value", "a constant (the property's default)",
                        comments)
    if kind == "diffuse":
        name = "diffuse_reflectance" if node.version < (2, 0, 0) and "diffuse_reflectance" in props else "reflectance"
        if name not in props:
            comments.append("reflectance: Mitsuba's default 0.5")
        mat = {"type": "diffuse", "reflectance": rgb_json(props.colour(name, 0.5))}
        rep.leftover(node, props.unread(), ("reflectance",), comments)
    elif kind in ("conductor", "roughconductor"):
        mat = _conductor(node, kind, props, rep, comments)
    elif kind == "dielectric":
        ni = _ior(props, "int_ior", "bk7", comments)
        ne = _ior(props, "ext_ior", "air", comments)
        for k in ("specular_reflectance", "specular_transmittance"):
            v = props.colour(k, 1.0)
            if np.any(v != 1.0):
                rep.unsupported(props.node(k), f"{k} other than 1", "1 (leave it out)", "1", comments)
        mat = {"type": "dielectric", "int_ior": ni, "ext_ior": ne}
        rep.leftover(node, props.unread(), ("int_ior", "ext_ior", "specular_reflectance",
                                            "specular_transmittance"), comments)
    elif kind == "plastic":
        mat = _plastic(node, props, rep, comments)
    elif kind in BSDFS:
        mat = _registered(node, kind, props, rep, comments)
    elif kind in SUBSTITUTES:
        alt, sub = SUBSTITUTES[kind]
        rep.unsupported(node, f"the {kind!r} BSDF", alt, sub, comments)
        if alt == "plastic":
            mat = _plastic(node, props, rep, comments, check_leftovers=False)
        elif alt == "diffuse":
            key = "base_color" if kind == "principled" else "diffuse_reflectance"
            mat = {"type": "diffuse", "reflectance": rgb_json(props.colour(key, 0.5))}
        else:
            mat = {"type": "dielectric", "int_ior": _ior(props, "int_ior", "bk7", comments),
                   "ext_ior": _ior(props, "ext_ior", "air", comments)}
    else:
        rep.unsupported(node, f"the BSDF plugin {kind!r}", nearest(kind, SUPPORTED), "a diffuse BSDF of reflectance 0.5",
                        comments)
        mat = {"type": "diffuse", "reflectance": 0.5}
    if comments:
        mat["comment"] = comments
    return mat


def _twosided(node: Node, objects: list[Node], rep: Reporter, resolve, comments: list[str]) -> dict:
    """Mitsuba's ``twosided``: the nested BSDF with mcocl's ``twosided`` key (the front BSDF mirrored behind)."""
    inner = [resolve(o) if o.tag == "ref" else o for o in objects if o.tag in ("bsdf", "ref")]
    if not inner:
        node.fail("a twosided BSDF needs a nested <bsdf> (or a <ref> to one)")
    if len(inner) > 1:
        rep.unsupported(node, "a twosided BSDF with different front and back BSDFs",
                        "one nested BSDF, the same on both sides", "its first nested BSDF on both sides", comments)
    mat = translate_bsdf(inner[0], rep, resolve)
    if mat["type"] == "dielectric":
        comments.append("twosided: a dielectric is two-sided already")
    elif any(p.key == "twosided" for p in BSDFS[mat["type"]].params):
        mat["twosided"] = True
    else:
        rep.unsupported(node, f"a twosided {mat['type']!r}", "twosided around diffuse, conductor, roughconductor "
                        "or plastic", f"a one-sided {mat['type']!r}", comments)
    if comments:
        mat["comment"] = comments + mat.get("comment", [])
    return mat


def _plastic(node: Node, props, rep: Reporter, comments: list[str], check_leftovers: bool = True) -> dict:
    """Mitsuba's ``plastic`` (kernels/render/bsdf_plastic.cl): linear, with a specular reflectance of 1."""
    if "diffuse_reflectance" not in props:
        comments.append("diffuse_reflectance: Mitsuba's default 0.5")
    mat = {"type": "plastic", "diffuse_reflectance": rgb_json(props.colour("diffuse_reflectance", 0.5)),
           "int_ior": _ior(props, "int_ior", "polypropylene", comments),
           "ext_ior": _ior(props, "ext_ior", "air", comments)}
    v = props.colour("specular_reflectance", 1.0)
    if np.any(v != 1.0):
        rep.unsupported(props.node("specular_reflectance"), "specular_reflectance other than 1", "1 (leave it out)",
                        "1", comments)
    if props.get("nonlinear", ("boolean",), False):
        rep.unsupported(props.node("nonlinear"), "the nonlinear plastic model", "nonlinear=false",
                        "the linear model", comments)
    if check_leftovers:
        rep.leftover(node, props.unread(), ("diffuse_reflectance", "int_ior", "ext_ior", "specular_reflectance",
                                            "nonlinear"), comments)
    return mat


def _registered(node: Node, kind: str, props, rep: Reporter, comments: list[str]) -> dict:
    """A registered BSDF without a translator of its own: each scene-file key read from the property of its name."""
    mat: dict[str, Any] = {"type": kind}
    spec = BSDFS[kind]
    for p in spec.params:
        if p.kind == "rgb":
            v = props.colour(p.key, p.default)
            if v is not None:
                mat[p.key] = rgb_json(v)
        else:
            v = props.get(p.key, ("float",), p.default)
            if v is not None:
                mat[p.key] = float(v)
        if p.key not in mat:
            node.fail(f"a {kind!r} BSDF needs the property {p.key!r}")
    rep.leftover(node, props.unread(), tuple(p.key for p in spec.params), comments)
    return mat


def _conductor(node: Node, kind: str, props, rep: Reporter, comments: list[str]) -> dict:
    material = props.get("material", ("string",), None)
    if material is None:
        material = "Cu"
        comments.append("material: Mitsuba's default is 'Cu' (copper)")
    if material.lower() != "none" or "eta" in props or "k" in props:
        at = props.node("material") if "material" in props else node
        what = f"the conductor material {material!r}" if material.lower() != "none" else "eta/k"
        rep.unsupported(at, what + " (spectral complex IOR)",
                        f'{kind} with material="none" (a perfect mirror) and a specular_reflectance of the metal\'s colour',
                        'material="none" with its specular_reflectance', comments)
        props.read.update({"eta", "k"})
    mat: dict[str, Any] = {"type": kind, "specular_reflectance": rgb_json(props.colour("specular_reflectance", 1.0))}
    supported = ("material", "specular_reflectance")
    if kind == "roughconductor":
        dist = props.get("distribution", ("string",), None)
        if dist is None:
            comments.append("distribution: Mitsuba's default 'beckmann'")
            dist = "beckmann"
        elif dist not in ("ggx", "beckmann"):
            rep.unsupported(props.node("distribution"), f"the microfacet distribution {dist!r}",
                            'distribution="ggx" or "beckmann"', "GGX with the same alpha", comments)
            dist = "ggx"
        if dist == "beckmann":  # mcocl's JSON default is GGX
            mat["distribution"] = "beckmann"
        alpha = props.get("alpha", ("float",), None)
        au, av = props.get("alpha_u", ("float",), None), props.get("alpha_v", ("float",), None)
        if au is not None or av is not None:
            au = alpha if au is None else au
            av = alpha if av is None else av
            if au is None or av is None:
                node.fail("give both alpha_u and alpha_v (or alpha)")
            if au != av:
                rep.unsupported(props.node("alpha_u" if "alpha_u" in props else "alpha_v"),
                                "anisotropic roughness (alpha_u != alpha_v)", "an isotropic alpha",
                                f"alpha = sqrt(alpha_u * alpha_v) = {np.sqrt(au * av):.6g}", comments)
            alpha = float(np.sqrt(au * av)) if au != av else au
        if alpha is None:
            comments.append("alpha: Mitsuba's default 0.1")
            alpha = 0.1
        mat["alpha"] = alpha
        if props.get("sample_visible", ("boolean",), True) is False:
            comments.append("sample_visible=false ignored: mcocl samples GGX by visible normals, Beckmann by D(m) cos (same expectation)")
        supported += ("distribution", "alpha", "alpha_u", "alpha_v", "sample_visible")
    rep.leftover(node, props.unread(), supported, comments)
    return mat


__all__ = ["SUBSTITUTES", "SUPPORTED", "rgb_json", "translate_bsdf"]
