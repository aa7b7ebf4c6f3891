"""The camera's clip planes under light tracing and bdpt (kernels/render/camera.cl, lt.cl, bdpt.cl).

A Cornell box with a dim sky, seen through a near clip plane that hides a
sphere standing right in front of the lens (it still casts its shadow and
light) and a far clip plane that cuts the back of the box (the sky shows
there): ``lt`` and ``bdpt`` agree with ``mis``, whose clipped primary rays
define the image, per 8 x 8 block (z-tests of the block means, a bound of
4.5 standard errors over 16 blocks x 3 channels x 2 integrators).  The same
scene without clips differs from the clipped one by many standard errors, so
the agreement is not one of images that the clips leave alike.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from test_render_textures import block_z

import mcocl

SCENES = Path(__file__).resolve().parent.parent / "scenes"
NEAR, FAR = 1.3, 4.5  # the camera sits at z = 3.9: the sphere lies 0.6 .. 1.2 in front, the back wall 4.9


def clipped_cornell(tmp_path: Path, clip: bool = True) -> Path:
    """The Cornell box at 32 x 32 with a sphere in front of the lens, a dim sky and (clip) the clip planes."""
    s = json.loads((SCENES / "cornell.json").read_text())
    s["camera"]["width"] = s["camera"]["height"] = 32
    if clip:
        s["camera"]["near_clip"], s["camera"]["far_clip"] = NEAR, FAR
    s["integrator"]["max_depth"] = 4
    s["shapes"].append({"type": "sphere", "center": [0.1, -0.1, 3.0], "radius": 0.3, "material": "white"})
    s["environment"] = {"type": "constant", "radiance": [0.3, 0.3, 0.3]}
    p = tmp_path / ("clipped.json" if clip else "unclipped.json")
    p.write_text(json.dumps(s))
    return p


def test_light_tracing_and_bdpt_agree_with_mis_through_clip_planes(tmp_path: Path) -> None:
    p = clipped_cornell(tmp_path)
    ref = mcocl.render(p, spp=256, seed=1, integrator="mis")
    unclipped = mcocl.render(clipped_cornell(tmp_path, clip=False), spp=256, seed=1, integrator="mis")
    assert np.abs(block_z(unclipped, ref)).max() > 20.0
    for seed, integ in ((2, "lt"), (3, "bdpt")):
        img = mcocl.render(p, spp=64, seed=seed, integrator=integ, spp_per_block=8)
        z = block_z(img, ref)
        assert np.abs(z).max() < 4.5, (integ, np.round(z[..., 0], 1))
