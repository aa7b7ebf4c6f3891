"""Point, spot and directional lights: the scene model, its validation and the kernels' records.

These emitters have no surface (kernels/render/delta_lights.cl): no ray hits
them, so only the integrators that connect vertices to lights see them —
``nee``, ``mis`` (with MIS weight 1: BSDF sampling cannot find them) and
``lt`` and ``bdpt`` (kernels/render/bdpt.cl); ``path`` renders them black,
and the light BVH takes point and spot lights as leaves but refuses
directional ones.  Conventions are Mitsuba 3's:

- ``point``: ``intensity`` I in W/sr (per RGB channel) at ``position``;
  irradiance I cos / d² on a surface at distance d.
- ``spot``: a point light aimed along ``direction`` (or at ``target``);
  full intensity within ``beam_width`` degrees of the axis, falling linearly
  in the angle to zero at ``cutoff_angle`` (default 20°; ``beam_width``
  defaults to 3/4 of it).
- ``directional``: ``irradiance`` E in W/m² arriving from infinitely far,
  travelling along ``direction``.

They share the light-choice table with the area lights
(:func:`mcocl.render.emitter_choice.light_choice`, exact on the uniforms'
grid) with the powers :func:`delta_power` gives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..layouts import LIGHT_RECORD, LightShape
from .emitter_choice import LUMINANCE

DELTA_KINDS = ("point", "spot", "directional")
DEFAULT_CUTOFF_ANGLE = 20.0  # degrees, Mitsuba 3's spot default
BEAM_FRACTION = 0.75  # Mitsuba 3's default beam_width: 3/4 of cutoff_angle
NO_PRIM = 0xFFFFFFFF  # light_record.prim of a light without a primitive


@dataclass
class DeltaLight:
    """One point, spot or directional light in world space (angles in degrees).

    ``rgb`` is the intensity (point, spot) or the irradiance (directional);
    ``direction`` a unit vector: the spot's axis, the directional light's direction of travel.
    """

    kind: str
    key: str
    rgb: np.ndarray
    position: np.ndarray
    direction: np.ndarray
    cutoff_angle: float = DEFAULT_CUTOFF_ANGLE
    beam_width: float = DEFAULT_CUTOFF_ANGLE * BEAM_FRACTION


def _unit(c: Any, v: np.ndarray, key: str) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if not n > 0.0:
        c.fail(key, "a direction must not be the zero vector")
    return v / n


def parse_lights(c: Any, value: list, key: str, limit: float) -> list[DeltaLight]:
    """The scene file's ``lights`` list (scenes/README.md, "lights"), validated.

    ``c``: the scene file's checker (mcocl.render.scene's, which raises InputError naming file and key);
    ``limit``: the largest coordinate magnitude allowed (the scene's geometry limit).
    """
    out = []
    for i, v in enumerate(value):
        k = f"{key}[{i}]"
        if not isinstance(v, dict) or "type" not in v:
            c.obj(v, k, ("type",))
        kind = c.string(v["type"], f"{k}.type", DELTA_KINDS)
        if kind == "point":
            o = c.obj(v, k, ("type", "position", "intensity"))
            out.append(DeltaLight(kind, k, c.rgb(o["intensity"], f"{k}.intensity"),
                                  c.vector(o["position"], f"{k}.position", limit=limit), np.array([0.0, 0.0, 1.0])))
        elif kind == "spot":
            o = c.obj(v, k, ("type", "position", "intensity"), ("direction", "target", "cutoff_angle", "beam_width"))
            pos = c.vector(o["position"], f"{k}.position", limit=limit)
            if ("direction" in o) == ("target" in o):
                c.fail(k, "a spot light needs exactly one of 'direction' and 'target'")
            if "target" in o:
                d = c.vector(o["target"], f"{k}.target", limit=limit) - pos
                axis = _unit(c, d, f"{k}.target")
            else:
                axis = _unit(c, c.vector(o["direction"], f"{k}.direction", limit=limit), f"{k}.direction")
            cutoff = c.number(o.get("cutoff_angle", DEFAULT_CUTOFF_ANGLE), f"{k}.cutoff_angle", 0.0, 180.0,
                              lo_open=True)
            beam = c.number(o.get("beam_width", cutoff * BEAM_FRACTION), f"{k}.beam_width", 0.0, cutoff)
            out.append(DeltaLight(kind, k, c.rgb(o["intensity"], f"{k}.intensity"), pos, axis, cutoff, beam))
        else:
            o = c.obj(v, k, ("type", "direction", "irradiance"))
            d = _unit(c, c.vector(o["direction"], f"{k}.direction", limit=limit), f"{k}.direction")
            out.append(DeltaLight(kind, k, c.rgb(o["irradiance"], f"{k}.irradiance"), np.zeros(3), d))
    return out


def delta_power(lights: list[DeltaLight], radius: float) -> np.ndarray:
    """float64 (D,): the power by which light sampling chooses each light (luminance-weighted).

    Point: 4π I; spot: 2π (1 − cos cutoff) I, the flux of its cone at full
    intensity; directional: π R² E through the disk of the scene's bounding
    sphere (radius R), as for the environment in light tracing.
    """
    out = np.zeros(len(lights))
    for i, li in enumerate(lights):
        lum = float(np.asarray(li.rgb, np.float64) @ LUMINANCE)
        if li.kind == "point":
            out[i] = 4.0 * math.pi * lum
        elif li.kind == "spot":
            out[i] = 2.0 * math.pi * (1.0 - math.cos(math.radians(li.cutoff_angle))) * lum
        else:
            out[i] = math.pi * radius * radius * lum
    return out


def delta_records(lights: list[DeltaLight], pmf: np.ndarray) -> np.ndarray:
    """The :data:`~mcocl.layouts.LIGHT_RECORD` of each light (layout: kernels/render/delta_lights.cl)."""
    rec = np.zeros(len(lights), LIGHT_RECORD.dtype())
    for i, li in enumerate(lights):
        r = rec[i]
        r["radiance"] = li.rgb
        r["pmf"] = pmf[i]
        r["prim"] = NO_PRIM
        if li.kind == "directional":
            r["shape"] = float(LightShape.DIRECTIONAL)
            r["base"] = li.direction
            continue
        r["base"] = li.position
        r["shape"] = float(LightShape.POINT if li.kind == "point" else LightShape.SPOT)
        if li.kind == "spot":
            cut, beam = math.radians(li.cutoff_angle), math.radians(li.beam_width)
            r["edge1"] = li.direction
            r["edge2"] = (math.cos(cut), math.cos(beam), cut)
            r["area"] = 1.0 / (cut - beam) if cut > beam else 0.0
    return rec


__all__ = ["DELTA_KINDS", "DeltaLight", "delta_power", "delta_records", "parse_lights"]
