"""``mcocl.render``: progressive path tracing of a scene file on OpenCL.

One call compiles the scene (:mod:`mcocl.render.compiled`), builds the
megakernel for the chosen integrator (``kernels/render/integrator.cl``) and
runs blocks of samples per pixel through :func:`mcocl.schedule.execute`
until the spp count, the time budget or the noise target is reached (or
Ctrl-C): checkpoints, resuming and several devices work as for integration,
and the image depends only on the scene, the settings and the seed.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import runtime
from ..accumulate import Accumulator
from ..errors import InputError
from ..output_files import check_output_file
from ..progress import ProgressBar
from ..schedule import Halting, Placement, Progress, execute
from ..validate import positive_number, whole_number
from .compiled import CompiledScene, compile_scene
from .film import STATS, film_image, relative_error
from .job import UNBOUNDED_SPP, RenderJob, default_spp_per_block, scene_tables, tables_digest
from .scene import Scene, check_integrator_settings

INTEGRATORS = ("path", "nee", "mis")


class NonFiniteSampleWarning(RuntimeWarning):
    """Some path samples were NaN or infinite and were left out of the image."""


@dataclass
class RenderResult:
    """The outcome of :func:`render`.

    Attributes:
        mean: (H, W, 3) float32 radiance (box filter: the plain mean of each pixel's samples).
        variance: (H, W, 3) float32 variance of the mean, per pixel and channel.
        count: (H, W) float32 finite samples per pixel.
        spp: samples per pixel computed (``count`` plus the non-finite ones).
        nonfinite: NaN/Inf samples, counted and left out of the image.
        seconds: wall time of the sampling (build excluded).
        build_seconds: kernel build time of this run (small when cached).
        relative_error: mean over pixels and channels of stderr / mean (the ``noise`` measure).
        integrator, max_depth, rr_depth, seed: the settings that ran.
        width, height, lanes, device, stopped_by, scene: as they were.
        spp_this_run: samples per pixel computed by this call (less than ``spp``
            when it resumed a checkpoint); ``samples_per_second`` counts these.
        notes: anything the user should know.
    """

    mean: np.ndarray
    variance: np.ndarray
    count: np.ndarray
    spp: int
    nonfinite: int
    seconds: float
    build_seconds: float
    relative_error: float
    integrator: str
    max_depth: int
    rr_depth: int
    seed: int
    width: int
    height: int
    lanes: int
    device: str
    stopped_by: str
    scene: str = ""
    spp_per_block: int = 1
    spp_this_run: int = -1
    notes: list[str] = field(default_factory=list)

    @property
    def samples(self) -> int:
        """Path samples computed (spp x pixels)."""
        return int(self.spp) * self.width * self.height

    @property
    def samples_per_second(self) -> float:
        """Paths per second of the sampling done by this call."""
        spp = self.spp if self.spp_this_run < 0 else self.spp_this_run
        return spp * self.width * self.height / self.seconds if self.seconds > 0 else math.nan

    @property
    def stderr(self) -> np.ndarray:
        """(H, W, 3) standard error of the mean."""
        return np.sqrt(self.variance)

    def to_dict(self) -> dict[str, Any]:
        """Every scalar field (no image arrays) plus ``samples`` and ``samples_per_second``, JSON-ready."""
        d = {k: getattr(self, k) for k in (
            "spp", "nonfinite", "seconds", "build_seconds", "relative_error", "integrator", "max_depth", "rr_depth",
            "seed", "width", "height", "lanes", "device", "stopped_by", "scene", "spp_per_block", "spp_this_run",
            "notes")}
        d["samples"] = self.samples
        d["samples_per_second"] = self.samples_per_second
        return d

    def metadata(self) -> dict[str, str]:
        """What the EXR header records about the render."""
        return {k: str(v) for k, v in self.to_dict().items() if k not in ("notes",)}

    def save_exr(self, path: str | os.PathLike[str]) -> None:
        """Write an OpenEXR: R, G, B (mean), the ``variance`` layer and per-pixel ``samples``."""
        from .image_io import write_exr

        write_exr(path, self.mean, self.variance, np.rint(self.count).astype(np.uint32), self.metadata())

    def save_png(self, path: str | os.PathLike[str], exposure: float = 0.0) -> None:
        """Write an sRGB preview (clamped) of the mean."""
        from .image_io import write_png

        write_png(path, np.nan_to_num(self.mean, nan=0.0), exposure)

    def __str__(self) -> str:
        s = (f"{self.width}x{self.height}, {self.spp} spp, {self.integrator}, {self.seconds:.3g} s "
             f"({self.samples_per_second / 1e6:.3g} M samples/s), relative error {self.relative_error:.3g}")
        if self.nonfinite:
            s += f" [{self.nonfinite} non-finite samples left out]"
        return s


def _compile(scene: Any, integrator: Any, max_depth: Any, rr_depth: Any, mesh_folder: Any = None) -> CompiledScene:
    """A compiled scene with the overrides applied (a given CompiledScene is not modified)."""
    if isinstance(scene, CompiledScene):
        s = check_integrator_settings(
            scene.integrator if integrator is None else integrator,
            scene.max_depth if max_depth is None else max_depth,
            scene.rr_depth if rr_depth is None else rr_depth, scene.spp, key="settings")
        import copy

        cs = copy.copy(scene)
        cs.integrator, cs.max_depth, cs.rr_depth = s["integrator"], s["max_depth"], s["rr_depth"]
        return cs
    if isinstance(scene, (str, os.PathLike, Scene)):
        return compile_scene(scene, integrator=integrator, max_depth=max_depth, rr_depth=rr_depth,
                             mesh_folder=mesh_folder)
    raise InputError(f"scene must be a scene file path, a Scene or a CompiledScene, got {type(scene).__name__}")


def render(
    scene: str | os.PathLike[str] | Scene | CompiledScene,
    spp: int | None = None,
    *,
    time: float | None = None,
    noise: float | None = None,
    integrator: str | None = None,
    max_depth: int | None = None,
    rr_depth: int | None = None,
    seed: int = 0,
    device: Any = None,
    devices: Any = None,
    split: int | None = None,
    client: Any = None,
    checkpoint: str | os.PathLike[str] | None = None,
    resume: str | os.PathLike[str] | None = None,
    progress: bool | Callable[[Progress], None] = False,
    lanes: int | None = None,
    spp_per_block: int | None = None,
    mesh_folder: str | os.PathLike[str] | None = None,
) -> RenderResult:
    """Render a scene by path tracing.

    Args:
        scene: a scene file (``scenes/README.md``), a loaded :class:`Scene`
            or a :class:`CompiledScene`.
        spp: samples per pixel.  Default: the scene's ``spp``, unless
            ``time`` or ``noise`` is given (then unbounded).  With ``time``
            or ``noise`` it is an upper bound.
        time: stop after this many seconds of sampling.
        noise: stop once the relative error (mean over pixels of
            stderr / mean) is at most this, e.g. 0.01.
        integrator: ``path``, ``nee`` or ``mis`` (default: the scene's, else ``mis``).
        max_depth, rr_depth: Mitsuba 3's conventions (max_depth -1 unbounded,
            1 emitters seen directly, 2 direct light only); default: the scene's.
        seed: 64-bit seed; the image depends on nothing else.
        device, devices, split, client: where to run (:class:`mcocl.schedule.Placement`).
        checkpoint: save the film here periodically and at the end.
        resume: continue from a checkpoint of the same scene and settings.
        progress: True for a progress bar on stderr, or a callback.
        lanes: paths per vector instruction (default: the device's; 1 = scalar kernel).
        spp_per_block: samples per pixel in one scheduler block (default: about
            2^18 paths per block; taken from the checkpoint when resuming).
        mesh_folder: a folder the scene file may read OBJ files from, besides
            its own folder (a scene cannot reach outside them).

    Returns:
        a :class:`RenderResult`.

    Raises:
        InputError: a bad scene file, setting or checkpoint (the message names it).
        KernelBuildError: the kernel did not compile.
    """
    if integrator is not None and integrator not in INTEGRATORS:
        raise InputError(f"integrator: unknown integrator {integrator!r}; choose one of {', '.join(INTEGRATORS)}")
    cs = _compile(scene, integrator, max_depth, rr_depth, mesh_folder)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) < 2**64:
        raise InputError(f"seed must be an integer in [0, 2**64), got {seed!r}")
    seed = int(seed)
    if time is not None:
        time = positive_number("time", time, "seconds")
    if noise is not None:
        noise = positive_number("noise", noise, "a target relative standard error such as 0.01")
    if spp is not None:
        spp = whole_number("spp", spp, 1, UNBOUNDED_SPP - 1)
    elif time is None and noise is None:
        spp = int(cs.spp)
    if spp is not None and spp >= UNBOUNDED_SPP:
        raise InputError(f"spp must be below {UNBOUNDED_SPP}, got {spp}")
    if lanes is not None and lanes not in (1, 2, 4, 8, 16):
        raise InputError(f"lanes must be 1, 2, 4, 8 or 16, got {lanes!r}")

    if checkpoint is not None:  # before any work: a run must not end in "cannot write"
        check_output_file(checkpoint, "checkpoint")
    tables = scene_tables(cs)
    meta = {
        "kind": "render",
        "scene": tables_digest(tables),
        "width": cs.width,
        "height": cs.height,
        "integrator": cs.integrator,
        "max_depth": cs.max_depth,
        "rr_depth": cs.rr_depth,
        "seed": seed,
    }
    spp_limit = spp if spp is not None else UNBOUNDED_SPP
    acc: Accumulator | None = None
    if resume is not None:
        acc = Accumulator.load(resume, expect_meta=meta)
        saved_block = acc.meta_int("spp_per_block", resume, 1, UNBOUNDED_SPP - 1)
        if spp_per_block is not None and whole_number("spp_per_block", spp_per_block) != saved_block:
            raise InputError(f"checkpoint {resume} uses spp_per_block={saved_block}, not {spp_per_block}")
        spp_per_block = saved_block
        saved_limit = acc.meta_int("spp_limit", resume, 1, UNBOUNDED_SPP)
        acc.check_shape((cs.height, cs.width, STATS), resume)
        if acc.blocks_done * spp_per_block > saved_limit and saved_limit != spp_limit:
            raise InputError(
                f"checkpoint {resume} ends in a partial block ({saved_limit} spp, blocks of {spp_per_block}); "
                f"resume it with spp={saved_limit}, or start renders with a multiple of {spp_per_block} spp")
    elif spp_per_block is None:
        spp_per_block = default_spp_per_block(cs.width, cs.height)
        if spp is not None:
            spp_per_block = max(1, min(spp_per_block, spp))
    else:
        spp_per_block = whole_number("spp_per_block", spp_per_block, 1, UNBOUNDED_SPP - 1)

    job = RenderJob(tables, cs.width, cs.height, cs.integrator, cs.max_depth, cs.rr_depth, seed,
                    spp_per_block, spp_limit, lanes)
    placement = Placement(device=device, devices=devices, split=split, client=client)
    ctx = runtime.device_context(device)
    runner = job.runner(ctx)
    if acc is None:
        acc = Accumulator(job.stat_shape, {**meta, "spp_per_block": spp_per_block})
    acc.meta["spp_limit"] = spp_limit
    spp_before = job.spp_done(acc.blocks_done)

    def target(a: Accumulator) -> bool:
        if noise is None or job.spp_done(a.blocks_done) < 2:
            return False
        img = film_image(a.totals)
        err = relative_error(img.mean, img.variance)
        return math.isfinite(err) and err <= noise

    callback: Callable[[Progress], None] | None = None
    bar: ProgressBar | None = None
    if progress is True:
        bar = ProgressBar(f"render [{cs.integrator}]", unit="spp", per_block=spp_per_block)
        pixels = cs.width * cs.height

        def callback(p: Progress) -> None:
            bar.extra = f", {p.blocks_per_second * spp_per_block * pixels / 1e6:.3g} M samples/s"
            bar.update(p)
    elif callable(progress):
        callback = progress

    max_blocks = -(-spp // spp_per_block) if spp is not None else None
    halting = Halting(max_blocks=max_blocks, time_budget=time, target=target if noise is not None else None,
                      checkpoint=str(checkpoint) if checkpoint is not None else None)
    report = execute(job, acc, halting, placement, progress=callback, runner=runner, ctx=ctx)
    if bar is not None:
        bar.close()

    img = film_image(acc.totals)
    nonfinite = img.nonfinite
    spp_done = job.spp_done(acc.blocks_done)
    notes = list(getattr(report, "notes", []) or [])
    result = RenderResult(
        mean=img.mean,
        variance=img.variance,
        count=img.count,
        spp=spp_done,
        nonfinite=nonfinite,
        seconds=report.seconds,
        build_seconds=runner.build_seconds,
        relative_error=relative_error(img.mean, img.variance),
        integrator=cs.integrator,
        max_depth=cs.max_depth,
        rr_depth=cs.rr_depth,
        seed=seed,
        width=cs.width,
        height=cs.height,
        lanes=runner.lanes,
        device=", ".join(report.devices) if report.devices else ctx.name,
        stopped_by={"blocks": "spp", "target": "noise"}.get(report.stopped_by, report.stopped_by),
        scene=str(cs.source) if cs.source is not None else "",
        spp_per_block=spp_per_block,
        spp_this_run=spp_done - spp_before,
        notes=notes,
    )
    if nonfinite:
        warnings.warn(
            f"{nonfinite} of {spp_done * cs.width * cs.height} path samples were NaN or infinite "
            "and were left out of the image",
            NonFiniteSampleWarning,
            stacklevel=2,
        )
    return result


__all__ = ["INTEGRATORS", "NonFiniteSampleWarning", "RenderResult", "render"]

