"""Path-tracing throughput, and efficiency against Mitsuba 3 on the bench's scenes.

    python bench/render_throughput.py                        # Cornell box: paths/s and build time
    python bench/render_throughput.py --mitsuba /work/mitsuba-venv/bin/python \\
        --llvm /work/llvm19/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
        --scenes cornell cornell_spheres veach_mis many_lights big --big-triangles 1000000

Without ``--mitsuba``: renders ``scenes/cornell.json`` (256 x 256, ``mis``,
max_depth 8, rr_depth 5) and reports the kernel build time, cold (empty PoCL
cache, in a subprocess) and cached, and paths per second (best and median of
``--repeats``) with the CPU seconds per million paths.

With ``--mitsuba``, for every scene of ``--scenes``:

- ``cornell``: scenes/cornell.json (Mitsuba's ``cornell_box()``);
- ``cornell_spheres``: the same box with its two boxes replaced by a mirror
  and a glass sphere (written into ``--out``);
- ``veach_mis``, ``many_lights``, ``caustic``: scenes/veach_mis.json, scenes/many_lights.json,
  scenes/caustic.json (its reference is rendered by ``bdpt``: ``mis`` leaves the caustic noisy);
- ``big``: the big-mesh scene of bench/make_big_scene.py with
  ``--big-triangles`` triangles (generated into ``--out`` when missing);

mcocl renders ``--spp`` spp with each of ``--configs`` (integrator/light
sampler[/render sampler], e.g. ``mis/power`` or ``mis/auto/sobol``; without the
third part the render's default sampler ``auto``, which is ``sobol`` for the
path integrators at 8 spp or more: mcocl/render/sampler_choice.py; the JSON
records the sampler that ran), Mitsuba
(bench/mitsuba_render.py in its own environment, the scene converted by
bench/mitsuba_scene.py: box filter, the ``--mitsuba-sampler`` (independent by
default; ``multijitter``, ``ldsampler``... stratify as our ``sobol`` does),
``path`` integrator with the scene's max_depth and rr_depth) renders the same spp, one process per repeat, the runs interleaved
so that both renderers see the same load.  Times exclude the kernel build
(ours) and the JIT compilation (Mitsuba's first call) and the scene load.
Errors are against a reference rendered by mcocl (``mis``, power light
choice, ``--reference-seconds`` of sampling, its own seed; cached in
``--out``); the reference's variance of the mean is subtracted from every
squared error, so a finite reference does not flatter either renderer.
Efficiency = 1 / (MSE x seconds), MSE over pixels and channels, seconds the
median over repeats of wall time (and, separately, of the CPU time the
process used, less sensitive to other load on a shared machine).  The
table's mcocl column is the best configuration of each scene (chosen on the
same runs: slightly optimistic; every configuration is in the JSON).
"""

from __future__ import annotations

import argparse
import hashlib
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

from mcocl.render import compile_scene  # noqa: E402
from mcocl.render.api import render  # noqa: E402
from mcocl.render.sampler_choice import resolve_auto_sampler  # noqa: E402

SCENE = ROOT / "scenes" / "cornell.json"
SCENE_FILES = {"cornell": SCENE, "veach_mis": ROOT / "scenes" / "veach_mis.json",
               "many_lights": ROOT / "scenes" / "many_lights.json", "caustic": ROOT / "scenes" / "caustic.json"}
# The reference's integrator: mis, except where mis leaves the image noisy for far longer than the
# reference's budget (a caustic of a small lamp through glass, which only bdpt's light subpaths resolve).
REFERENCE_INTEGRATOR = {"caustic": "bdpt"}

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


def cornell_spheres(out: Path) -> Path:
    """scenes/cornell.json with a mirror sphere and a glass sphere instead of its two boxes."""
    d = json.loads(SCENE.read_text())
    d["comment"] = "Written by bench/render_throughput.py: the Cornell box with a mirror and a glass sphere."
    d["materials"]["mirror"] = {"type": "conductor"}
    d["materials"]["glass"] = {"type": "dielectric", "int_ior": 1.5}
    d["shapes"] = [s for s in d["shapes"] if s.get("name") not in ("small-box", "large-box")]
    d["shapes"] += [{"name": "mirror-ball", "type": "sphere", "material": "mirror", "center": [-0.42, -0.68, -0.35],
                     "radius": 0.32},
                    {"name": "glass-ball", "type": "sphere", "material": "glass", "center": [0.42, -0.68, 0.25],
                     "radius": 0.32}]
    p = out / "cornell_spheres.json"
    p.write_text(json.dumps(d, indent=1) + "\n")
    return p


def big_scene(out: Path, triangles: int) -> Path:
    """The big-mesh scene of bench/make_big_scene.py, generated into ``out/big_<triangles>`` once."""
    folder = out / f"big_{triangles}"
    if not (folder / "big_scene.json").exists():
        subprocess.run([sys.executable, str(ROOT / "bench" / "make_big_scene.py"), "--triangles", str(triangles),
                        "--out", str(folder)], check=True)
    return folder / "big_scene.json"


def scene_variant(src: Path, integrator: str, light_sampler: str) -> Path:
    """A copy of the scene beside it with the integrator and light sampler set (OBJ paths stay valid)."""
    d = json.loads(src.read_text())
    d.setdefault("integrator", {}).update({"type": integrator, "light_sampler": light_sampler})
    folder = src.parent if not src.resolve().is_relative_to(ROOT / "scenes") else Path(tempfile.gettempdir())
    p = folder / f".{src.stem}.{integrator}.{light_sampler}.json"
    p.write_text(json.dumps(d))
    return p


def reference(out: Path, scene: Path, seconds: float, integrator: str = "mis") -> tuple[np.ndarray, np.ndarray, str]:
    """An mcocl render of ``seconds`` with ``integrator`` (mean, variance of the mean, how), cached by the
    scene's digest."""
    # mis keeps the key it had before the integrator was a choice, so cached references stay valid
    tag = b"" if integrator == "mis" else integrator.encode()
    key = hashlib.sha256(scene.read_bytes() + str(seconds).encode() + tag).hexdigest()[:12]
    f = out / f"reference_{scene.stem}_{key}.npz"
    if f.exists():
        z = np.load(f)
        return z["mean"], z["variance"], str(z["how"])
    print(f"rendering the reference of {scene.name} ({seconds:g} s; cached in {f}) ...", flush=True)
    r = render(compile_scene(scene_variant(scene, integrator, "power")), None, time_budget=seconds,
               integrator=integrator, seed=0x5EED, progress=False)
    how = f"mcocl {integrator}/power, {r.spp} spp, {r.seconds:.0f} s"
    np.savez(f, mean=r.mean, variance=r.variance, how=how)
    return r.mean, r.variance, how


def mse(img: np.ndarray, ref: np.ndarray, ref_var: np.ndarray) -> float:
    """Mean squared error against the reference, less the reference's own variance."""
    d = img.astype(np.float64) - ref.astype(np.float64)
    return float(np.mean(d * d) - np.mean(ref_var.astype(np.float64)))


def ran_sampler(integrator: str, spp: int, sampler: str, pixels: int) -> str:
    """The sampler a render of ``spp`` spp over ``pixels`` pixels runs with (``auto`` resolved): its kernel
    is built before the timing."""
    return resolve_auto_sampler(integrator, spp, None, None, pixels)[0] if sampler == "auto" else sampler


def throughput_only(args: argparse.Namespace, out: Path) -> None:
    """Paths/s and build time on the Cornell box (no Mitsuba)."""
    cornell = compile_scene(SCENE)
    sampler = ran_sampler(args.integrator, args.spp, args.sampler, cornell.width * cornell.height)
    res: dict = {"scene": str(SCENE.relative_to(ROOT)), "integrator": args.integrator, "spp": args.spp,
                 "sampler": sampler, "cpus": os.cpu_count(), "loadavg_start": os.getloadavg()}
    if not args.no_cold_build:
        res["build_seconds_cold"] = cold_build_seconds(args.integrator, args.lanes)
    warm = render(SCENE, spp=1, integrator=args.integrator, seed=999, lanes=args.lanes, sampler=sampler)
    runs = []
    for k in range(args.repeats):
        c0 = time.process_time()
        r = render(SCENE, spp=args.spp, integrator=args.integrator, seed=1 + k, lanes=args.lanes, sampler=sampler)
        cpu = time.process_time() - c0
        runs.append({"seconds": r.seconds, "cpu_seconds": cpu, "paths_per_second": r.samples_per_second,
                     "cpu_seconds_per_mpath": cpu / (r.samples / 1e6)})
    pps = [r["paths_per_second"] for r in runs]
    res.update({"device": warm.device, "lanes": warm.lanes, "build_seconds_cached": warm.build_seconds,
                "paths_per_second_best": max(pps), "paths_per_second_median": statistics.median(pps),
                "cpu_seconds_per_mpath_best": min(r["cpu_seconds_per_mpath"] for r in runs), "runs": runs,
                "loadavg_end": os.getloadavg()})
    (out / "render_throughput.json").write_text(json.dumps(res, indent=2))
    if args.json:
        print(json.dumps(res, indent=2))
        return
    print(f"scene      {res['scene']}, {args.integrator}, {sampler} sampler, {args.spp} spp x {args.repeats}")
    print(f"device     {res['device']} ({res['lanes']} lanes), {res['cpus']} CPUs, load average "
          f"{res['loadavg_start'][0]:.1f} -> {res['loadavg_end'][0]:.1f}")
    if "build_seconds_cold" in res:
        print(f"build      {res['build_seconds_cold']:.2f} s cold (empty PoCL cache), {res['build_seconds_cached']:.2f} s cached")
    print(f"mcocl      {res['paths_per_second_best'] / 1e6:.3g} M paths/s best, {res['paths_per_second_median'] / 1e6:.3g} "
          f"median; {res['cpu_seconds_per_mpath_best']:.3f} CPU-s per M paths")


def compare_scene(args: argparse.Namespace, out: Path, name: str, scene: Path, env: dict) -> dict:
    """mcocl's configurations and Mitsuba on one scene, interleaved run by run (see the module docstring)."""
    configs = [(*c.split("/"), "auto")[:3] for c in args.configs]
    if name in ("cornell", "cornell_spheres", "big", "caustic"):  # one area light: the light sampler cannot matter
        configs = list(dict.fromkeys((integ, "power", smp) for integ, _, smp in configs))
    compiled, load = {}, {}
    for c in configs:
        t0 = time.perf_counter()
        compiled[c] = compile_scene(scene_variant(scene, c[0], c[1]))
        load[c] = time.perf_counter() - t0
        # build the kernel of the sampler the timed renders run with (auto at spp=1 would be independent)
        render(compiled[c], spp=1, integrator=c[0], seed=999, lanes=args.lanes, sampler=ran_sampler(c[0], args.spp, c[2], compiled[c].width * compiled[c].height))
    mdir = out / "mitsuba" / name
    ours: dict = {c: {"seconds": [], "cpu": [], "mse": [], "sampler": ""} for c in compiled}
    mi_runs: dict = {"seconds": [], "cpu": [], "mse": []}
    ref, ref_var, how = reference(out, scene, args.reference_seconds, REFERENCE_INTEGRATOR.get(name, "mis"))
    mi_info: dict = {}
    for k in range(args.repeats):
        for c, cs in compiled.items():
            c0 = time.process_time()
            r = render(cs, spp=args.spp, integrator=c[0], seed=1 + args.seed + k, lanes=args.lanes, sampler=c[2])
            ours[c]["cpu"].append(time.process_time() - c0)
            ours[c]["seconds"].append(r.seconds)
            ours[c]["mse"].append(mse(r.mean, ref, ref_var))
            ours[c]["sampler"] = r.sampler
        p = subprocess.run([args.mitsuba, str(ROOT / "bench" / "mitsuba_render.py"), "--scene", str(scene),
                            "--variant", args.variant, "--spp", str(args.spp), "--repeats", "1", "--seed", str(args.seed + k),
                            "--sampler", args.mitsuba_sampler, "--out", str(mdir)], capture_output=True, text=True, env=env, cwd=ROOT)
        if p.returncode != 0:
            raise SystemExit(f"Mitsuba failed on {scene}:\n{p.stderr[-3000:]}")
        mi_info = json.loads((mdir / "mitsuba_times.json").read_text())
        img = np.load(mdir / f"mitsuba_{args.spp}spp_0.npy")
        mi_runs["seconds"].append(mi_info["times"][0])
        mi_runs["cpu"].append(mi_info["cpu_seconds"][0])
        mi_runs["mse"].append(mse(img, ref, ref_var))
        mi_runs.setdefault("image_mean", []).append(float(img.mean()))

    def eff(runs: dict, key: str) -> float:
        return 1.0 / (statistics.mean(runs["mse"]) * statistics.median(runs[key]))

    rows = {"/".join(c if c[2] != "auto" else c[:2]): {"sampler": v["sampler"],
                                "seconds_median": statistics.median(v["seconds"]),
                                "cpu_seconds_median": statistics.median(v["cpu"]),
                                "mse": statistics.mean(v["mse"]), "load_seconds": load[c],
                                "efficiency_ratio": eff(v, "seconds") / eff(mi_runs, "seconds"),
                                "efficiency_ratio_cpu": eff(v, "cpu") / eff(mi_runs, "cpu")} for c, v in ours.items()}
    best = max(rows, key=lambda c: rows[c]["efficiency_ratio"])
    cs = next(iter(compiled.values()))
    return {"scene": name, "file": str(scene.relative_to(ROOT)) if scene.is_relative_to(ROOT) else str(scene),
            "size": f"{cs.width}x{cs.height}", "max_depth": cs.max_depth, "rr_depth": cs.rr_depth, "spp": args.spp,
            "reference": how, "reference_mean": float(ref.mean()), "configs": rows, "best": best,
            "mitsuba": {"variant": mi_info["variant"], "version": mi_info["version"], "sampler": args.mitsuba_sampler,
                        "seconds_median": statistics.median(mi_runs["seconds"]),
                        "cpu_seconds_median": statistics.median(mi_runs["cpu"]), "mse": statistics.mean(mi_runs["mse"]),
                        "image_mean": statistics.mean(mi_runs["image_mean"]),
                        "load_seconds": mi_info["load_seconds"], "jit_seconds": mi_info["first_call_seconds"]},
            "loadavg": os.getloadavg()[0]}


def main() -> None:
    """Throughput alone, or the comparison with Mitsuba on the chosen scenes."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of each timed render (default 64)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--integrator", default="mis", choices=("path", "nee", "mis"), help="without --mitsuba")
    ap.add_argument("--sampler", default="auto", choices=("auto", "independent", "sobol"),
                    help="without --mitsuba: the render sampler (default auto, the render's default)")
    ap.add_argument("--lanes", type=int, default=None, help="vector width (default: the device's)")
    ap.add_argument("--no-cold-build", action="store_true", help="skip the cold-build measurement")
    ap.add_argument("--mitsuba", default=None, metavar="PYTHON", help="Python of a venv with mitsuba: compare with it")
    ap.add_argument("--llvm", default=None, metavar="LIBLLVM", help="libLLVM.so for Mitsuba's llvm variants (DRJIT_LIBLLVM_PATH)")
    ap.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (default llvm_ad_rgb)")
    ap.add_argument("--mitsuba-sampler", default="independent",
                    help="Mitsuba's sampler plugin (default independent; multijitter or ldsampler stratify)")
    ap.add_argument("--scenes", nargs="+", default=["cornell", "cornell_spheres", "veach_mis", "many_lights", "caustic", "big"])
    ap.add_argument("--configs", nargs="+", default=["mis/power", "nee/power", "mis/bvh", "nee/bvh"],
                    help="mcocl integrator/light_sampler[/sampler] (bvh only on the many-light scenes; the "
                         "sampler auto, independent or sobol, default auto); lt/power "
                         "adds light tracing, which renders mirrors and glass seen directly black (compare it "
                         "only on scenes without them)")
    ap.add_argument("--big-triangles", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=0, help="seeds of the timed renders: SEED + repeat (both renderers)")
    ap.add_argument("--reference-seconds", type=float, default=60.0)
    ap.add_argument("--out", default=str(ROOT / "bench-out" / "render"))
    ap.add_argument("--json", action="store_true", help="print the results as one JSON object")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.mitsuba:
        throughput_only(args, out)
        return
    env = dict(os.environ)
    if args.llvm:
        env["DRJIT_LIBLLVM_PATH"] = args.llvm
    results = []
    for name in args.scenes:
        scene = (SCENE_FILES[name] if name in SCENE_FILES else cornell_spheres(out) if name == "cornell_spheres"
                 else big_scene(out, args.big_triangles))
        results.append(compare_scene(args, out, name, scene, env))
        (out / "mitsuba_compare.json").write_text(json.dumps(results, indent=2))
        r = results[-1]
        print(json.dumps({"scene": name, "best": r["best"], **r["configs"][r["best"]]}), flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
        return
    print(f"\n{args.spp} spp x {args.repeats} repeats, {os.cpu_count()} CPUs; Mitsuba {results[0]['mitsuba']['version']} "
          f"{args.variant}")
    print("| scene | size, depth | mcocl best | mcocl s | Mitsuba s | MSE mcocl / Mitsuba | efficiency ratio (wall) "
          "| (CPU) | image mean mcocl ref / Mitsuba |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        b, m = r["configs"][r["best"]], r["mitsuba"]
        print(f"| {r['scene']} | {r['size']}, {r['max_depth']} | {r['best']} | {b['seconds_median']:.2f} | "
              f"{m['seconds_median']:.2f} | {b['mse'] / m['mse']:.2f} | **{b['efficiency_ratio']:.2f}** | "
              f"{b['efficiency_ratio_cpu']:.2f} | {r['reference_mean']:.4f} / {m['image_mean']:.4f} |")


if __name__ == "__main__":
    main()
