"""Mitsuba ``<sensor>`` (with its ``<film>`` and ``<sampler>``) and ``<integrator>`` → mcocl camera and settings.

- ``perspective``: ``fov`` on ``fov_axis`` (Mitsuba's default ``"x"``) becomes
  mcocl's ``fov`` on the image's smaller axis,
  ``tan(fov'/2) = tan(fov/2) · smaller / size(axis)`` with size(x) = width,
  size(y) = height, size(diagonal) = √(width² + height²); the value is kept
  unchanged when the axis already is the smaller one.  ``focal_length``
  ("50mm", Mitsuba's default when no fov is given) is a 35 mm film equivalent:
  ``fov = 2 atan(√(36² + 24²) / (2 f))`` on the diagonal.  ``to_world``:
  a lone ``<lookat>`` gives origin/target/up as written; any other rigid
  transform gives origin = M·0, target = origin + M·ẑ, up = M·ŷ.
- ``thinlens``: the same, plus ``aperture_radius`` (required, as in Mitsuba)
  and ``focus_distance`` (Mitsuba's default: ``far_clip``, 10^4) → mcocl's
  thin-lens camera.
- ``hdrfilm``: ``width``/``height`` (Mitsuba's defaults 768 × 576); ``<rfilter>`` ``box``,
  ``tent`` (``radius``, default 1) or ``gaussian`` (``stddev``, default 0.5; Mitsuba's default
  filter when the film names none) → ``camera.filter`` (mcocl/render/pixel_filter.py);
  ``crop_offset_x/y``, ``crop_width/height`` → ``camera.crop`` (the image is the window).
- ``near_clip`` → ``camera.near_clip`` and ``far_clip`` → ``camera.far_clip``, with Mitsuba's
  defaults 0.01 and 10⁴ when the file gives none (primary rays start on the near plane and end on
  the far one, along the optical axis; the clips are launch parameters of the render kernels, so
  they cost no build of their own).  An explicit ``near_clip`` of 0 clips nothing (Mitsuba
  requires it positive).
- samplers ``independent``, ``stratified``, ``multijitter``, ``orthogonal`` and
  ``ldsampler``: ``sample_count`` (default 4) → ``spp``; ``independent`` →
  ``integrator.sampler`` ``independent`` (Philox: the file asked for it), the four that stratify →
  ``sobol`` (Owen-scrambled Sobol' nets per pixel, mcocl/render/sobol_film.py),
  mcocl's stratified sampler: another pattern, the same expectation.  Light
  tracing (``ptracer``) and ``--integrator bdpt`` draw independent samples.
  A sensor without a ``<sampler>`` gets mcocl's default ``auto``
  (mcocl/render/sampler_choice.py).
- integrators ``path`` and ``volpath`` → ``mis`` with the same ``max_depth`` and
  ``rr_depth`` (Mitsuba's conventions, defaults −1 and 5); ``direct`` → ``mis``
  with max_depth 2; ``ptracer`` (Mitsuba's particle tracer) → ``lt``, light
  tracing with the same ``max_depth`` and ``rr_depth``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...errors import InputError
from ..pixel_filter import PIXEL_FILTERS, PixelFilter, make_filter
from .properties import split_children
from .report import Reporter, nearest
from .xml_source import Node

SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")
STRATIFYING = SAMPLERS[1:]  # those that stratify: mcocl's sobol
INTEGRATORS = ("path", "volpath", "direct", "ptracer")
FILM_SIZE = (768, 576)
SAMPLE_COUNT = 4
FOV_AXES = ("x", "y", "diagonal", "smaller", "larger")
SENSORS = ("perspective", "thinlens")
CROP_KEYS = ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height")
NEAR_CLIP = 1e-2  # Mitsuba's default near_clip
FAR_CLIP = 1e4  # Mitsuba's far_clip, the default focus_distance of a thinlens


def fov_on_smaller_axis(fov: float, axis: str, width: int, height: int) -> float:
    """Convert a full field of view (degrees) measured on ``axis`` to the image's smaller axis."""
    small = min(width, height)
    size = {"x": width, "y": height, "smaller": small, "larger": max(width, height),
            "diagonal": math.hypot(width, height)}[axis]
    if size == small:
        return fov
    return math.degrees(2.0 * math.atan(math.tan(math.radians(fov) / 2.0) * small / size))


def _referenced(objects: list[Node], resolve) -> list[Node]:
    """``objects`` with each ``<ref id>`` replaced by the element it names (a sampler, film or
    rfilter declared at the top level with an ``id``, as Mitsuba allows)."""
    return [resolve(o) if o.tag == "ref" and resolve is not None else o for o in objects]


def translate_sensor(node: Node, rep: Reporter, resolve=None) -> tuple[dict, int]:
    """(the mcocl camera, spp, the render sampler) of a ``<sensor>``; ``resolve`` follows ``<ref>``s.

    The sampler is ``independent`` or ``sobol`` for a ``<sampler>`` (:func:`_sampler`), ``auto`` without one.
    """
    kind = node.attrib.get("type", "")
    comments: list[str] = []
    if kind not in SENSORS:
        rep.unsupported(node, f"the sensor {kind!r}", ", ".join(SENSORS), None, comments)
    props, objects = split_children(node)
    objects = _referenced(objects, resolve)
    width, height, spp, sampler = FILM_SIZE[0], FILM_SIZE[1], SAMPLE_COUNT, "auto"
    films = [o for o in objects if o.tag == "film"]
    samplers = [o for o in objects if o.tag == "sampler"]
    for o in objects:
        if o.tag == "rfilter":  # Mitsuba's sensors take no filter: it would be an unused object there
            rep.unsupported(o, "<rfilter> directly inside a sensor", "the same <rfilter> inside the sensor's <film>",
                            "nothing (ignored)", comments)
        elif o.tag not in ("film", "sampler"):
            rep.unsupported(o, f"<{o.tag}> inside a sensor", "<film> and <sampler>", "nothing (ignored)", comments)
    for group in (films, samplers):
        if len(group) > 1:
            group[1].fail(f"a sensor takes one <{group[1].tag}> (the first is at {group[0].where()})")
    pixel_filter, crop = make_filter("gaussian"), None
    if films:
        width, height, pixel_filter, crop = _film(films[0], rep, comments, resolve)
    else:
        comments.append(f"no <film>: Mitsuba's hdrfilm default {width} x {height} with its Gaussian filter "
                        "(stddev 0.5)")
    if samplers:
        spp, sampler = _sampler(samplers[0], rep, comments)
    else:
        comments.append(f"no <sampler>: Mitsuba's default sample_count {spp}, and mcocl's default sampler 'auto' "
                        "(sobol where the spp make its batches, mcocl/render/sampler_choice.py)")

    axis = props.get("fov_axis", ("string",), None)
    if axis is None:
        axis = "x"
        comments.append("fov_axis: Mitsuba's default 'x'")
    elif axis.lower() not in FOV_AXES:
        props.node("fov_axis").fail(f"unknown fov_axis {axis!r} (one of: {', '.join(FOV_AXES)})")
    axis = axis.lower()  # Mitsuba reads fov_axis case-insensitively
    fov = props.get("fov", ("float",), None)
    focal = props.get("focal_length", ("string", "float"), None)
    if fov is not None and focal is not None:
        node.fail("give fov or focal_length, not both")
    if fov is None:
        text = "50mm" if focal is None else str(focal)
        try:
            f_mm = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            (props.node("focal_length") if focal is not None else node).fail(f"cannot read focal_length {text!r}")
        fov = math.degrees(2.0 * math.atan(math.hypot(36.0, 24.0) / (2.0 * f_mm)))
        axis = "diagonal"
        comments.append(f"focal_length {text} (35 mm film equivalent{', Mitsuba default' if focal is None else ''})"
                        f" = {fov:.6g} degrees on the diagonal")
    if not 0.0 < fov < 180.0:
        props.node("fov").fail(f"fov must lie in (0, 180) degrees, got {fov:g}")
    fov_small = fov_on_smaller_axis(fov, axis, width, height)
    if fov_small != fov:
        comments.append(f"fov {fov:g} on axis {axis!r} of {width} x {height} = {fov_small:.9g} on the smaller axis")
    cam: dict[str, Any] = {"comment": comments}
    cam.update(_orientation(node, props, rep, comments))
    cam.update({"fov": fov_small, "width": width, "height": height, "filter": pixel_filter.to_json()})
    if crop is not None:
        cam["crop"] = crop
    lens_keys: tuple[str, ...] = ()
    if kind == "thinlens":
        lens_keys = ("aperture_radius", "focus_distance")
        aperture = props.get("aperture_radius", ("float",), None)
        if aperture is None:
            node.fail("a thinlens sensor needs an aperture_radius")
        focus = props.get("focus_distance", ("float",), None)
        if focus is None:
            focus = FAR_CLIP
            comments.append(f"focus_distance: Mitsuba's default, far_clip = {FAR_CLIP:g}")
        cam.update({"aperture_radius": aperture, "focus_distance": focus})
    elif "focus_distance" in props:
        # Mitsuba's projective cameras all read focus_distance; a pinhole has no focus, so it changes nothing.
        props.get("focus_distance", ("float",), None)
        comments.append("focus_distance: no effect on a pinhole (perspective) camera")
    for k in ("shutter_open", "shutter_close"):
        if k in props:
            props.get(k, ("float",), None)
            comments.append(f"{k}: ignored (mcocl's scenes do not move, so the shutter interval changes nothing)")
    cam.update(_clip_planes(props, comments))
    rep.leftover(node, props.unread(), ("fov", "fov_axis", "focal_length", "to_world", "near_clip", "far_clip",
                                        "focus_distance", "shutter_open", "shutter_close", *lens_keys),
                 comments)
    return cam, spp, sampler


def _clip_planes(props, comments: list[str]) -> dict[str, float]:
    """``near_clip`` and ``far_clip`` of the sensor, Mitsuba's defaults where the file gives none.

    Raises:
        InputError: near_clip negative, or not below far_clip (at the property's line).
    """
    out: dict[str, float] = {}
    near = props.get("near_clip", ("float",), None)
    far = props.get("far_clip", ("float",), None)
    near_default, far_default = near is None, far is None
    near = NEAR_CLIP if near_default else near
    far = FAR_CLIP if far_default else far
    if not 0.0 <= near < (FAR_CLIP if far_default else math.inf):
        props.node("near_clip").fail(f"near_clip must lie in [0, {FAR_CLIP:g}), got {near:g}")
    if not far > near:  # a default far clip exceeds every near clip the line above lets through
        props.node("far_clip").fail(f"far_clip must exceed near_clip ({near:g}), got {far:g}")
    if near > 0.0:
        out["near_clip"] = near
        comments.append(f"near_clip {near:g}{' (Mitsuba default)' if near_default else ''}: primary rays start at "
                        "that distance along the optical axis (and camera connections of lt and bdpt only from there)")
    else:
        comments.append("near_clip 0: nothing is clipped in front (Mitsuba would require it positive)")
    out["far_clip"] = far
    comments.append(f"far_clip {far:g}{' (Mitsuba default)' if far_default else ''}: primary rays end at that "
                    "distance along the optical axis (and camera connections of lt and bdpt only from before it)")
    return out


def _orientation(node: Node, props, rep: Reporter, comments: list[str]) -> dict:
    t = props.get("to_world", ("transform",), None)
    if t is None:
        comments.append("no to_world: Mitsuba's camera at the origin looking along +z with up +y")
        return {"origin": [0.0, 0.0, 0.0], "target": [0.0, 0.0, 1.0], "up": [0.0, 1.0, 0.0]}
    if t.lookat is not None:
        o, tgt, up = t.lookat
        return {"origin": o, "target": tgt, "up": up}
    m = t.matrix[:3, :3]
    left, up, fwd = m[:, 0], m[:, 1], m[:, 2]
    lens = np.linalg.norm(m, axis=0)
    at = props.node("to_world")
    gram = (m / lens).T @ (m / lens)
    if not np.allclose(gram, np.eye(3), atol=1e-6) or not np.allclose(lens, lens[0], rtol=1e-6):
        at.fail("the camera's to_world must be a rotation, translation and uniform scale (write it as a <lookat>)")
    if np.dot(np.cross(up, fwd), left) < 0:
        rep.unsupported(at, "a mirrored camera to_world (e.g. a scale of -1 on x)", "a <lookat>",
                        "the same view without the mirror (the image is flipped left-right)", comments)
    origin = t.matrix[:3, 3]
    comments.append("origin/target/up from the to_world matrix")
    return {"origin": [float(x) for x in origin], "target": [float(x) for x in origin + fwd / lens[2]],
            "up": [float(x) for x in up / lens[1]]}


def _film(node: Node, rep: Reporter, comments: list[str], resolve=None) -> tuple[int, int, PixelFilter, dict | None]:
    kind = node.attrib.get("type", "")
    if kind != "hdrfilm":
        rep.unsupported(node, f"the film {kind!r}", "hdrfilm", "hdrfilm with its width and height", comments)
    props, objects = split_children(node)
    width = props.get("width", ("integer",), FILM_SIZE[0])
    height = props.get("height", ("integer",), FILM_SIZE[1])
    for k, v in (("width", width), ("height", height)):
        if v < 1:
            props.node(k).fail(f"{k} must be >= 1, got {v}")
    if "width" not in props or "height" not in props:
        comments.append(f"film size {width} x {height} (Mitsuba's default 768 x 576 where not given)")
    crop = _crop(node, props, width, height, comments)
    objects = _referenced(objects, resolve)
    filters = [o for o in objects if o.tag == "rfilter"]
    for o in objects:
        if o.tag != "rfilter":
            rep.unsupported(o, f"<{o.tag}> inside a film", "<rfilter>", "nothing (ignored)", comments)
    if len(filters) > 1:
        filters[1].fail("a film takes one <rfilter>")
    if filters:
        pixel_filter = _rfilter(filters[0], rep, comments)
    else:
        pixel_filter = make_filter("gaussian")
        comments.append("no <rfilter>: Mitsuba's default Gaussian filter (stddev 0.5, radius 2), "
                        "by filter importance sampling")
    for k in ("pixel_format", "component_format", "file_format", "banner"):
        if k in props:
            props.read.add(k)
            comments.append(f"{k}: ignored (mcocl writes float32 RGB EXR with a variance layer)")
    if not any(k in props for k in ("sample_border", "high_quality_edges")) and pixel_filter.kind != "box":
        # measured on Mitsuba's bunny documentation scene (Gaussian filter): its border pixels differ by up to
        # 10 standard errors where the image has a gradient at its edge, the rest agrees
        comments.append("sample_border: Mitsuba's default false crops the filters of the pixels at the image's "
                        "edge; mcocl samples every pixel's whole filter (as Mitsuba's true), so edge pixels can differ")
    # high_quality_edges: the name of sample_border before Mitsuba 3.0 (its Film API change), still
    # written by exporters (the Blender add-on's test scenes); same meaning, same default false.
    for key in ("sample_border", "high_quality_edges"):
        if key in props:
            # Filter importance sampling draws every pixel's film points over its whole filter footprint,
            # which is what sample_border = true gives Mitsuba's splatting film; with false, Mitsuba's border
            # pixels see only the part of their filter inside the image (the same image for the box filter).
            border = props.get(key, ("boolean",), None)
            comments.append(f"{key} {str(border).lower()}: mcocl samples each pixel's whole filter footprint"
                            + ("" if border else " (as Mitsuba's true; its false crops the border pixels' filters)"))
    rep.leftover(node, props.unread(), ("width", "height", *CROP_KEYS, "pixel_format", "component_format",
                                        "file_format", "sample_border", "high_quality_edges"), comments)
    return width, height, pixel_filter, crop


def _crop(film: Node, props, width: int, height: int, comments: list[str]) -> dict | None:
    """hdrfilm ``crop_offset_x/y``, ``crop_width/height`` (Mitsuba's defaults: the whole film) → ``camera.crop``."""
    ox = props.get("crop_offset_x", ("integer",), 0)
    oy = props.get("crop_offset_y", ("integer",), 0)
    cw = props.get("crop_width", ("integer",), width)
    ch = props.get("crop_height", ("integer",), height)
    for k, v, lo, hi in (("crop_offset_x", ox, 0, width - 1), ("crop_offset_y", oy, 0, height - 1),
                         ("crop_width", cw, 1, width - ox), ("crop_height", ch, 1, height - oy)):
        if not lo <= v <= hi:
            (props.node(k) if k in props else film).fail(f"{k} must lie in [{lo}, {hi}] for a {width} x {height} film, got {v}")
    if (ox, oy, cw, ch) == (0, 0, width, height):
        return None
    comments.append(f"crop: the {cw} x {ch} window at ({ox}, {oy}) of the {width} x {height} film")
    return {"offset": [ox, oy], "size": [cw, ch]}


def _rfilter(node: Node, rep: Reporter, comments: list[str]) -> PixelFilter:
    """Mitsuba's ``box``, ``tent`` (``radius``) and ``gaussian`` (``stddev``) reconstruction filters."""
    kind = node.attrib.get("type", "")
    props, objects = split_children(node)
    for o in objects:
        rep.unsupported(o, f"<{o.tag}> inside an rfilter", "leave it out", "nothing (ignored)", comments)
    if kind not in PIXEL_FILTERS:
        rep.unsupported(node, f"the reconstruction filter {kind!r}", nearest(kind, PIXEL_FILTERS),
                        "the Gaussian filter (stddev 0.5)", comments)
        return make_filter("gaussian")
    names = {"box": (), "tent": ("radius",), "gaussian": ("stddev",)}[kind]
    values = {k: props.get(k, ("float",), None) for k in names}
    try:
        f = make_filter(kind, **values)
    except InputError as e:
        node.fail(str(e))
    comments.append(f"rfilter {kind}" + "".join(f", {k} {v:g}" for k, v in values.items() if v is not None)
                    + ("" if kind == "box" else " (sampled as the film point's distribution)"))
    rep.leftover(node, props.unread(), names, comments)
    return f


def _sampler(node: Node, rep: Reporter, comments: list[str]) -> tuple[int, str]:
    """(spp, mcocl's render sampler) of a ``<sampler>``."""
    kind = node.attrib.get("type", "")
    if kind not in SAMPLERS:
        rep.unsupported(node, f"the sampler {kind!r}", nearest(kind, SAMPLERS), "independent", comments)
    props, objects = split_children(node)
    for o in objects:
        rep.unsupported(o, f"<{o.tag}> inside a sampler", "leave it out", "nothing (ignored)", comments)
    spp = props.get("sample_count", ("integer",), SAMPLE_COUNT)
    if spp < 1:
        props.node("sample_count").fail(f"sample_count must be >= 1, got {spp}")
    ours = "independent" if kind not in STRATIFYING else "sobol"
    comments.append(f"sampler {kind!r}, sample_count {spp} -> spp, sampler {ours!r} ("
                    + ("independent samples from mcocl's Philox counter-based generator" if ours == "independent" else
                       "mcocl's stratified sampler: Owen-scrambled Sobol' nets per pixel, its variance from "
                       "independent scramblings") + "; a different pattern, the same expectation)")
    for k in ("seed", "jitter", "scramble_seed"):
        if k in props:
            props.read.add(k)
            comments.append(f"{k}: ignored (the image depends on mcocl's --seed)")
    rep.leftover(node, props.unread(), ("sample_count", "seed", "jitter"), comments)
    return spp, ours


def translate_integrator(node: Node, rep: Reporter) -> dict:
    """mcocl ``integrator`` settings (without spp) of an ``<integrator>``."""
    kind = node.attrib.get("type", "")
    comments: list[str] = []
    props, objects = split_children(node)
    for o in objects:
        rep.unsupported(o, f"<{o.tag}> inside an integrator", "a single path integrator", "nothing (ignored)",
                        comments)
    if kind not in INTEGRATORS:
        rep.unsupported(node, f"the integrator {kind!r}", "path", "mcocl's mis path tracer", comments)
    if kind == "direct":
        out = {"type": "mis", "max_depth": 2, "rr_depth": 5}
        comments.append("direct -> mis path tracer with max_depth 2 (emitters seen directly plus direct light)")
        for k in ("emitter_samples", "bsdf_samples", "shading_samples"):
            if k in props:
                props.read.add(k)
                comments.append(f"{k}: ignored (one light and one BSDF sample per path, same expectation)")
    else:
        md = props.get("max_depth", ("integer",), -1)
        rr = props.get("rr_depth", ("integer",), 5)
        if md < -1:
            props.node("max_depth").fail(f"max_depth must be >= -1, got {md}")
        if rr < 1:
            props.node("rr_depth").fail(f"rr_depth must be >= 1, got {rr}")
        light = kind == "ptracer"
        out = {"type": "lt" if light else "mis", "max_depth": md, "rr_depth": rr}
        how = ("lt (light tracing, every non-delta vertex connected to the camera)" if light else
               "mis (light and BSDF sampling combined by the power heuristic)")
        comments.append(f"{kind} -> {how}, max_depth {md}, rr_depth {rr} (Mitsuba's conventions"
                        f"{'; defaults -1 and 5' if 'max_depth' not in props or 'rr_depth' not in props else ''})")
        if light and "samples_per_pass" in props:
            props.read.add("samples_per_pass")
            comments.append("samples_per_pass: ignored (mcocl splits the work into blocks itself)")
    if props.get("hide_emitters", ("boolean",), False):
        rep.unsupported(props.node("hide_emitters"), "hide_emitters=true", "hide_emitters=false",
                        "visible emitters", comments)
    rep.leftover(node, props.unread(), ("max_depth", "rr_depth", "hide_emitters"), comments)
    out["comment"] = comments
    return out


__all__ = ["fov_on_smaller_axis", "translate_integrator", "translate_sensor"]
