"""Mitsuba BSDF plugins → mcocl materials (scenes/README.md, "Mitsuba XML", table of BSDFs).

Supported exactly: ``diffuse``; ``conductor`` and ``roughconductor`` with a
``material`` preset (Mitsuba 3's default ``"none"``: a perfect mirror times
``specular_reflectance``; the presets' RGB eta/k in mcocl/conductor_iors.py) or
``eta``/``k``, the rough one with ``distribution`` ``"ggx"`` or ``"beckmann"``
(the default) and ``alpha`` or ``alpha_u``/``alpha_v``;
``dielectric``, ``thindielectric`` and ``roughdielectric`` (roughness as
``roughconductor``) with numeric or named ``int_ior``/``ext_ior`` (Mitsuba's
defaults: BK7 1.5046 inside, air 1.000277 outside); ``plastic`` and
``roughplastic`` (linear, a specular reflectance of 1; polypropylene 1.49
inside, air outside; roughness as ``roughconductor``, isotropic);
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
from ...conductor_iors import CONDUCTOR_IORS
from .file_search import FileSearch
from .properties import split_children
from .report import Reporter, nearest
from .spectra import named_ior, nearest_ior_names
from .texture import apply_textures, textured_properties
from .xml_source import Node

# Every registered BSDF (mcocl/bsdf_registry.py).  The ones below have their own
# translators (Mitsuba's properties differ from mcocl's keys); any other is read
# by :func:`_registered`, property name = scene-file key.
SUPPORTED = tuple(BSDFS)

# Unsupported BSDF plugin → (nearest supported alternative, lenient substitute).
SUBSTITUTES = {
    "principled": ("diffuse", "a diffuse BSDF with its base_color (default 0.5)"),
    "twosided": ("one nested BSDF, the same on both sides", "its first nested BSDF on both sides"),
    "mask": ("its nested BSDF", "its nested BSDF (opacity ignored)"),
    "bumpmap": ("its nested BSDF", "its nested BSDF (bumps ignored)"),
    "normalmap": ("its nested BSDF", "its nested BSDF (normal map ignored)"),
    "blendbsdf": ("one of its two BSDFs", "its first nested BSDF"),
}
NESTED = ("mask", "bumpmap", "normalmap", "blendbsdf")

_COLOUR_TAGS = ("rgb", "spectrum", "float")
# Colour properties Mitsuba 3 reads as unbounded textures (a sampled spectrum is not clipped to 1).
UNBOUNDED_COLOURS = ("eta", "k")


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


def translate_bsdf(node: Node, rep: Reporter, resolve, files: FileSearch | None = None) -> dict:
    """The mcocl material of a ``<bsdf>`` element.

    ``resolve(ref_node)`` returns the element a ``<ref id>`` points to (for
    BSDFs nested in ``twosided`` and friends, and textures); bitmap textures'
    files must lie in ``files`` (mcocl/render/mitsuba/texture.py).
    """
    kind = node.attrib.get("type")
    if not kind:
        node.fail('a <bsdf> needs a type="..." attribute')
    props, objects = split_children(node)
    comments: list[str] = []
    if kind == "twosided":
        return _twosided(node, objects, rep, resolve, comments, files)
    if kind in NESTED:
        alt, sub = SUBSTITUTES[kind]
        inner = [resolve(o) if o.tag == "ref" else o for o in objects if o.tag in ("bsdf", "ref")]
        rep.unsupported(node, f"the {kind!r} BSDF", alt, sub if inner else None, comments)
        mat = translate_bsdf(inner[0], rep, resolve, files)
        mat["comment"] = comments + mat.get("comment", [])
        return mat
    textures = textured_properties(objects, resolve, rep, files)
    for o in objects:
        if (resolve(o) if o.tag == "ref" else o).tag == "texture":
            continue
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
        mat = _dielectric_iors(node, "dielectric", props, rep, comments)
        rep.leftover(node, props.unread(), ("int_ior", "ext_ior", *DIELECTRIC_TINTS), comments)
    elif kind in ("plastic", "roughplastic"):
        mat = _plastic(node, props, rep, comments, kind=kind)
    elif kind == "roughdielectric":
        mat = _rough_dielectric(node, props, rep, comments)
    elif kind == "thindielectric":
        mat = _thin_dielectric(node, props, rep, comments)
    elif kind in BSDFS:
        mat = _registered(node, kind, props, rep, comments)
    elif kind in SUBSTITUTES:
        alt, sub = SUBSTITUTES[kind]
        rep.unsupported(node, f"the {kind!r} BSDF", alt, sub, comments)
        mat = {"type": "diffuse", "reflectance": rgb_json(props.colour("base_color", 0.5))}  # principled
    else:
        rep.unsupported(node, f"the BSDF plugin {kind!r}", nearest(kind, SUPPORTED), "a diffuse BSDF of reflectance 0.5",
                        comments)
        mat = {"type": "diffuse", "reflectance": 0.5}
    if comments:
        mat["comment"] = comments
    apply_textures(node, mat, textures, {o.attrib.get("name", ""): o for o in objects})
    return mat


def _twosided(node: Node, objects: list[Node], rep: Reporter, resolve, comments: list[str],
              files: FileSearch | None) -> dict:
    """Mitsuba's ``twosided``: the nested BSDF with mcocl's ``twosided`` key (the front BSDF mirrored behind)."""
    inner = [resolve(o) if o.tag == "ref" else o for o in objects if o.tag in ("bsdf", "ref")]
    if not inner:
        node.fail("a twosided BSDF needs a nested <bsdf> (or a <ref> to one)")
    if len(inner) > 1:
        rep.unsupported(node, "a twosided BSDF with different front and back BSDFs",
                        "one nested BSDF, the same on both sides", "its first nested BSDF on both sides", comments)
    mat = translate_bsdf(inner[0], rep, resolve, files)
    if mat["type"] in ("dielectric", "roughdielectric", "thindielectric"):
        comments.append(f"twosided: a {mat['type']} is two-sided already")
    elif any(p.key == "twosided" for p in BSDFS[mat["type"]].params):
        mat["twosided"] = True
    else:
        rep.unsupported(node, f"a twosided {mat['type']!r}", "twosided around diffuse, conductor, roughconductor "
                        "or plastic", f"a one-sided {mat['type']!r}", comments)
    if comments:
        mat["comment"] = comments + mat.get("comment", [])
    return mat


def _plastic(node: Node, props, rep: Reporter, comments: list[str], kind: str = "plastic") -> dict:
    """Mitsuba's ``plastic`` or ``roughplastic`` (kernels/render/bsdf_plastic.cl, bsdf_roughplastic.cl): linear,
    with a specular reflectance of 1; the rough one's roughness as ``roughconductor``'s."""
    if "diffuse_reflectance" not in props:
        comments.append("diffuse_reflectance: Mitsuba's default 0.5")
    mat = {"type": kind, "diffuse_reflectance": rgb_json(props.colour("diffuse_reflectance", 0.5)),
           "int_ior": _ior(props, "int_ior", "polypropylene", comments),
           "ext_ior": _ior(props, "ext_ior", "air", comments)}
    v = props.colour("specular_reflectance", 1.0)
    if np.any(v != 1.0):
        rep.unsupported(props.node("specular_reflectance"), "specular_reflectance other than 1", "1 (leave it out)",
                        "1", comments)
    if props.get("nonlinear", ("boolean",), False):
        rep.unsupported(props.node("nonlinear"), "the nonlinear plastic model", "nonlinear=false",
                        "the linear model", comments)
    supported: tuple[str, ...] = ("diffuse_reflectance", "int_ior", "ext_ior", "specular_reflectance", "nonlinear")
    if kind == "roughplastic":
        _roughness(node, kind, props, rep, comments, mat)
        if "alpha_u" in mat:
            props.node("alpha_u").fail("roughplastic is isotropic in Mitsuba too: give alpha")
        supported += ROUGHNESS_PROPS
        # tests/data/README.md: mcocl integrates the coat's internal reflectance exactly where Mitsuba averages
        # 64 cosines; measured on the widely copied point-cloud scene template (a white GGX floor, alpha 0.05,
        # int_ior 1.46) the whole image came out 1.8 % brighter than Mitsuba 3.9.1's (0.9 % at alpha 0.3)
        comments.append("roughplastic: the diffuse base's light is 1-2 % brighter than Mitsuba's (mcocl integrates "
                        "the coat's internal reflectance exactly, Mitsuba averages 64 cosines)")
    rep.leftover(node, props.unread(), supported, comments)
    return mat


def _registered(node: Node, kind: str, props, rep: Reporter, comments: list[str]) -> dict:
    """A registered BSDF without a translator of its own: each scene-file key read from the property of its name."""
    mat: dict[str, Any] = {"type": kind}
    spec = BSDFS[kind]
    for p in spec.params:
        if p.optional and p.key not in props:
            continue
        if p.kind == "rgb":
            v = props.colour(p.key, p.default, "unbounded" if p.key in UNBOUNDED_COLOURS else "bounded")
            if v is not None:
                mat[p.key] = rgb_json(v)
        elif p.kind in ("flag", "choice", "name"):
            v = props.get(p.key, ("boolean",) if p.kind == "flag" else ("string",), p.default)
            if v is not None:
                mat[p.key] = v
        else:
            v = props.get(p.key, ("float",), p.default)
            if v is not None:
                mat[p.key] = float(v)
        if p.key not in mat:
            node.fail(f"a {kind!r} BSDF needs the property {p.key!r}")
    rep.leftover(node, props.unread(), tuple(p.key for p in spec.params), comments)
    return mat


def _roughness(node: Node, kind: str, props, rep: Reporter, comments: list[str], mat: dict[str, Any]) -> None:
    """``distribution``, ``alpha`` or ``alpha_u``/``alpha_v`` (Mitsuba's rules) into ``mat``."""
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
        if au is None or av is None:
            node.fail(f"a {kind!r} needs both alpha_u and alpha_v (Mitsuba's rule)")
        if alpha is not None:
            node.fail(f"a {kind!r} takes either alpha or alpha_u/alpha_v, not both (Mitsuba's rule)")
        if au == av:
            mat["alpha"] = au
        else:
            mat["alpha_u"], mat["alpha_v"] = au, av
        return
    if alpha is None:
        comments.append("alpha: Mitsuba's default 0.1")
        alpha = 0.1
    mat["alpha"] = alpha
    if props.get("sample_visible", ("boolean",), True) is False:
        comments.append("sample_visible=false ignored: mcocl samples GGX by visible normals, Beckmann by D(m) cos "
                        "(same expectation)")


ROUGHNESS_PROPS = ("distribution", "alpha", "alpha_u", "alpha_v", "sample_visible")


def _conductor(node: Node, kind: str, props, rep: Reporter, comments: list[str]) -> dict:
    """Mitsuba 3's ``conductor``/``roughconductor``: ``material`` (default "none", a perfect mirror) or ``eta``/``k``."""
    mat: dict[str, Any] = {"type": kind, "specular_reflectance": rgb_json(props.colour("specular_reflectance", 1.0))}
    material = props.get("material", ("string",), None)
    has_ior = "eta" in props or "k" in props
    if material is not None and material != "none" and has_ior:
        props.node("material").fail("give either material or eta/k, not both (Mitsuba's rule)")
    if material is not None and material != "none":
        if material not in CONDUCTOR_IORS:
            props.node("material").fail(f"unknown conductor material {material!r} (closest: "
                                        f"{nearest(material, tuple(CONDUCTOR_IORS))})")
        mat["material"] = material
        comments.append(f"material: {material!r}, RGB eta/k of Mitsuba's table (mcocl/conductor_iors.py)")
    elif has_ior:
        if "eta" in props:
            mat["eta"] = rgb_json(props.colour("eta", 0.0, "unbounded"))
        if "k" in props:
            mat["k"] = rgb_json(props.colour("k", 1.0, "unbounded"))
    supported = ("material", "eta", "k", "specular_reflectance")
    if kind == "roughconductor":
        _roughness(node, kind, props, rep, comments, mat)
        supported += ROUGHNESS_PROPS
    rep.leftover(node, props.unread(), supported, comments)
    return mat


# The tints of a (rough, thin) dielectric's reflection and transmission: mcocl's keys of the same names.
DIELECTRIC_TINTS = ("specular_reflectance", "specular_transmittance")


def _dielectric_iors(node: Node, kind: str, props, rep: Reporter, comments: list[str]) -> dict:
    """The iors and the constant tints (those given; a textured one is put in by apply_textures) of a
    (rough, thin) dielectric."""
    mat: dict[str, Any] = {"type": kind, "int_ior": _ior(props, "int_ior", "bk7", comments),
                           "ext_ior": _ior(props, "ext_ior", "air", comments)}
    for k in DIELECTRIC_TINTS:
        if k in props:
            mat[k] = rgb_json(props.colour(k, 1.0))
    return mat


def _rough_dielectric(node: Node, props, rep: Reporter, comments: list[str]) -> dict:
    """Mitsuba 3's ``roughdielectric`` (kernels/render/bsdf_roughdielectric.cl)."""
    mat = _dielectric_iors(node, "roughdielectric", props, rep, comments)
    _roughness(node, "roughdielectric", props, rep, comments, mat)
    rep.leftover(node, props.unread(), ("int_ior", "ext_ior", *DIELECTRIC_TINTS, *ROUGHNESS_PROPS), comments)
    return mat


def _thin_dielectric(node: Node, props, rep: Reporter, comments: list[str]) -> dict:
    """Mitsuba 3's ``thindielectric`` (kernels/render/bsdf_thindielectric.cl)."""
    mat = _dielectric_iors(node, "thindielectric", props, rep, comments)
    rep.leftover(node, props.unread(), ("int_ior", "ext_ior", *DIELECTRIC_TINTS), comments)
    return mat


__all__ = ["SUBSTITUTES", "SUPPORTED", "rgb_json", "translate_bsdf"]
