"""``mcocl render``: path-trace a scene file into an OpenEXR image."""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from ..engine.contract import DeviceFailureWarning
from ..render.api import INTEGRATORS, NonFiniteSampleWarning, render
from ..render.scene import RENDER_SAMPLERS
from .common import (
    add_device_args,
    add_halting_args,
    add_persistence_args,
    count,
    exposure_stops,
    file_path,
    print_json,
    run_option_kwargs,
)
from .convert_cmd import add_scene_params_args, print_substitution_warnings
from .paths import check_files

DESCRIPTION = """\
Render SCENE (a JSON scene file, see scenes/README.md) by path tracing and
write an OpenEXR image: channels R, G, B (the mean radiance), a `variance`
layer (variance of the mean, per channel) and `samples` (samples per pixel).

Integrators (one megakernel, chosen at build time):
  path  BSDF sampling only; an emitter hit adds its radiance
  nee   light sampling at every vertex, BSDF sampling to continue
  mis   both, combined by the power heuristic (default)

Pixel samples (--sampler): auto (default) draws per-pixel Owen-scrambled
Sobol' nets for path/nee/mis at 8 spp or more (1.8-8.8x as efficient on
the bench scenes lit directly; no gain on caustics seen through glass, where
--sampler independent is 1.3-1.8x faster), independent samples elsewhere;
the summary, --json and the EXR header say which ran.

Stopping: --spp N samples per pixel, --time S seconds, --target-error R
(mean relative standard error over the pixels), whichever comes first; with
none of them, the scene's spp.  (--noise is the deprecated name of
--target-error.)  Ctrl-C stops after the current batch, writes the
image so far and exits with status 130.  The image depends only on the
scene, the settings and --seed: --checkpoint / --resume continue a render
and give the same image as an uninterrupted one.
"""

EXAMPLES = """\
examples:
  mcocl render scenes/cornell.json --spp 256 --out cornell.exr
  mcocl render scenes/cornell.json --time 60 --integrator mis --out cornell.exr --png cornell.png
  mcocl render scenes/veach_mis.json --integrator nee --spp 64 --out nee.exr
  mcocl render scenes/cornell.json --integrator lt --time 30 --out lt.exr
  mcocl render scenes/caustic.json --integrator bdpt --spp 256 --out caustic.exr
  mcocl render scenes/veach_mis.json --integrator bdpt --strategy 2,2 --out s2t2.exr
  mcocl render scenes/veach_mis.json --sampler sobol --batches 4 --spp 256 --out qmc.exr
  mcocl render scenes/cornell.json --target-error 0.01 --checkpoint cornell.ckpt --out cornell.exr
  mcocl render scenes/cornell.json --resume cornell.ckpt --spp 1024 --out cornell.exr
"""


def strategy_pair(text: str) -> tuple[int, int]:
    """``--strategy s,t``: two whole numbers (their range is checked by the render)."""
    try:
        s, t = (int(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected s,t (two whole numbers), got {text!r}") from None
    return s, t


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``render`` parser."""
    p = sub.add_parser("render", help="path-trace a scene into an OpenEXR image", description=DESCRIPTION,
                       epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", help="scene file (JSON, or Mitsuba XML)")
    p.add_argument("--spp", type=count, default=None, help="samples per pixel (default: the scene's, unless --time/--target-error)")
    add_halting_args(p, "stop once the mean relative standard error of the pixels is at most this (e.g. 0.01)",
                     "--noise")
    p.add_argument("--integrator", choices=INTEGRATORS, default=None, help="light transport estimator (default: the scene's)")
    p.add_argument("--mis-heuristic", choices=("power", "balance"), default="power",
                   help="bdpt: how strategies are combined (power: beta 2, the default)")
    p.add_argument("--strategy", type=strategy_pair, default=None, metavar="S,T",
                   help="bdpt: render strategy (s, t) only (s light, t camera vertices), MIS-weighted")
    p.add_argument("--unweighted", action="store_true", help="bdpt --strategy: leave out the MIS weight")
    p.add_argument("--no-roulette", action="store_true",
                   help="bdpt: trace every connection's shadow ray (no Russian roulette on dim connections)")
    p.add_argument("--max-depth", type=int, default=None,
                   help="longest path in segments, Mitsuba's convention (-1 unbounded, 1 emitters only, 2 direct light)")
    p.add_argument("--rr-depth", type=int, default=None, help="depth from which Russian roulette may end paths")
    p.add_argument("--sampler", choices=RENDER_SAMPLERS, default=None,
                   help="auto, independent, or sobol: per-pixel Owen-scrambled Sobol', variance from batch means "
                        "(default: the scene's, else auto: sobol for path/nee/mis when its 4 batches get 2 or more "
                        "samples each (--spp 8 or more, or --time/--target-error alone) or with --batches; "
                        "each batch one whole-film block of at most 2^22 paths; sobol for bdpt when its "
                        "batches hold 2 or more samples (--spp 5 or more, or --time/--target-error alone); "
                        "independent otherwise (lt, spp < 8, films over 2^21 pixels) and when "
                        "resuming a checkpoint made with it)")
    p.add_argument("--batches", type=count, default=None, metavar="B",
                   help="--sampler sobol (path, nee, mis, bdpt; given with auto, it chooses sobol): independent scramblings per pixel that the variance layer comes from, "
                        "each a net of spp/B samples (default 4, at least 2: fewer, larger nets give a smaller "
                        "image error and a noisier per-pixel variance). With --time/--target-error, blocks keep "
                        "their default size and --target-error waits for B of them")
    p.add_argument("--seed", type=int, default=0, help="64-bit seed (default 0)")
    p.add_argument("--out", type=file_path, default=None, help="OpenEXR output (default: SCENE's name with .exr, in the current directory)")
    p.add_argument("--png", type=file_path, default=None, help="also write an sRGB PNG preview")
    p.add_argument("--mesh-folder", default=None, metavar="DIR",
                   help="one more folder the scene may read mesh files (OBJ, PLY, serialized) from, besides its own folder; for a Mitsuba scene also the other files its <path> search finds")
    p.add_argument("--exposure", type=exposure_stops, default=0.0, help="PNG exposure in stops (default 0)")
    add_persistence_args(p, "scene and settings", "print one JSON object describing the render")
    add_device_args(p)
    add_scene_params_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Render, write the image(s), print a summary; 130 if Ctrl-C stopped the render."""
    out = Path(args.out) if args.out else Path(Path(args.scene).stem + ".exr")
    check_files([("--out", out), ("--png", args.png), ("--checkpoint", args.checkpoint)],
                [("the scene", args.scene), ("--mesh-folder", args.mesh_folder)], resume=args.resume,
                kinds={"--out": "exr"})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NonFiniteSampleWarning)
        warnings.simplefilter("always", DeviceFailureWarning)
        r = render(
            args.scene, spp=args.spp, integrator=args.integrator, max_depth=args.max_depth,
            rr_depth=args.rr_depth, params=dict(args.define) or None, lenient=args.lenient,
            mesh_folder=args.mesh_folder, sampler=args.sampler, batches=args.batches, mis=args.mis_heuristic, strategy=args.strategy,
            unweighted=args.unweighted, roulette=not args.no_roulette, **run_option_kwargs(args),
        )
    for w in caught:
        if issubclass(w.category, (NonFiniteSampleWarning, DeviceFailureWarning)):
            print(f"WARNING: {w.message}", file=sys.stderr)
    print_substitution_warnings(caught)
    r.save_exr(out)
    if args.png:
        r.save_png(args.png, exposure=args.exposure)
    if args.json:
        d = r.to_dict()
        d["out"] = str(out)
        d["png"] = args.png
        print_json(d)
    else:
        print(f"image     {out}" + (f" (preview {args.png})" if args.png else ""))
        print(f"render    {r.width}x{r.height}, {r.spp} spp, {r.integrator}, max_depth {r.max_depth}, "
              f"rr_depth {r.rr_depth}, seed {r.seed}, sampler {r.sampler}")
        print(f"time      {r.seconds:.3f} s  ({r.samples_per_second / 1e6:.3g} M samples/s, {r.lanes} lanes; "
              f"build {r.build_seconds:.2f} s)")
        print(f"noise     {r.relative_error:.4g} (mean relative standard error)")
        print(f"device    {r.device}")
        if r.nonfinite:
            print(f"nonfinite {r.nonfinite} samples (left out of the image)")
        if r.stopped_by not in ("spp",):
            print(f"stopped   by {r.stopped_by}")
        for n in r.notes:
            print(f"note      {n}")
    return 130 if r.stopped_by == "interrupt" else 0
