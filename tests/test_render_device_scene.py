"""One scene-to-device contract (mcocl/render/device_scene.py) for every consumer.

The render job, the ray-casting kernels (through ``CompiledScene.buffers``)
and the light tests must read the same tables, and the light-choice
probabilities that the compiled scene reports must be the ones the kernel's
sampling really has.  The latter is checked independently of the code that
computes them: every one of the 2^23 uniforms of kernels/rng/uniform.cl is
enumerated and pushed through the kernel's inversion rule (the largest k with
``light_cdf[k] <= u``; the environment when ``u < env_threshold``), and the
counted shares must equal the stored probabilities exactly.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

from mcocl import layouts, runtime
from mcocl.render.bvh_leaves import device_geometry
from mcocl.render.compiled import compile_scene
from mcocl.render.device_scene import geom_args, scene_buffers, scene_tables
from mcocl.render.job import RenderJob
from mcocl.render.scene import parse_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def _scene(name: str, env: float | None = None):
    data = json.loads((SCENES / name).read_text())
    if env is not None:
        data["environment"] = {"type": "constant", "radiance": env}
    return compile_scene(parse_scene(data, SCENES / name))


CASES = [("cornell.json", None), ("veach_mis.json", None), ("veach_mis.json", 0.7), ("furnace_sphere.json", None),
         ("cornell.json", 3.0)]


@pytest.fixture(scope="module", params=CASES, ids=[f"{n}-env{e}" for n, e in CASES])
def cs(request):
    return _scene(*request.param)


def _grid_uniforms() -> np.ndarray:
    """All 2^23 uniforms of kernels/rng/uniform.cl, u = (m + 1/2) 2^-23, computed in float32 as the kernel does."""
    m = np.arange(1 << 23, dtype=np.float32)
    return (m + np.float32(0.5)) * np.float32(2.0 ** -23)


def test_light_pmf_is_the_share_of_grid_uniforms_each_light_gets(cs):
    u = _grid_uniforms()
    nl = cs.num_lights
    if nl:
        k = np.searchsorted(cs.light_cdf[:nl], u, side="right") - 1  # largest k with cdf[k] <= u
        share = np.bincount(k, minlength=nl) / float(1 << 23)
        np.testing.assert_array_equal(cs.light_pmf, share.astype(np.float32))
    env_share = np.count_nonzero(u < np.float32(cs.env_threshold)) / float(1 << 23)
    assert cs.env_pmf == env_share
    if not np.any(cs.env_radiance[:3] > 0):
        assert cs.env_pmf == 0.0 and (nl == 0 or cs.light_pmf.sum(dtype=np.float64) == 1.0)


def test_records_carry_the_compiled_scenes_probabilities(cs):
    t = scene_tables(cs)
    nl = cs.num_lights
    prims = t["prim_rec"].view(layouts.PRIM_RECORD.dtype())[:, 0]
    lights = t["light_rec"].reshape(-1, 16).view(layouts.LIGHT_RECORD.dtype())[:, 0]
    np.testing.assert_array_equal(lights["pmf"][:nl], cs.light_pmf)
    np.testing.assert_array_equal(lights["prim"][:nl], cs.light_prims)
    np.testing.assert_array_equal(prims["pmf"][cs.light_prims], cs.light_pmf)
    others = np.setdiff1d(np.arange(cs.num_triangles + cs.num_spheres), cs.light_prims)
    assert np.all(prims["pmf"][others] == 0)
    np.testing.assert_array_equal(t["env_choice"], np.float32([cs.env_threshold, cs.env_pmf]))
    # shading records: material and emitter of each primitive's shape; light shapes by code
    np.testing.assert_array_equal(prims["material"][: len(cs.prim_shape)], cs.shape_material[cs.prim_shape])
    np.testing.assert_array_equal(prims["emitter"][: len(cs.prim_shape)], cs.shape_emitter[cs.prim_shape])
    is_sphere = cs.light_prims >= cs.num_triangles
    assert np.all((lights["shape"][:nl] == layouts.LightShape.TRIANGLE) == ~is_sphere)


def test_bvh_nodes_read_through_the_node_record(cs):
    nodes = cs.bvh_nodes
    header = nodes[:1].view(layouts.BVH_HEADER.dtype())[0, 0]
    assert header["nprims"] == len(cs.bvh_prims)
    assert header["num_nodes"] == cs.bvh_stats["nodes"] == (len(nodes) - 1) // 4
    inner = nodes[1:].reshape(-1, 16).view(layouts.BVH_NODE.dtype())[:, 0]
    for side in "01":
        ref, cnt = inner[f"ref{side}"], inner[f"cnt{side}"]
        assert np.all(ref[cnt == 0] < header["num_nodes"])
        assert np.all(ref[cnt > 0] + cnt[cnt > 0] <= header["nprims"])
        assert np.all(inner[f"lo{side}"] <= inner[f"hi{side}"])


def test_every_consumer_uploads_the_same_tables(cs):
    """scene_buffers (ray casting, primitive queries) holds exactly the render job's tables."""
    ctx = runtime.device_context()
    tables = scene_tables(cs)
    job = RenderJob(tables, cs.width, cs.height, "mis", cs.max_depth, cs.rr_depth, seed=1, spp_per_block=1)
    bufs = scene_buffers(cs, ctx)
    assert set(bufs) == set(job.tables)
    for name, want in job.tables.items():
        got = np.empty_like(want)
        cl.enqueue_copy(ctx.queue, got, bufs[name])
        assert got.tobytes() == want.tobytes(), name
    geom = geom_args(cs, ctx)
    assert geom[:4] == [bufs[k] for k in ("bvh_nodes", "tri_rows", "spheres", "sphere_flip")]
    assert [int(x) for x in geom[4:]] == [int(x) for x in tables["geometry_counts"]]


def test_render_params_follow_the_tables(cs):
    t = scene_tables(cs)
    job = RenderJob(t, cs.width, cs.height, "nee", 7, 3, seed=2**63 + 5, spp_per_block=4, spp_limit=10)
    p = job.params(first_block=9, nblocks=2)
    assert p.dtype == layouts.RENDER_PARAMS.dtype()
    assert (int(p["first_block"]), int(p["seed"]), int(p["nblocks"])) == (9, 2**63 + 5, 2)
    assert (int(p["max_depth"]), int(p["rr_depth"]), int(p["spp_limit"])) == (7, 3, 10)
    assert [int(p["ntris"]), int(p["nspheres"])] == [cs.num_triangles, cs.num_spheres]
    assert [int(p["nlights"]), int(p["light_top"])] == list(t["light_scalars"])
    assert float(p["env_pmf"]) == np.float32(cs.env_pmf)
    np.testing.assert_array_equal(p["env_radiance"], t["env"])


def test_the_bvh_table_is_made_once_and_holds_the_tree() -> None:
    """compile_scene makes the kernels' BVH table; the scene's tree is its first rows (no second copy), and
    the tables are made again, the same as from scratch, only when the arrays behind them change."""
    cs = _scene("veach_mis.json")
    t = scene_tables(cs)
    assert np.shares_memory(t["bvh_nodes"], cs.bvh_nodes) and scene_tables(cs)["bvh_nodes"] is t["bvh_nodes"]
    table, rows = device_geometry(cs.bvh_nodes.copy(), cs.bvh_prims, cs.tri_vertices, cs.spheres)
    np.testing.assert_array_equal(table, t["bvh_nodes"])
    np.testing.assert_array_equal(rows, t["tri_rows"])
    cs.tri_vertices[0, 0, 0] += 1.0  # changed in place: the records must follow
    moved = scene_tables(cs)
    assert moved["bvh_nodes"] is not t["bvh_nodes"]
    np.testing.assert_array_equal(moved["bvh_nodes"], device_geometry(cs.bvh_nodes, cs.bvh_prims, cs.tri_vertices,
                                                                      cs.spheres)[0])
    assert not np.array_equal(moved["bvh_nodes"], t["bvh_nodes"])


def test_a_scene_without_its_primitives_keeps_its_settings() -> None:
    cs = _scene("cornell.json")
    light = cs.without_primitives()
    assert light.num_triangles == 0 and light.vertex_normals is None and light.device_bvh is None
    assert (light.width, light.height, light.integrator, light.max_depth) == (cs.width, cs.height, cs.integrator,
                                                                             cs.max_depth)
    np.testing.assert_array_equal(light.bounds, cs.bounds)
    assert cs.num_triangles > 0 and light.buffer_cache is not cs.buffer_cache
