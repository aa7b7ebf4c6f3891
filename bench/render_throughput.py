"""Path-tracing throughput on the Cornell box, and efficiency against Mitsuba 3.

    python bench/render_throughput.py                        # paths/s and build time
    python bench/render_throughput.py --mitsuba /work/venv-mitsuba/bin/python \\
        --llvm /work/llvm19/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

Renders ``scenes/cornell.json`` (Mitsuba 3's ``cornell_box()``, 256 x 256)
with the ``mis`` integrator, max_depth 8, rr_depth 5, and reports

- the kernel build time, cold (empty PoCL cache, in a subprocess) and cached;
- paths per second = spp x pixels / seconds of sampling, after the build,
  the best and the median of ``--repeats`` renders, with the CPU seconds the
  process used per million paths (less sensitive to other load);
- with ``--mitsuba``: Mitsuba's time for the same image (bench/mitsuba_cornell.py
  in its own environment, box filter, same depths; one process per run,
  interleaved with ours so that both see the same load; Mitsuba's JIT
  compilation is excluded like our build), the RMSE of both against
  a high-spp reference rendered by mcocl (cached in ``--out``), and the ratio
  of efficiencies, efficiency = 1 / (RMSE^2 x seconds).  The reference's own
  variance (known per pixel) is subtracted from the squared errors, so a
  finite reference does not flatter either renderer.

The machine is usually shared: run it on a quiet machine for figures to
publish, and read the CPU-time column when it is not.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from mcocl.render.api import render  # noqa: E402

SCENE = ROOT / "scenes" / "cornell.json"

COLD_BUILD = """
import time, sys
from mcocl import runtime
from mcocl.render.compiled import load_compiled
from mcocl.render.job import RenderJob, scene_tables
cs = load_compiled(sys.argv[1])
job = RenderJob(scene_tables(cs), cs.width, cs.height, sys.argv[2], 8, 5, 0, 1, 1, None if sys.argv[3] == 'None' else int(sys.argv[3]))
ctx = runtime.device_context()
t0 = time.perf_counter()
r = job.runner(ctx)
print(time.perf_counter() - t0)
"""


def cold_build_seconds(integrator: str, lanes: int | None) -> float:
    """Kernel build time with an empty PoCL cache, measured in a fresh process."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, POCL_CACHE_DIR=cache)
        p = subprocess.run([sys.executable, "-c", COLD_BUILD, str(SCENE), integrator, str(lanes)],
                           capture_output=True, text=True, env=env, cwd=ROOT, check=True)
        return float(p.stdout.strip().splitlines()[-1])


def reference(out: Path, spp: int) -> tuple[np.ndarray, np.ndarray]:
    """A high-spp mcocl render (mean, variance of the mean), cached in `out`."""
    f = out / f"reference_mis_{spp}spp.npz"
    if f.exists():
        z = np.load(f)
        return z["mean"], z["variance"]
    print(f"rendering the reference ({spp} spp; cached in {f}) ...", flush=True)
    r = render(SCENE, spp=spp, integrator="mis", max_depth=8, rr_depth=5, seed=123456, progress=True)
    np.savez(f, mean=r.mean, variance=r.variance)
    return r.mean, r.variance


def rmse2(img: np.ndarray, ref: np.ndarray, ref_var: np.ndarray) -> float:
    """Mean squared error against the reference, less the reference's own variance."""
    d = img.astype(np.float64) - ref.astype(np.float64)
    return float(np.mean(d * d) - np.mean(ref_var.astype(np.float64)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of each timed render (default 64)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--integrator", default="mis", choices=("path", "nee", "mis"))
    ap.add_argument("--lanes", type=int, default=None, help="vector width (default: the device's)")
    ap.add_argument("--no-cold-build", action="store_true", help="skip the cold-build measurement")
    ap.add_argument("--mitsuba", default=None, metavar="PYTHON", help="Python of a venv with mitsuba: compare with it")
    ap.add_argument("--llvm", default=None, metavar="LIBLLVM", help="libLLVM.so for Mitsuba's llvm variants (DRJIT_LIBLLVM_PATH)")
    ap.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (default llvm_ad_rgb)")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--out", default=str(ROOT / "bench-out" / "render"))
    ap.add_argument("--json", action="store_true", help="print the results as one JSON object")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    res: dict = {"scene": str(SCENE.relative_to(ROOT)), "integrator": args.integrator, "spp": args.spp,
                 "max_depth": 8, "rr_depth": 5, "cpus": os.cpu_count(), "loadavg_start": os.getloadavg()}
    if not args.no_cold_build:
        res["build_seconds_cold"] = cold_build_seconds(args.integrator, args.lanes)
    env = dict(os.environ)
    if args.llvm:
        env["DRJIT_LIBLLVM_PATH"] = args.llvm
    mdir = out / "mitsuba"

    def mitsuba_once(k: int) -> tuple[float, float, np.ndarray, dict]:
        """One timed Mitsuba render (after its JIT warm-up) in its own process."""
        p = subprocess.run([args.mitsuba, str(ROOT / "bench" / "mitsuba_cornell.py"), "--variant", args.variant,
                            "--spp", str(args.spp), "--repeats", "1", "--seed", str(k), "--out", str(mdir)],
                           capture_output=True, text=True, env=env, cwd=ROOT)
        if p.returncode != 0:
            raise SystemExit(f"Mitsuba failed:\n{p.stderr[-3000:]}")
        info = json.loads((mdir / "mitsuba_times.json").read_text())
        return info["times"][0], info["cpu_seconds"][0], np.load(mdir / f"mitsuba_{args.spp}spp_0.npy"), info

    # Interleave the two renderers run by run, so that both see the same load.
    warm = render(SCENE, spp=1, integrator=args.integrator, max_depth=8, rr_depth=5, seed=999, lanes=args.lanes)
    runs, images, mi_times, mi_cpu, mi_imgs, mi = [], [], [], [], [], {}
    for k in range(args.repeats):
        c0 = time.process_time()
        r = render(SCENE, spp=args.spp, integrator=args.integrator, max_depth=8, rr_depth=5, seed=1 + k,
                   lanes=args.lanes)
        cpu = time.process_time() - c0
        runs.append({"seconds": r.seconds, "cpu_seconds": cpu, "paths_per_second": r.samples_per_second,
                     "cpu_seconds_per_mpath": cpu / (r.samples / 1e6), "loadavg": os.getloadavg()[0]})
        images.append(r.mean)
        if args.mitsuba:
            t, c, im, mi = mitsuba_once(k)
            mi_times.append(t)
            mi_cpu.append(c)
            mi_imgs.append(im)
    pps = [r["paths_per_second"] for r in runs]
    res.update({"device": warm.device, "lanes": warm.lanes, "build_seconds_cached": warm.build_seconds,
                "paths_per_second_best": max(pps), "paths_per_second_median": statistics.median(pps),
                "cpu_seconds_per_mpath_best": min(r["cpu_seconds_per_mpath"] for r in runs), "runs": runs})

    if args.mitsuba:
        ref, ref_var = reference(out, args.reference_spp)
        e_ours = [rmse2(im, ref, ref_var) for im in images]
        e_mi = [rmse2(im, ref, ref_var) for im in mi_imgs]
        t_ours = statistics.median(r["seconds"] for r in runs)
        t_mi = statistics.median(mi_times)
        eff_ours = 1.0 / (statistics.mean(e_ours) * t_ours)
        eff_mi = 1.0 / (statistics.mean(e_mi) * t_mi)
        # the same with the CPU seconds each process used: less sensitive to other load on a shared machine
        c_ours = statistics.median(r["cpu_seconds"] for r in runs)
        c_mi = statistics.median(mi_cpu)
        res["efficiency_ratio_cpu"] = (statistics.mean(e_mi) * c_mi) / (statistics.mean(e_ours) * c_ours)
        mi_mean = np.mean(mi_imgs, axis=0)
        res["mitsuba"] = {
            "variant": mi["variant"], "version": mi["version"], "seconds_median": t_mi, "seconds": mi_times,
            "cpu_seconds": mi_cpu,
            "samples_per_second": args.spp * mi["width"] * mi["height"] / t_mi,
            "rmse": float(np.sqrt(statistics.mean(e_mi))),
            "rmse_sqrt_spp": float(np.sqrt(statistics.mean(e_mi) * args.spp)),
            "image_mean_rgb": [float(x) for x in mi_mean.reshape(-1, 3).mean(axis=0)],
            "first_call_seconds": mi["first_call_seconds"],
        }
        res["ours_rmse"] = float(np.sqrt(statistics.mean(e_ours)))
        res["ours_rmse_sqrt_spp"] = float(np.sqrt(statistics.mean(e_ours) * args.spp))
        res["ours_seconds_median"] = t_ours
        res["reference_spp"] = args.reference_spp
        res["reference_mean_rgb"] = [float(x) for x in ref.reshape(-1, 3).mean(axis=0)]
        res["efficiency_ratio"] = eff_ours / eff_mi
    res["loadavg_end"] = os.getloadavg()

    if args.json:
        print(json.dumps(res, indent=2))
        return
    print(f"scene      {res['scene']} 256x256, {args.integrator}, max_depth 8, rr_depth 5, {args.spp} spp x {args.repeats}")
    print(f"device     {res['device']} ({res['lanes']} lanes), {res['cpus']} CPUs, load average "
          f"{res['loadavg_start'][0]:.1f} -> {res['loadavg_end'][0]:.1f}")
    if "build_seconds_cold" in res:
        print(f"build      {res['build_seconds_cold']:.2f} s cold (empty PoCL cache), {res['build_seconds_cached']:.2f} s cached")
    print(f"mcocl      {res['paths_per_second_best'] / 1e6:.3g} M paths/s best, {res['paths_per_second_median'] / 1e6:.3g} median; "
          f"{res['cpu_seconds_per_mpath_best']:.3f} CPU-s per M paths")
    if args.mitsuba:
        m = res["mitsuba"]
        print(f"Mitsuba    {m['version']} {m['variant']}: {m['samples_per_second'] / 1e6:.3g} M samples/s "
              f"(median {m['seconds_median']:.2f} s), RMSE x sqrt(spp) = {m['rmse_sqrt_spp']:.3f}")
        print(f"mcocl      median {res['ours_seconds_median']:.2f} s, RMSE x sqrt(spp) = {res['ours_rmse_sqrt_spp']:.3f}")
        print(f"reference  mcocl mis {args.reference_spp} spp; image means: reference {np.round(res['reference_mean_rgb'], 4)}, "
              f"Mitsuba {np.round(m['image_mean_rgb'], 4)}")
        print(f"efficiency 1/(RMSE^2 x s): mcocl / Mitsuba = {res['efficiency_ratio']:.2f} (wall time), "
              f"{res['efficiency_ratio_cpu']:.2f} (CPU time of each process)")
    (out / "render_throughput.json").write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
