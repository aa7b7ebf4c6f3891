"""Time the light BVH's walks alone (kernels/render/light_bvh.cl), issue 14.

A kernel draws, per work-item, LANES shading points spread over the scene's
bounding box with random normals, chooses a light from each with
light_bvh_sample and recomputes its probability with light_bvh_pmf (the MIS
weight's walk of a BSDF-sampled hit), ``rounds`` times over.  Printed: the
CPU nanoseconds (all threads; the machine may be shared) per (sample + pmf) pair, and for the sample walk alone, on each
scene; the renders' cost of the light choice, apart from tracing.

Usage: python bench/light_walk.py [--points N] [--rounds R] [scene.json ...]
"""

from __future__ import annotations

import argparse
import resource
from pathlib import Path

import numpy as np
import pyopencl as cl

from mcocl import runtime
from mcocl.layouts import LightSampler
from mcocl.render.compiled import compile_scene
from mcocl.render.device_scene import scene_buffers, scene_params, scene_tables
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"

KERNEL = r"""
/* Hash of (item, round, k) to a uniform in (0, 1) (a benchmark's points, not a sampler). */
MC_INLINE floatv walk_bench_u(uintv i, uint r, uint k) {
    uintv h = i * 0x9E3779B1u + (uintv)(r * 0x85EBCA77u + k * 0xC2B2AE3Du);
    h ^= h >> 15; h *= 0x2C1B3C6Du; h ^= h >> 12; h *= 0x297A2D39u; h ^= h >> 15;
    return (to_floatv(h >> 9) + 0.5f) * (1.0f / 8388608.0f);
}

kernel void light_walk_bench(LIGHT_TEST_PARAMS, float4 lo, float4 hi, uint rounds, uint with_pmf, uint n,
                             global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    LIGHT_TEST_SETUP;
    uintv id = (uintv)(base) + LANE_IOTA;
    intv all = (intv)(0) == (intv)(0);
    floatv acc = (floatv)(0.0f);
    for (uint r = 0u; r < rounds; ++r) {
        vec3v p = v3(lo.x + (hi.x - lo.x) * walk_bench_u(id, r, 0u), lo.y + (hi.y - lo.y) * walk_bench_u(id, r, 1u),
                     lo.z + (hi.z - lo.z) * walk_bench_u(id, r, 2u));
        vec3v nn = v3_normalize(v3(walk_bench_u(id, r, 3u) - 0.5f, walk_bench_u(id, r, 4u) - 0.5f,
                                   walk_bench_u(id, r, 5u) - 0.5f));
        floatv pmf;
        uintv k = light_bvh_sample(lt.light_bvh, p, nn, walk_bench_u(id, r, 6u), all, &pmf);
        acc += pmf;
        if (with_pmf) {
            intv ok = pmf > 0.0f;
            LIGHT_RECORD_GATHER(q, lt.light_rec, k);
            uintv prim = lane_as_uint(REC_FIELD(q, LIGHT_RECORD_PRIM));
            acc += light_bvh_pmf(lt.light_bvh, p, nn, gather_uint(lt.light_trail, prim), ok);
        }
    }
    store_floatv(acc, out + base);
}
"""


def _cpu_seconds() -> float:
    """CPU seconds of this process and its threads (the device's workers): robust on a shared machine."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def bench(path: Path, points: int, rounds: int) -> tuple[float, float, float]:
    """Nanoseconds per sample walk, per (sample + pmf) walk pair, and a checksum, on one scene."""
    cs = compile_scene(load_scene(path)).with_settings(light_sampler="bvh")
    ctx = runtime.device_context()
    src = runtime.compose(["render/light_sample_test.cl"], generated=KERNEL)
    prg = runtime.build(ctx, src, [f"-DLANES={ctx.lanes}", f"-DLIGHT_SAMPLER={int(LightSampler.BVH)}"],
                        what="light walk bench")
    b = scene_buffers(cs, ctx)
    names = ("bvh_nodes", "tri_rows", "spheres", "sphere_flip", "prim_rec",
             "emitter_radiance", "light_rec", "light_cdf", "light_bvh", "light_trail")
    args = [scene_params(scene_tables(cs)), *(b[k] for k in names)]
    lo = np.float32([*cs.bounds[0][:3], 0])
    hi = np.float32([*cs.bounds[1][:3], 0])
    out = np.empty(points, np.float32)
    bo = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    g, lsz = ctx.work_size(-(-points // ctx.lanes))
    k = runtime.kernel(prg, "light_walk_bench")
    ns = []
    for with_pmf in (0, 1):
        best = float("inf")
        for _ in range(3):
            t = _cpu_seconds()
            k(ctx.queue, g, lsz, *args, lo, hi, np.uint32(rounds), np.uint32(with_pmf), np.uint32(points), bo)
            ctx.queue.finish()
            best = min(best, _cpu_seconds() - t)
        ns.append(best / (points * rounds) * 1e9)
    cl.enqueue_copy(ctx.queue, out, bo)
    return ns[0], ns[1], float(out.astype(np.float64).sum())


def main() -> int:
    """Print the walk times of each scene."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", type=Path,
                    default=[SCENES / n for n in ("veach_mis.json", "many_lights.json", "cornell.json")])
    ap.add_argument("--points", type=int, default=1 << 16)
    ap.add_argument("--rounds", type=int, default=8)
    a = ap.parse_args()
    print(f"{'scene':<24} {'ns/sample':>10} {'ns/(sample+pmf)':>16} {'checksum':>14}")
    for path in a.scenes:
        s, sp, chk = bench(path, a.points, a.rounds)
        print(f"{path.name:<24} {s:>10.1f} {sp:>16.1f} {chk:>14.6e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
