"""bdpt in a scene far from the world's origin renders what it renders near it.

offset_origin's offset grows with the coordinates (kernels/render/prims.cl), so 200 units away it is
about 0.02.  bdpt's connection shadow rays left the offset origin parallel to the unoffset segment, and
met the far endpoint's own surface before the SHADOW_EPSILON margin: the light over a floor lost 61 %
of its next-event (1, 2) contribution and the image 4.4 % (kernels/render/bdpt.cl, segment_clear).
The same seed draws the same numbers in both scenes, so the two images differ only by rounding and by
the few paths that rounding sends elsewhere.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def light_over_floor(shift: float):
    """The Cornell box's light and floor alone, translated by ``shift`` along x (camera too), 16 px."""
    d = json.loads((SCENES / "cornell.json").read_text())
    d["shapes"] = [s for s in d["shapes"] if s.get("name") in ("light", "floor")]
    for s in d["shapes"]:
        s.setdefault("transform", []).append({"translate": [shift, 0, 0]})
    cam = d["camera"]
    cam["origin"][0] += shift
    cam["target"][0] += shift
    cam["width"] = cam["height"] = 16
    return compile_scene(parse_scene(d))


@pytest.mark.parametrize(("kw", "bound"), [
    ({"strategy": (1, 2), "unweighted": True}, 1e-3),  # next-event estimation alone (old code: -61 %)
    ({}, 5e-3),                                         # every strategy (old code: -4.4 %)
])
def test_a_scene_far_from_the_origin_renders_the_same(kw: dict, bound: float) -> None:
    near, far = (float(np.mean(render(light_over_floor(x), spp=64, integrator="bdpt", sampler="independent",
                                      max_depth=2, seed=3, **kw).mean)) for x in (0.0, 200.0))
    assert near > 0
    assert abs(far / near - 1) < bound, (near, far)
