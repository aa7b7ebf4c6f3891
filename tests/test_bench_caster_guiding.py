"""bench/caster_guiding.py's scenes: the small-lamp boxes keep the Cornell light's power and hold casters."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from caster_guiding import BOXES, small_lamp_box  # noqa: E402

from mcocl.render.caster_guiding import caster_rows  # noqa: E402
from mcocl.render.compiled import load_compiled  # noqa: E402

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def light_power(cs) -> float:
    """Sum over the area lights' triangles of radiance (mean over channels) times area."""
    v = cs.tri_vertices[:, :, :3].astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    prims = np.asarray(cs.light_prims)
    emitter = np.asarray(cs.shape_emitter)[np.asarray(cs.prim_shape)[prims]]
    return float(np.sum(area[prims] * cs.emitter_radiance[emitter, :3].astype(np.float64).mean(axis=1)))


@pytest.mark.parametrize("box", BOXES, ids=[b[0] for b in BOXES])
def test_small_lamp_boxes(tmp_path: Path, box) -> None:
    name, balls, extra = box
    cs = load_compiled(small_lamp_box(tmp_path, name, balls, extra))
    assert (cs.width, cs.height) == (64, 64)
    assert light_power(cs) == pytest.approx(light_power(load_compiled(SCENES / "cornell.json")), rel=1e-5)
    if name == "ball on the floor":  # its lamp subtends < SMALL_LIGHT_SR: a caster without lifting the bound
        assert len(caster_rows(cs)) == 1
