"""What aiming at caustic casters gains, and what it costs where it should not aim.

    PYTHONPATH=. python bench/caster_guiding.py gain --rounds 2      # caustic.json, aiming on / off
    PYTHONPATH=. python bench/caster_guiding.py cost                 # closed boxes lit by a small lamp

``gain``: scenes/caustic.json at ``--spp`` spp, ``--seeds`` seeds, aiming on
and off (``SMALL_LIGHT_SR`` 0: no casters, so the kernel without aiming), each
in its own process, the processes taking turns ``--rounds`` times; MSE against
the cached ``bdpt`` reference of bench/render_throughput.py (its own variance
subtracted), the median wall time of a render (the kernel built before), and
efficiency 1 / (MSE x seconds).

``cost``: the Cornell box with its ceiling light shrunk to 0.1 x 0.1 at the
same power and one glass ball in four places (on the floor, on a table, on the
small box, tiny in a corner), 64 x 64, ``--spp`` spp, ``--seeds`` seeds of
``mis`` with independent samples, squared error against 2048 spp of ``bdpt``
with the lamp's own pixels left out (their edge noise is the same for every
configuration).  Every ball is made a caster (the small-light bound lifted),
and the configurations are: no aiming; the rules of
mcocl/render/caster_guiding.py (the caustic's side and the reach); the side
rule alone; aiming from everywhere.  Printed: each configuration's MSE over
no aiming's.  Nothing of ``cost`` is timed (one process; the ratios are of
errors at equal samples).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from render_throughput import REFERENCE_INTEGRATOR, SCENE_FILES, mse, reference  # noqa: E402

import mcocl.render.caster_guiding as caster_guiding  # noqa: E402
import mcocl.render.device_scene as device_scene  # noqa: E402
from mcocl.render.api import render  # noqa: E402

GLASS = {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}
# (name, [(centre, radius)], extra shapes): the balls of the cost part
TABLE = {"name": "table", "type": "cube", "material": "white",
         "transform": [{"scale": [0.45, 0.02, 0.4]}, {"translate": [-0.3, -0.1, -0.2]}]}
BOXES = (("ball on the floor", [([0.5, -0.8, 0.5], 0.2)], []),
         ("ball on a table", [([-0.3, 0.0, -0.2], 0.08)], [TABLE]),
         ("ball on the small box", [([0.335, -0.1, 0.38], 0.3)], []),
         ("tiny ball in a corner", [([-0.8, -0.95, -0.8], 0.05)], []))
# (name, CASTER_CONE_DEG, CASTER_REACH); None: no aiming
CONFIGS = (("no aiming", None, None), ("side and reach", caster_guiding.CASTER_CONE_DEG, device_scene.CASTER_REACH),
           ("side only", caster_guiding.CASTER_CONE_DEG, 1e9), ("everywhere", 180.0, 1e9))


def small_lamp_box(folder: Path, name: str, balls: list, extra: list, lamp: float = 0.05) -> Path:
    """scenes/cornell.json with its light shrunk to a square of half-side ``lamp`` (same power), glass balls
    and ``extra`` shapes, 64 x 64."""
    d = json.loads((ROOT / "scenes" / "cornell.json").read_text())
    d.pop("comment", None)
    d["materials"]["glass"] = GLASS
    light = d["shapes"][0]
    k = (0.23 * 0.19) / (lamp * lamp)
    light["transform"][0]["scale"] = [lamp, lamp, lamp]
    light["emitter"]["radiance"] = [x * k for x in light["emitter"]["radiance"]]
    for i, (c, r) in enumerate(balls):
        d["shapes"].append({"name": f"ball{i}", "type": "sphere", "center": c, "radius": r, "material": "glass"})
    d["shapes"] += extra
    d["camera"]["width"] = d["camera"]["height"] = 64
    path = folder / (name.replace(" ", "_") + ".json")
    path.write_text(json.dumps(d))
    return path


def cost(args: argparse.Namespace) -> None:
    """Print each configuration's MSE over no aiming's on the small-lamp boxes."""
    caster_guiding.SMALL_LIGHT_SR = 100.0  # every ball a caster: the rules below decide where it is aimed at
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'scene':24s}" + "".join(f"{name:>16s}" for name, _, _ in CONFIGS))
        for name, balls, extra in BOXES:
            path = small_lamp_box(Path(tmp), name, balls, extra)
            ref = render(path, spp=2048, integrator="bdpt", seed=999, sampler="independent")
            keep = ref.mean.reshape(-1, 3).max(axis=1) < 3.0  # not the lamp seen directly
            ref_px = ref.mean.reshape(-1, 3)[keep]
            ref_var = ref.variance.reshape(-1, 3)[keep]
            errors = []
            for _, cone, reach in CONFIGS:
                aim = cone is not None
                if aim:
                    caster_guiding.CASTER_CONE_DEG, device_scene.CASTER_REACH = cone, reach
                device_scene.CASTER_SHARE = caster_guiding.CASTER_SHARE if aim else 0.0
                e = [mse(render(path, spp=args.spp, integrator="mis", seed=s, sampler="independent")
                         .mean.reshape(-1, 3)[keep], ref_px, ref_var) for s in range(1, args.seeds + 1)]
                errors.append(float(np.mean(e)))
            print(f"{name:24s}" + "".join(f"{e / errors[0]:15.2f}x" for e in errors), flush=True)
        print(f"(no aiming's MSE is 1; {args.seeds} seeds of {args.spp} spp each; share {caster_guiding.CASTER_SHARE})")


def one_process(mode: str, sampler: str, spp: int, seeds: int, out: Path) -> str:
    """Aiming ``on`` or ``off`` on caustic.json: a JSON line of its MSEs and median render time."""
    if mode == "off":
        caster_guiding.SMALL_LIGHT_SR = 0.0
    scene = SCENE_FILES["caustic"]
    ref, ref_var, _ = reference(out, scene, 60.0, REFERENCE_INTEGRATOR["caustic"])
    render(scene, spp=spp, integrator="mis", seed=0, sampler=sampler)  # the build, untimed
    errors, times = [], []
    for seed in range(1, seeds + 1):
        t = time.perf_counter()
        r = render(scene, spp=spp, integrator="mis", seed=seed, sampler=sampler)
        times.append(time.perf_counter() - t)
        errors.append(mse(r.mean, ref, ref_var))
    return json.dumps({"mode": mode, "sampler": sampler, "mse": errors, "seconds": float(np.median(times))})


def gain(args: argparse.Namespace) -> None:
    """caustic.json with aiming on and off, in processes taking turns: MSE, time, efficiency."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    reference(out, SCENE_FILES["caustic"], 60.0, REFERENCE_INTEGRATOR["caustic"])  # made once, before the turns
    for sampler in args.samplers:
        for rnd in range(args.rounds):
            row = {}
            for mode in ("off", "on"):
                cmd = [sys.executable, __file__, "one", mode, sampler, str(args.spp), str(args.seeds), str(out)]
                line = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1]
                row[mode] = json.loads(line)
            effs = {}
            for mode, r in row.items():
                m = float(np.mean(r["mse"]))
                se = float(np.std(r["mse"], ddof=1) / np.sqrt(len(r["mse"])))
                effs[mode] = 1.0 / (m * r["seconds"])
                print(f"{sampler:12s} round {rnd + 1} aiming {mode:3s}: MSE {m:.4f} +- {se:.4f}, "
                      f"{r['seconds'] * 1e3:6.1f} ms, efficiency {effs[mode]:7.0f}")
            print(f"{sampler:12s} round {rnd + 1} efficiency on / off: {effs['on'] / effs['off']:.2f}x", flush=True)


def main() -> None:
    """Run the part named on the command line."""
    if len(sys.argv) > 1 and sys.argv[1] == "one":  # a child of gain
        mode, sampler, spp, seeds, out = sys.argv[2:7]
        print(one_process(mode, sampler, int(spp), int(seeds), Path(out)))
        return
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("part", choices=("gain", "cost"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=2, help="gain: turns of the on and off processes")
    ap.add_argument("--samplers", nargs="+", default=["sobol", "independent"], help="gain: render samplers")
    ap.add_argument("--out", default=str(ROOT / "bench-out" / "render"), help="where the reference is cached")
    args = ap.parse_args()
    cost(args) if args.part == "cost" else gain(args)


if __name__ == "__main__":
    main()
