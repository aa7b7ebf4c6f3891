"""The light BVH's flat form for a few lights (kernels/render/light_bvh.cl, light_bvh_flat).

A scene of at most FLAT_LIGHTS lights gets a root and one leaf per light,
and the kernel weighs every leaf at once; its probabilities must keep the
tree's contract: the frequencies of the chosen lights fit the probabilities
light_bvh_pmf reports (chi-square, shared harness), the walk's probability
equals light_bvh_pmf's bit for bit, all 2^23 uniforms of the grid land on
each light in exactly that share, and every light whose front faces the
point has a positive one.  The default light sampler, "auto", takes the
BVH exactly where it is flat.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from chi2 import Chi2Family
from test_render_light_bvh import CELL, POINTS, SCENES, BVHKernels, _cloud_scene, check_choice_fits_pmf

from mcocl.layouts import LIGHT_BVH_NODE
from mcocl.render.compiled import compile_scene
from mcocl.render.emitter_choice import resolve_light_sampler
from mcocl.render.light_bvh import FLAT_FLAG, FLAT_LIGHTS
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene

KERNEL = Path(__file__).resolve().parent.parent / "kernels" / "render" / "light_bvh.cl"
FAMILY = Chi2Family("flat light BVH choice", len(POINTS))


@pytest.fixture(scope="module")
def few() -> BVHKernels:
    return BVHKernels(_cloud_scene(ntri=12))  # 12 triangles and 2 spheres


def test_kernel_and_host_agree_on_the_flat_limit_and_flag() -> None:
    text = KERNEL.read_text()
    m = re.search(r"#define LIGHT_BVH_FLAT_MAX (\d+)u", text)
    f = re.search(r"#define LIGHT_BVH_FLAT_FLAG (0x[0-9a-fA-F]+)u", text)
    assert m and int(m.group(1)) == FLAT_LIGHTS
    assert f and int(f.group(1), 16) == FLAT_FLAG


def test_few_lights_make_a_flat_tree(few: BVHKernels) -> None:
    """The root counts every light and points at the leaves 1..L, in light order; a trail is the light's index."""
    cs = few.cs
    assert 1 < cs.num_lights <= FLAT_LIGHTS
    rec = few.t["light_bvh"].reshape(-1, 12).view(LIGHT_BVH_NODE.dtype())[:, 0]
    assert len(rec) == cs.num_lights + 1
    assert rec["count"][0] == cs.num_lights | FLAT_FLAG and rec["ref"][0] == 1
    assert np.all(rec["count"][1:] == 1) and list(rec["ref"][1:]) == list(range(cs.num_lights))
    assert list(few.t["light_trail"][cs.light_prims]) == list(range(cs.num_lights))
    assert np.isclose(rec["power"][0], rec["power"][1:].astype(np.float64).sum(), rtol=1e-5)


@pytest.mark.parametrize("point", range(len(POINTS)))
def test_flat_choice_fits_its_pmf_exactly(few: BVHKernels, point: int) -> None:
    check_choice_fits_pmf(few, point, FAMILY)


@pytest.mark.parametrize("point", [0, 2])
def test_flat_pmf_is_the_share_of_grid_uniforms_each_light_gets(few: BVHKernels, point: int) -> None:
    p, n = POINTS[point]
    u = (np.arange(1 << 23, dtype=np.float32) + np.float32(0.5)) * np.float32(CELL)
    k = few.choose(p, n, u).astype(np.int64)
    table = few.pmfs(p, n)
    assert table.astype(np.float64).sum() == 1.0  # a flat choice always finds a light when one is lit
    share = np.bincount(k[k >= 0], minlength=len(table)) * CELL
    np.testing.assert_array_equal(share.astype(np.float32), table)


def test_auto_takes_the_bvh_where_its_tree_is_flat() -> None:
    """The default light sampler: bvh for 2..FLAT_LIGHTS area lights and no point light, else power."""
    assert parse_scene(_cloud_scene(ntri=4) | {"integrator": {}}).light_sampler == "auto"
    assert compile_scene(load_scene(SCENES / "veach_mis.json")).light_sampler == "bvh"
    assert compile_scene(load_scene(SCENES / "many_lights.json")).light_sampler == "power"
    assert resolve_light_sampler("auto", FLAT_LIGHTS, 0) == "bvh"
    assert resolve_light_sampler("auto", FLAT_LIGHTS + 1, 0) == "power"
    assert resolve_light_sampler("auto", 1, 0) == resolve_light_sampler("auto", 3, 1) == "power"
    assert resolve_light_sampler("uniform", 3, 0) == "uniform"
    cs = compile_scene(load_scene(SCENES / "many_lights.json")).with_settings(light_sampler="bvh")
    assert cs.with_settings(light_sampler="auto").light_sampler == "power"
