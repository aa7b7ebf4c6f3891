"""Render a scene in Mitsuba 3 the way bench/render_throughput.py renders it in mcocl.

Run with the Python of a separate virtual environment that has ``mitsuba``
(it is not a dependency of mcocl):

    python3 -m venv /work/venv-mitsuba && /work/venv-mitsuba/bin/pip install mitsuba numpy
    /work/venv-mitsuba/bin/python bench/mitsuba_render.py --scene scenes/veach_mis.json --spp 64 --out DIR

``llvm_ad_rgb`` needs an LLVM that works on the CPU (Debian's LLVM 15 crashes
here; LLVM 19 works): ``apt-get download libllvm19; dpkg -x libllvm19_*.deb DIR``
and ``DRJIT_LIBLLVM_PATH=DIR/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1``.

``--scene`` is one of mcocl's JSON scenes, converted by bench/mitsuba_scene.py
(box filter, independent sampler, path integrator with the scene's depths);
without it, ``mitsuba.cornell_box()`` with a box filter and the path
integrator with max_depth 8, rr_depth 5.  Writes ``mitsuba_<spp>spp_<k>.npy``
(H, W, 3) images, ``mitsuba_times.json`` (wall and CPU seconds of each
timed render after a first, JIT-compiling one) and ``load_seconds``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=None, help="an mcocl JSON scene (default: mitsuba.cornell_box())")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--rr-depth", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0, help="seed of the first timed render (then seed + 1, ...)")
    ap.add_argument("--out", default="bench-out/render/mitsuba")
    ap.add_argument("--sampler", default="independent",
                    help="Mitsuba sampler plugin (independent, stratified, multijitter, ldsampler, orthogonal)")
    args = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t_load = time.perf_counter()
    if args.scene:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from mitsuba_scene import load

        scene = load(mi, args.scene, out / "meshes", args.spp, args.sampler)
    else:
        d = mi.cornell_box()
        d["sensor"]["film"]["rfilter"] = {"type": "box"}
        d["integrator"] = {"type": "path", "max_depth": args.max_depth, "rr_depth": args.rr_depth}
        scene = mi.load_dict(d)
    load_seconds = time.perf_counter() - t_load
    t0 = time.perf_counter()
    img = mi.render(scene, spp=args.spp, seed=1_000_000 + args.seed)  # first call: JIT compilation
    np.asarray(img)
    first = time.perf_counter() - t0
    times, cpu = [], []
    for k in range(args.repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        img = mi.render(scene, spp=args.spp, seed=args.seed + k)
        dr.eval(img)
        a = np.array(img, dtype=np.float32)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        np.save(out / f"mitsuba_{args.spp}spp_{k}.npy", a[..., :3])
    info = {"variant": args.variant, "sampler": args.sampler, "version": mi.__version__, "spp": args.spp, "times": times, "cpu_seconds": cpu,
            "first_call_seconds": first, "load_seconds": load_seconds, "width": int(a.shape[1]), "height": int(a.shape[0])}
    (out / "mitsuba_times.json").write_text(json.dumps(info, indent=2))
    print(json.dumps(info))


if __name__ == "__main__":
    main()
