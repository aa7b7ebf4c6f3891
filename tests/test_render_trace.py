"""Packet traversal (kernels/render/trace_packet.cl) against bvh.cl's scalar traversal.

The renderer's lane builds trace LANES rays together through the BVH that the
scene half builds; it must find exactly the hits the scalar traversal finds:
same primitive, same distance, same occlusion answer, on random triangle soups
with spheres, an empty scene, degenerate triangles and axis-parallel rays.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from mcocl import runtime
from mcocl.render.compiled import compile_scene
from mcocl.render.device_scene import geom_args
from mcocl.render.scene import parse_scene


def _scene(rng: np.random.Generator, ntri: int, nsph: int, degenerate: int = 0) -> dict:
    c = rng.uniform(-1, 1, (ntri, 1, 3))
    v = (c + rng.normal(0, 0.25, (ntri, 3, 3)))
    if degenerate:
        v[:degenerate, 2] = v[:degenerate, 1]  # zero-area triangles
    shapes = []
    if ntri:
        shapes.append({"type": "mesh", "material": "m", "vertices": v.reshape(-1, 3).tolist(),
                       "faces": np.arange(3 * ntri).reshape(-1, 3).tolist()})
    for _ in range(nsph):
        shapes.append({"type": "sphere", "material": "m", "center": rng.uniform(-1, 1, 3).tolist(),
                       "radius": float(rng.uniform(0.02, 0.4))})
    return {"camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
            "materials": {"m": {"type": "diffuse", "reflectance": 0.5}}, "shapes": shapes}


def _rays(rng: np.random.Generator, n: int) -> np.ndarray:
    o = rng.uniform(-1.5, 1.5, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[: n // 8, :2] = 0.0  # axis-parallel rays: zero direction components
    d[: n // 8, 2] = np.sign(d[: n // 8, 2]) + (d[: n // 8, 2] == 0)
    tmax = rng.uniform(0.1, 3.0, n)
    return np.concatenate([o.T, d.T, tmax[None]]).astype(np.float32)


def compare(scene: dict, rays: np.ndarray, lanes: int = 8) -> np.ndarray:
    cs = compile_scene(parse_scene(scene))
    ctx = runtime.device_context()
    prg = runtime.build(ctx, runtime.compose(["render/trace_test.cl"]), [f"-DLANES={lanes}"], what="trace test kernel")
    n = rays.shape[1]
    mf = cl.mem_flags
    br = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(rays))
    out = np.empty((6, n), np.float32)
    bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
    g, lsz = ctx.work_size(n // lanes)
    runtime.kernel(prg, "trace_compare")(ctx.queue, g, lsz, *geom_args(cs, ctx), np.uint32(n), br, bo)
    cl.enqueue_copy(ctx.queue, out, bo)
    return out


@pytest.mark.parametrize("ntri,nsph,degenerate", [(300, 20, 0), (2000, 0, 0), (0, 50, 0), (40, 5, 10), (1, 0, 0)])
@pytest.mark.parametrize("lanes", [8, 16])
def test_packet_matches_scalar(ntri: int, nsph: int, degenerate: int, lanes: int) -> None:
    rng = np.random.default_rng(ntri * 7 + nsph)
    rays = _rays(rng, 4096)
    out = compare(_scene(rng, ntri, nsph, degenerate), rays, lanes)
    t_p, prim_p, any_p, t_s, prim_s, any_s = out
    same = prim_p == prim_s
    # ties (two primitives at the same distance) may resolve either way
    tie = ~same & np.isclose(t_p, t_s, rtol=1e-6)
    assert np.all(same | tie), f"{np.sum(~(same | tie))} rays hit different primitives"
    hit = prim_s >= 0
    assert hit.any() and (~hit).any()
    # the same formulas, but the compiler may contract them into fma differently
    np.testing.assert_allclose(t_p[hit], t_s[hit], rtol=1e-5, atol=1e-6)
    assert np.all(np.isinf(t_p[~hit]))
    np.testing.assert_array_equal(any_p, any_s)


def test_empty_scene() -> None:
    rng = np.random.default_rng(3)
    out = compare(_scene(rng, 0, 0), _rays(rng, 256))
    assert np.all(out[1] == -1) and np.all(out[2] == 0) and np.all(out[4] == -1)
