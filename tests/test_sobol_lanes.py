"""The Sobol' back end with lanes at different samples and dimensions, against its NumPy twin.

The render's packets draw with every lane at its own depth (so dimension) and
mostly one point (kernels/samplers/sobol_sampler.cl groups such lanes by
dimension; a packet of several points goes lane by lane; lanes at one
dimension take the packet path), four or eight coordinates at a time, and the
camera's pairs through sampler_next_2d.  Each way must give exactly the
numbers of tests/test_integrate_sobol.py's twin of the back end.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest
from test_integrate_sobol import _twin_points

from mcocl import runtime

LANES = 16
LOG2_POINTS = 8  # as a render build (mcocl/render/sobol_film.py)
TABLE_DIMS = 128
SEED = 0x1234_5678_9ABC


def _device(index: np.ndarray, dim: np.ndarray, count: int, lanes: int = LANES) -> np.ndarray:
    """(packets, lanes, count) uniforms of kernels/samplers/sampler_points.cl's sampler_points_at."""
    ctx = runtime.device_context()
    src = runtime.compose(["samplers/sampler_points.cl"])
    prg = runtime.build(ctx, src, [f"-DLANES={lanes}", "-DDIM=1", "-DSAMPLER_BACKEND=SAMPLER_BACKEND_SOBOL",
                                   f"-DSOBOL_LOG2_POINTS={LOG2_POINTS}", f"-DSOBOL_TABLE_DIMS={TABLE_DIMS}"],
                        what="sobol lane points")
    packets = len(index) // lanes
    mf = cl.mem_flags
    ib = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(index, np.uint64))
    db = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(dim, np.uint32))
    out = np.empty((packets, count, lanes), np.float32)
    ob = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
    runtime.kernel(prg, "sampler_points_at")(ctx.queue, (packets,), None, ib, db, np.uint32(count), np.uint64(SEED),
                                             ob)
    cl.enqueue_copy(ctx.queue, out, ob)
    return out.transpose(0, 2, 1)


def _twin(index: np.ndarray, dim: np.ndarray, count: int, lanes: int = LANES) -> np.ndarray:
    """The same uniforms from the twin: coordinates dim .. dim + count - 1 of each sample."""
    rows = [_twin_points(int(d) + count, int(i), 1, SEED, LOG2_POINTS)[0, int(d):int(d) + count]
            for i, d in zip(index, dim)]
    return np.array(rows, np.float32).reshape(-1, lanes, count)


def _case(points: str, dims: str, count: int, packets: int = 6, lanes: int = LANES) -> tuple[np.ndarray, np.ndarray]:
    """Sample indices and dimensions of `packets` packets: lanes at one point or at several, one dimension or many."""
    gen = np.random.default_rng([points == "one", dims == "one", count])
    replicate = gen.integers(0, 1 << 20, (packets, lanes), dtype=np.uint64)  # every lane its own scrambling
    if points == "one":
        point = np.repeat(gen.integers(0, 1 << LOG2_POINTS, (packets, 1), dtype=np.uint64), lanes, axis=1)
    else:
        point = gen.integers(0, 1 << LOG2_POINTS, (packets, lanes), dtype=np.uint64)
    step = 2 if count == 2 else 4
    top = (TABLE_DIMS - count) // step + 1
    if dims == "one":
        dim = np.repeat(gen.integers(0, top, (packets, 1)), lanes, axis=1) * step
    else:
        dim = gen.integers(0, top, (packets, lanes)) * step
    index = (replicate << np.uint64(LOG2_POINTS)) | point
    return index.reshape(-1), dim.reshape(-1).astype(np.uint32)


@pytest.mark.parametrize("count", [2, 4, 8])
@pytest.mark.parametrize(("points", "dims"), [("one", "many"), ("many", "many"), ("one", "one"), ("many", "one")])
def test_lanes_at_different_dimensions_draw_the_twins_numbers(points: str, dims: str, count: int) -> None:
    index, dim = _case(points, dims, count)
    np.testing.assert_array_equal(_device(index, dim, count), _twin(index, dim, count))


@pytest.mark.parametrize("lanes", [2, 4, 8])
def test_narrower_lane_builds_draw_the_twins_numbers(lanes: int) -> None:
    index, dim = _case("one", "many", 8, lanes=lanes)
    np.testing.assert_array_equal(_device(index, dim, 8, lanes), _twin(index, dim, 8, lanes))
