"""The MIS weights of one bdpt path sum to 1 (kernels/render/bdpt_weight_test.cl).

On paths the render's own walks and connections produce, the test kernel
recomputes every vertex's densities from the vertices alone, asks bdpt.cl's
bdpt_mis_weight for the weight of every strategy (s, t) that could have
produced the path, and counts the paths whose weights do not sum to 1 or
whose weight in the render differs from the recomputed one.  Scenes: the
spherical furnace (all diffuse, long paths), the Cornell box with depth caps,
the caustic's glass sphere (delta vertices), a plastic Cornell box (a smooth
material that also scatters by a delta coat), a thin lens and a camera with
near and far clip planes; both heuristics.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mcocl.render import splat_film
from mcocl.render.api import render


@pytest.fixture(autouse=True)
def _scalar_build(monkeypatch) -> None:
    """These tests run bdpt's scalar build (MCOCL_LANES=1): it compiles in half the time of the
    16-lane build, and test_render_bdpt.py::test_lane_builds_agree_with_the_scalar_build holds the lane
    builds to it."""
    monkeypatch.setenv("MCOCL_LANES", "1")


SCENES = Path(__file__).resolve().parent.parent / "scenes"


def _small(tmp_path: Path, name: str, size: int = 24, plastic: bool = False, aperture: float = 0.0,
           clip: tuple[float, float] | None = None) -> Path:
    """A copy of a scene at size x size pixels, its diffuse materials made plastic, with a thin lens,
    or with the camera's (near_clip, far_clip)."""
    s = json.loads((SCENES / name).read_text())
    s["camera"]["width"] = s["camera"]["height"] = size
    # one light sampler for every scene, so that the cases share one build of the check kernel (40 s on a
    # cold cache each); the BVH sampler's pmf in bdpt's weights is held by its agreement with mis instead
    # (tests/test_render_bdpt.py on the Cornell box, which takes the BVH sampler)
    s.setdefault("integrator", {})["light_sampler"] = "power"
    if clip:
        s["camera"]["near_clip"], s["camera"]["far_clip"] = clip
    if aperture:
        s["camera"]["aperture_radius"], s["camera"]["focus_distance"] = aperture, 2.5
    if plastic:
        for key, m in s["materials"].items():
            if m["type"] == "diffuse":
                s["materials"][key] = {"type": "plastic", "diffuse_reflectance": m["reflectance"]}
    out = tmp_path / name
    out.write_text(json.dumps(s))
    return out


def _check(monkeypatch, scene: Path, max_depth: int, mis: str) -> tuple[float, float, float]:
    """Paths checked, bad paths and checked paths with a delta vertex, summed over the image."""
    monkeypatch.setitem(splat_film.TRACE_KERNELS, "bdpt", ("render/bdpt_weight_test.cl", "bdpt_weight_check"))
    r = render(scene, spp=4, integrator="bdpt", max_depth=max_depth, seed=3, mis=mis)
    assert r.nonfinite == 0
    checked, bad, delta = r.mean.reshape(-1, 3).astype(np.float64).sum(axis=0) * r.spp
    return checked, bad, delta


@pytest.mark.parametrize("mis", ["power", "balance"])
@pytest.mark.parametrize(("name", "max_depth", "kw", "with_delta"), [
    ("furnace_sphere.json", 3, {}, False),
    ("furnace_sphere.json", -1, {}, False),
    ("cornell.json", 4, {}, False),
    ("caustic.json", -1, {"size": 32}, True),
    ("cornell.json", 5, {"plastic": True}, True),
    ("cornell.json", 5, {"aperture": 0.15}, False),
    # the near plane cuts the box's open front, the far one its back wall (camera at z = 3.9)
    ("cornell.json", 5, {"clip": (3.2, 4.6)}, False),
])
def test_weights_of_a_path_sum_to_one(monkeypatch, tmp_path, name, max_depth, kw, with_delta, mis) -> None:
    checked, bad, delta = _check(monkeypatch, _small(tmp_path, name, **kw), max_depth, mis)
    assert checked >= 100, checked
    assert bad == 0, f"{bad:g} of {checked:g} paths"
    assert (delta > 0) == with_delta, delta
