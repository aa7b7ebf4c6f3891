"""bdpt's MIS weights across specular chains (kernels/render/bdpt.cl, "Specular chains").

The caustic under a glass sphere in the Cornell box (camera, floor, glass, glass, light) is sampled by
two strategies only: the camera subpath hitting the light through the ball, (0, 5), and light tracing,
(4, 1).  The ratio of their densities is the light's area density over the camera's at the floor point:
the chain's geometry cancels.  Light tracing is then far the likelier, so it takes most of the weight;
area densities at the glass vertices (cos / distance^2 at the first one from each side) gave it 2.5 % of
the caustic.  tests/test_bdpt_weights.py checks that the weights still sum to 1.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mcocl.render.api import render
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"


@pytest.fixture(autouse=True)
def _scalar_build(monkeypatch) -> None:
    """The scalar build, as tests/test_render_bdpt.py (half the build time of the lane builds)."""
    monkeypatch.setenv("MCOCL_LANES", "1")


def _cornell_with_glass_ball(tmp_path: Path, size: int):
    """scenes/cornell.json with a glass sphere instead of its two boxes, size x size pixels."""
    d = json.loads((SCENES / "cornell.json").read_text())
    d["materials"]["glass"] = {"type": "dielectric", "int_ior": 1.5}
    d["shapes"] = [s for s in d["shapes"] if s.get("name") not in ("small-box", "large-box")]
    d["shapes"].append({"name": "glass-ball", "type": "sphere", "material": "glass", "center": [0.42, -0.68, 0.25],
                        "radius": 0.32})
    p = tmp_path / "cornell_glass.json"
    p.write_text(json.dumps(d))
    sc = load_scene(p)
    sc.camera.width = sc.camera.height = size
    return sc


def test_light_tracing_carries_the_caustic_under_the_glass_ball(tmp_path: Path) -> None:
    """Path length 4, weighted (4, 1) against weighted (0, 5), in the pixels where those two hold most of
    the length-4 image (the caustic; elsewhere (1, 4), (2, 3) and (3, 2) take diffuse paths): light tracing's
    share there is well over half (8 % with area densities across the chain, 99.99 % now).  Unbiasedness: the
    agreement tests with mis through glass (tests/test_render_bdpt.py, test_render_bdpt_split.py)."""
    sc = _cornell_with_glass_ball(tmp_path, 32)
    kw = {"spp": 64, "integrator": "bdpt", "max_depth": 4, "seed": 3, "sampler": "independent"}
    w41 = render(sc, strategy=(4, 1), **kw).mean.astype(np.float64).sum(axis=2)
    w05 = render(sc, strategy=(0, 5), **kw).mean.astype(np.float64).sum(axis=2)
    rest = sum(render(sc, strategy=st, **kw).mean.astype(np.float64).sum(axis=2) for st in [(1, 4), (2, 3), (3, 2)])
    chain = w41 + w05
    caustic = chain > 2 * (rest + 1e-3)
    assert caustic.sum() >= 6, caustic.sum()
    share = w41[caustic].sum() / chain[caustic].sum()
    assert share > 0.6, share
