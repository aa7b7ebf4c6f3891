"""The ``render`` bench suite: the integrators on one scene against a reference image.

``mcocl bench render SCENE`` runs ``path``, ``nee`` and ``mis`` (the
lecture's "Příklad z renderingu": BSDF sampling, light sampling and their
combination with the power heuristic) on the scene, each for the budget,
and measures the error of each checkpoint as the RMSE over the image
(pixels and channels) against a reference:

- ``--reference FILE``: an EXR of the same size (its ``variance`` layer, when
  present, is used as below);
- otherwise ``--reference-integrator`` (``mis`` by default; ``bdpt`` on a
  caustic, which ``mis`` leaves noisy for a long time) renders one first for
  ``--reference-time`` seconds (default 8x the budget) with a seed of its
  own, and it is cached in ``OUT/cache`` under a digest of the compiled scene,
  the settings, the integrator and its kernel, so the next bench of the same
  scene reuses it.

``--integrators mis lt bdpt`` (the same as ``--estimators``) compares some
of them at equal time; relative efficiency is then against the first named
(mcocl/bench/runner.py, relative_to).

The reference's own noise would inflate every RMSE: E[(I - R)^2] =
MSE(I) + Var(R) per pixel.  When the reference carries its variance of the
mean, the bench subtracts its average, so the reported RMSE estimates the
image's error against the true image.

Scalar figures per checkpoint: estimate = mean radiance of the image,
stderr = RMS over pixels and channels of the standard error the renderer
reports for each pixel (so rms z compares RMSE with what the renderer
claims), samples = paths (spp x pixels).  There is no NumPy baseline: a
NumPy path tracer of the scene format does not exist, and the table says so.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import sys
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__, runtime
from ..engine.contract import Progress
from ..errors import InputError
from ..render import CompiledScene, NonFiniteSampleWarning, RenderResult, compile_scene, render
from ..render.image_io import read_exr
from ..render.job import (
    INTEGRATOR_CODES,
    KERNEL_FILE,
    SPLAT_INTEGRATORS,
    default_spp_per_block,
    scene_tables,
    tables_digest,
)
from ..render.scene import INTEGRATORS
from ..render.splat_film import TRACE_KERNELS
from .suite import BaselineSpec, BenchOptions, EstimatorSpec, Observation, Tick

DESCRIPTIONS = {
    "path": "BSDF sampling only; emitters count when hit",
    "nee": "light sampling at every vertex (next-event estimation), BSDF sampling to continue",
    "mis": "both, combined by the power heuristic (beta 2)",
    "lt": "light tracing: paths from the emitters, every non-delta vertex connected to the camera",
    "bdpt": "bidirectional path tracing: every connection of a camera and a light subpath, MIS-weighted",
}
REFERENCE_FACTOR = 8.0
REFERENCE_SEED = 0x5EED_0F_2EF


@dataclass
class Reference:
    """The reference image, how it was made, and its file."""

    mean: np.ndarray
    variance: np.ndarray | None
    how: str
    file: str = ""


def image_rmse(mean: np.ndarray, ref: Reference) -> float:
    """RMSE over pixels and channels, less the reference's own variance when known (see the module docstring)."""
    d = np.asarray(mean, dtype=np.float64) - ref.mean
    ok = np.isfinite(d)
    if not np.any(ok):
        return math.nan
    mse = float(np.mean(d[ok] ** 2))
    if ref.variance is not None:
        mse -= float(np.mean(ref.variance[ok]))
    return math.sqrt(max(mse, 0.0))


class RenderRun:
    """One integrator on the scene, advanced by checkpoint and resume in whole spp blocks."""

    def __init__(self, problem: RenderProblem, integrator: str) -> None:
        self.problem = problem
        self.integrator = integrator
        self._dir = tempfile.mkdtemp(prefix="mcocl-bench-")
        self.checkpoint = os.path.join(self._dir, "render.ckpt")
        self.seconds = 0.0
        self.last: RenderResult | None = None
        self.build_seconds = 0.0
        cs = problem.scene
        self.block = default_spp_per_block(cs.width, cs.height)

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Render for about ``seconds`` more (whole blocks of spp)."""
        p = self.problem
        if self.last is None:
            spp = self.block
        else:
            rate = self.last.spp / self.seconds if self.seconds > 0 else 0.0
            spp = self.last.spp + max(int(math.ceil(rate * seconds / self.block)), 1) * self.block
        before = self.seconds

        def progress(pr: Progress) -> None:
            if tick is not None:
                tick(before + pr.elapsed)

        kw: dict[str, Any] = {"resume": self.checkpoint} if self.last is not None else {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NonFiniteSampleWarning)  # counted, reported by the bench
            r = render(p.scene, spp, time_budget=max(4 * seconds, 1.0), integrator=self.integrator, seed=p.seed,
                       device=p.device, lanes=p.lanes, checkpoint=self.checkpoint, progress=progress,
                       spp_per_block=self.block, **kw)
        self.last = r
        self.seconds += r.seconds
        self.build_seconds += r.build_seconds
        var = np.asarray(r.variance, dtype=np.float64)
        stderr = math.sqrt(float(np.mean(var[np.isfinite(var)]))) if np.any(np.isfinite(var)) else math.nan
        return Observation(self.seconds, int(r.samples), float(np.nanmean(r.mean)), stderr,
                           image_rmse(r.mean, p.reference), int(r.nonfinite), r.stopped_by, r.width * r.height)

    def info(self) -> dict[str, Any]:
        """Facts from the last result."""
        r = self.last
        if r is None:
            return {}
        return {"integrator": r.integrator, "spp": r.spp, "lanes": r.lanes, "device": r.device,
                "build_seconds": self.build_seconds, "relative_error": r.relative_error, "notes": list(r.notes)}

    def close(self) -> None:
        """Remove the checkpoint."""
        shutil.rmtree(self._dir, ignore_errors=True)


@dataclass
class RenderProblem:
    """A scene and its reference image."""

    name: str
    description: str
    path: str
    scene: CompiledScene
    reference: Reference
    seed: int = 1
    device: Any = None
    lanes: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def estimators(self) -> list[EstimatorSpec]:
        """path, nee, mis, lt, bdpt."""
        out = []
        for name in INTEGRATORS:
            def start(name: str = name) -> RenderRun:
                return RenderRun(self, name)

            out.append(EstimatorSpec(name, start, DESCRIPTIONS[name]))
        return out

    def baseline(self) -> BaselineSpec:
        """None: there is no NumPy path tracer of the scene format."""
        return BaselineSpec(None, unavailable="not available for render (no NumPy path tracer of the scene format)")

    def summary(self) -> dict[str, Any]:
        """JSON facts about the scene and the reference."""
        cs = self.scene
        return {"name": self.name, "scene": self.path, "width": cs.width, "height": cs.height,
                "max_depth": cs.max_depth, "rr_depth": cs.rr_depth, "reference": self.reference.how,
                "reference_file": self.reference.file,
                "exact": float(np.nanmean(self.reference.mean)), "description": self.description}


def _reference_from_file(path: str, cs: CompiledScene) -> Reference:
    img = read_exr(path)
    want = (cs.height, cs.width, 3)
    if img.mean.shape != want:
        raise InputError(f"--reference {path}: the image is {img.mean.shape[1]}x{img.mean.shape[0]}, "
                         f"the scene renders {cs.width}x{cs.height}")
    var = None if img.variance is None else img.variance.astype(np.float64)
    how = f"{Path(path).name}" + (" (its variance subtracted from the MSE)" if var is not None else " (no variance layer)")
    return Reference(img.mean.astype(np.float64), var, how, str(path))


def _kernel_digest(options: BenchOptions, integrator: str = "mis") -> str:
    """Digest of the reference render's program: the full flattened source and the build options.

    The source is the integrator's kernel with every include resolved, so an
    edit to any file it includes (RNG, MIS weights, BSDFs) makes a cached
    reference stale; the options are those the render kernel is built with on
    the bench's device (integrator, lanes, film precision), or for the
    splatting integrators (lt, bdpt: their own kernel files) the integrator's
    name and the lanes.
    """
    ctx = runtime.device_context(options.device)
    lanes = int(options.lanes) if options.lanes is not None else ctx.lanes
    if integrator in SPLAT_INTEGRATORS:
        source, _ = TRACE_KERNELS[integrator]
        return runtime.build_digest(runtime.compose([source]), [f"-DLANES={lanes}", f"-D{integrator.upper()}"])
    build_options = [f"-DLANES={lanes}", f"-DINTEGRATOR={INTEGRATOR_CODES[integrator]}"]
    build_options += ["-DFILM_DOUBLE"] if ctx.fp64 else []  # as RenderRunner adds it
    return runtime.build_digest(runtime.compose([KERNEL_FILE]), build_options)


def _cached_reference(cs: CompiledScene, seconds: float, cache_dir: str, options: BenchOptions) -> Reference:
    integrator = options.reference_integrator
    if integrator not in INTEGRATORS:
        raise InputError(f"--reference-integrator {integrator!r}: not an integrator (one of {', '.join(INTEGRATORS)})")
    key = hashlib.sha256(repr((tables_digest(scene_tables(cs)), cs.width, cs.height, cs.max_depth, cs.rr_depth,
                               round(seconds, 3), REFERENCE_SEED, __version__, integrator,
                               _kernel_digest(options, integrator))).encode()).hexdigest()[:16]
    path = Path(cache_dir) / f"render-reference-{key}.exr"
    if path.is_file():
        img = read_exr(path)
        try:
            secs = f"{float(img.metadata.get('seconds', 'nan')):.4g}"
        except ValueError:
            secs = "?"
        return Reference(img.mean.astype(np.float64), None if img.variance is None else img.variance.astype(np.float64),
                         f"{integrator}, {secs} s, {img.metadata.get('spp', '?')} spp (cached)", str(path))
    print(f"bench render: rendering the reference ({integrator}, {seconds:g} s) into {path}", file=sys.stderr)
    r = render(cs, None, time_budget=seconds, integrator=integrator, seed=REFERENCE_SEED, device=options.device,
               lanes=options.lanes, progress=True)
    if r.stopped_by == "interrupt":
        raise KeyboardInterrupt  # a cut-short reference must not be cached as a finished one
    path.parent.mkdir(parents=True, exist_ok=True)
    r.save_exr(path)
    return Reference(r.mean.astype(np.float64), r.variance.astype(np.float64),
                     f"{integrator}, {r.seconds:.4g} s, {r.spp} spp (rendered now)", str(path))


class RenderSuite:
    """The ``render`` suite (see the module docstring)."""

    name = "render"
    error_kind = "rmse"
    reference_estimator = "path"

    def problems(self, options: BenchOptions) -> list[RenderProblem]:
        """The one scene given on the command line, with its reference."""
        if len(options.inputs) != 1:
            raise InputError("bench render needs one scene file: mcocl bench render SCENE")
        if options.problem_files:
            raise InputError("--problem files are for the integrate suite")
        path = options.inputs[0]
        cs = compile_scene(path)
        if options.reference:
            ref = _reference_from_file(options.reference, cs)
        else:
            seconds = options.reference_seconds or REFERENCE_FACTOR * (options.budget or 1.0)
            ref = _cached_reference(cs, seconds, options.cache_dir or tempfile.gettempdir(), options)
        prob = RenderProblem(Path(path).stem, f"{cs.width}x{cs.height}, max_depth {cs.max_depth}, "
                             f"rr_depth {cs.rr_depth}; error = RMSE over the image", path, cs, ref)
        prob.seed, prob.device, prob.lanes = options.seed, options.device, options.lanes
        return [prob]


SUITE = RenderSuite()
