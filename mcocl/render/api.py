"""``mcocl.render``: progressive path tracing and light tracing of a scene file on OpenCL.

One call compiles the scene (:mod:`mcocl.render.compiled`), builds the
megakernel for the chosen integrator (``kernels/render/integrator.cl``;
``kernels/render/lt.cl`` on the splatting film of
:mod:`mcocl.render.splat_film` for ``lt``) and
runs blocks of samples per pixel through :func:`mcocl.engine.dispatch.execute`
until the spp count, the time budget or the target error is reached (or
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
from ..engine.contract import Progress
from ..engine.dispatch import execute
from ..errors import InputError, NonFiniteSampleWarning
from ..host_memory import release_free_heap, releases_free_heap
from ..run_options import RunOptions, renamed_keyword
from ..validate import whole_number
from .bdpt_settings import bdpt_settings
from .compiled import CompiledScene, compile_scene
from .emitter_choice import bounding_sphere
from .film import STATS, film_image, relative_error
from .job import (
    SOBOL_INTEGRATORS,
    SPLAT_INTEGRATORS,
    TILE_PIXELS,
    UNBOUNDED_SPP,
    RenderJob,
    default_spp_per_block,
    scene_tables,
    tables_digest,
)
from .pixel_filter import BOX
from .sampler_choice import resolve_auto_sampler
from .scene import DEFAULT_RENDER_SAMPLER, INTEGRATORS, RENDER_SAMPLERS, Scene, check_integrator_settings
from .scene_file import load_scene
from .sobol_film import DEFAULT_BATCHES, MIN_BATCHES, batch_relative_error, sobol_block_pixels, sobol_spp_per_block
from .splat_film import BDPT_SOBOL_BLOCK, splat_spp_per_block


@dataclass
class RenderResult:
    """The outcome of :func:`render`.

    Attributes:
        mean: (H, W, 3) float32 radiance (box filter: the plain mean of each pixel's samples).
        variance: (H, W, 3) float32 variance of the mean, per pixel and channel.
        count: (H, W) float32 finite samples per pixel; for ``lt``, ``bdpt`` and the ``sobol``
            sampler, the number of batches (blocks) the variance was estimated from
            (:mod:`mcocl.render.splat_film`, :mod:`mcocl.render.sobol_film`).
        spp: samples per pixel computed (``count`` plus the non-finite ones); with ``sobol`` stopped
            inside a batch, whose blocks are pixel ranges, their mean over the pixels, rounded down.
        nonfinite: NaN/Inf samples, counted and left out of the image.
        seconds: wall time of the sampling (build excluded).
        build_seconds: kernel build time of this run (small when cached).
        relative_error: mean over pixels and channels of stderr / mean (what ``target_error`` bounds;
            with ``sobol`` each stderr is divided by c4 of the pixel's batches, the mean bias of a
            square root of few batches: :func:`mcocl.render.sobol_film.batch_relative_error`).
        integrator, max_depth, rr_depth, seed: the settings that ran.
        width, height, lanes, device, stopped_by, scene: as they were.
        spp_this_run: samples per pixel computed by this call (less than ``spp``
            when it resumed a checkpoint); ``samples_per_second`` counts these.
        notes: anything the user should know.
        sampler: the render sampler that ran, ``independent`` or ``sobol`` (what ``auto`` resolved to:
            :mod:`mcocl.render.sampler_choice`).
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
    sampler: str = "independent"

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
            "sampler", "notes")}
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
        """Write an sRGB preview (clamped) of the mean, scaled by 2^exposure."""
        from .image_io import check_exposure, write_png

        write_png(path, np.nan_to_num(self.mean, nan=0.0), check_exposure(exposure))

    def __str__(self) -> str:
        s = (f"{self.width}x{self.height}, {self.spp} spp, {self.integrator}, {self.seconds:.3g} s "
             f"({self.samples_per_second / 1e6:.3g} M samples/s), relative error {self.relative_error:.3g}")
        if self.nonfinite:
            s += f" [{self.nonfinite} non-finite samples left out]"
        return s


def _requested_sampler(cs: CompiledScene, sampler: Any) -> tuple[str, bool]:
    """(the sampler asked for, whether the scene asked): ``sampler`` if given, else the scene's."""
    name = getattr(cs, "sampler", DEFAULT_RENDER_SAMPLER) if sampler is None else sampler
    if name not in RENDER_SAMPLERS:
        raise InputError(f"sampler: unknown render sampler {name!r}; choose one of {', '.join(RENDER_SAMPLERS)}")
    return name, sampler is None


def _render_sampler(cs: CompiledScene, name: str, from_scene: bool, spp: int | None, spp_per_block: Any,
                    batches: Any, bounded_by_spp: bool) -> tuple[str, str, int | None]:
    """The render sampler, a note, and the samples of a batch when ``auto`` sized it (else None).

    ``sobol`` for the path integrators and ``bdpt`` (SOBOL_INTEGRATORS), not ``lt``.

    The scene's ``sobol`` is a preference (a Mitsuba scene's stratified sampler asks for it): ``lt``,
    e.g. chosen by ``--integrator``, draws independent samples instead, and the note says
    so; a ``sobol`` asked for here with it is an error.  ``auto`` is decided by
    :func:`mcocl.render.sampler_choice.resolve_auto_sampler` (a resumed checkpoint's own sampler wins:
    :func:`_checkpoint_sampler`); ``batches`` asks for sobol.
    """
    if name == "auto":
        if batches is not None and cs.integrator not in SOBOL_INTEGRATORS:
            raise InputError(f"batches: only the sobol sampler estimates its variance from batches, and it works "
                             f"with {', '.join(SOBOL_INTEGRATORS)}, not {cs.integrator!r}")
        block = None if spp_per_block is None else whole_number("spp_per_block", spp_per_block, 1, UNBOUNDED_SPP - 1)
        name, why, batch = resolve_auto_sampler(cs.integrator, spp, block,
                                                batches if batches is not None else getattr(cs, "batches", None),
                                                cs.width * cs.height, bounded_by_spp)
        return name, f"sampler auto: {name} ({why})", batch
    if name == "sobol" and cs.integrator not in SOBOL_INTEGRATORS:
        if from_scene:
            return "independent", (f"the scene's sampler 'sobol' works with {', '.join(SOBOL_INTEGRATORS)} only: "
                                   f"{cs.integrator} draws independent samples"), None
        raise InputError(f"sampler 'sobol' works with {', '.join(SOBOL_INTEGRATORS)}, not {cs.integrator!r}")
    return name, "", None


def _default_block_spp(cs: CompiledScene, spp: int | None, sampler: str, batches: int, bounded_by_spp: bool) -> int:
    """The samples per pixel of a block when the caller gives none (a resumed run checks ``batches`` by it)."""
    default = default_spp_per_block(cs.width, cs.height)
    if cs.integrator in SPLAT_INTEGRATORS:
        # the variance of a splatted image comes from its batches (blocks): have a few; bdpt's sobol
        # batches are blocks too (kernels/render/bdpt.cl, "Quasi-Monte Carlo")
        return splat_spp_per_block(default, spp, cs.integrator, cs.width, cs.height, sampler, batches)
    if sampler == "sobol":
        # batches are the replicates of the variance: a few, each as large a net as they can be
        return sobol_spp_per_block(default, spp, batches, bounded_by_spp)
    return default if spp is None else max(1, min(default, spp))


def _checkpoint_sampler(acc: Accumulator, path: Any) -> str:
    """The sampler a checkpoint was written with (its ``sampler`` key; none: ``independent``)."""
    saved = acc.meta.get("sampler")
    if saved is None:
        return "independent"
    if saved not in RENDER_SAMPLERS or saved == "auto":
        raise InputError(f"checkpoint {path}: its field 'sampler' is {saved!r}, not a render sampler")
    return saved


def _saved_block_pixels(acc: Accumulator, path: Any, npix: int) -> int:
    """A sobol checkpoint's pixels per block: 0 (the whole film) without the key, else whole tiles."""
    if "block_pixels" not in acc.meta:
        return 0
    pixels = acc.meta_int("block_pixels", path, TILE_PIXELS, max(npix - 1, TILE_PIXELS))
    if pixels % TILE_PIXELS:
        raise InputError(f"checkpoint {path}: its field 'block_pixels' is {pixels}, not a multiple of {TILE_PIXELS}")
    return pixels


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


@releases_free_heap
def render(
    scene: str | os.PathLike[str] | Scene | CompiledScene,
    spp: int | None = None,
    *,
    time_budget: float | None = None,
    target_error: float | None = None,
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
    time: float | None = None,
    noise: float | None = None,
    params: dict[str, Any] | None = None,
    lenient: bool = False,
    mesh_folder: str | os.PathLike[str] | None = None,
    sampler: str | None = None,
    batches: int | None = None,
    mis: str = "power",
    strategy: tuple[int, int] | None = None,
    unweighted: bool = False,
    roulette: bool = True,
) -> RenderResult:
    """Render a scene by path tracing.

    Args:
        scene: a scene file (``scenes/README.md``), a loaded :class:`Scene`
            or a :class:`CompiledScene`.
        spp: samples per pixel.  Default: the scene's ``spp``, unless
            ``time_budget`` or ``target_error`` is given (then unbounded).
            With either of them it is an upper bound.
        time_budget: stop after this many seconds of sampling.
        target_error: stop once the relative error (mean over pixels of
            stderr / mean) is at most this, e.g. 0.01.
        integrator: ``path``, ``nee``, ``mis`` or ``lt`` (light tracing with
            next-event estimation to the camera; ``spp`` then counts light paths
            per pixel of the image, and mirrors or glass seen directly stay
            black) or ``bdpt`` (bidirectional path tracing, every strategy
            combined by MIS; area emitters only) (default: the scene's, else ``mis``).
        max_depth, rr_depth: Mitsuba 3's conventions (max_depth -1 unbounded,
            1 emitters seen directly, 2 direct light only); default: the scene's.
        seed: 64-bit seed; the image depends on nothing else.
        device, devices, split, client: where to run (:class:`mcocl.engine.contract.Placement`).
        checkpoint: save the film here periodically and at the end.
        resume: continue from a checkpoint of the same scene and settings.
        progress: True for a progress bar on stderr, or a callback.
        lanes: paths per vector instruction (default: the device's; 1 = scalar kernel).
        spp_per_block: samples per pixel in one scheduler block (default: about
            2^20 paths per block, a sobol batch that ``auto`` sizes up to 2^22 in one
            whole-film block, bdpt up to 16 spp, bdpt with sobol spp/4 up to the default block:
            splat_film.splat_spp_per_block; taken from the
            checkpoint when resuming).
        params, lenient: for a Mitsuba XML scene file, ``$name`` values and
            whether to substitute what is unsupported (:func:`load_scene`).
        mesh_folder: a folder the scene file may read OBJ files from, besides
            its own folder (a scene cannot reach outside them).
        time, noise: deprecated names of ``time_budget`` and ``target_error``.
        sampler: ``auto``, ``independent`` or ``sobol`` (per-pixel Owen-scrambled Sobol',
            the variance from the spread of block means: :mod:`mcocl.render.sobol_film`);
            default: the scene's ``integrator.sampler``, else ``auto``: ``sobol`` for ``path``,
            ``nee`` and ``mis`` when its default 4 batches hold 2 or more samples each (spp >= 8, or
            no spp under ``time_budget``/``target_error``), with ``batches``, or with an
            ``spp_per_block`` that makes 2 batches of 2 or more samples, each batch it sizes one
            whole-film block of at most 2^22 paths; ``sobol`` for ``bdpt`` when its batches (blocks)
            hold 2 or more samples (kernels/render/bdpt.cl, "Quasi-Monte Carlo"); ``independent``
            otherwise (``lt``, spp < 8, a film where 2 samples per pixel do not fit such a block) and when resuming a
            checkpoint made with it (:mod:`mcocl.render.sampler_choice`).  ``RenderResult.sampler``
            says which ran.
        batches: ``sobol`` only (path, nee, mis, bdpt; with ``auto``, giving it chooses ``sobol``): independent scramblings (batches) per pixel that the variance
            comes from, each a net of ceil(spp / batches) samples (default 4: 3 degrees of freedom
            per pixel; more batches give a steadier per-pixel variance and a larger image error,
            fewer the reverse).  At least 2; one scrambling of all ``spp`` samples has no variance
            (``spp_per_block=spp`` renders it, its ``variance`` NaN).  Under ``time_budget`` or
            ``target_error`` blocks keep their default size, their number grows with the run, and
            ``target_error`` waits for ``batches`` of them.  Not with ``spp_per_block``.
            A batch of more paths than an independent block is rendered as several blocks of
            pixel ranges (same image; a stop inside a batch leaves some pixels a batch short).
            Default: the scene's ``integrator.batches``, else 4.
        mis: ``bdpt``'s MIS heuristic, ``power`` (beta 2, the default) or ``balance``.
        strategy: ``bdpt`` renders only strategy (s, t) (s light, t >= 1 camera vertices),
            MIS-weighted unless ``unweighted``.
        roulette: ``bdpt``'s unbiased Russian roulette on the shadow rays of dim connections (on by
            default; off renders the exact sum of every strategy, as a single ``strategy`` always is).

    The shared options (seed, time_budget, target_error, placement, lanes,
    checkpoint, resume, progress) are checked by :class:`mcocl.run_options.RunOptions`.

    Returns:
        a :class:`RenderResult`.

    Raises:
        InputError: a bad scene file, setting or checkpoint (the message names it).
        KernelBuildError: the kernel did not compile.
    """
    if integrator is not None and integrator not in INTEGRATORS:
        raise InputError(f"integrator: unknown integrator {integrator!r}; choose one of {', '.join(INTEGRATORS)}")
    time_budget = renamed_keyword("render", "time_budget", time_budget, "time", time)
    target_error = renamed_keyword("render", "target_error", target_error, "noise", noise)
    if isinstance(scene, (str, os.PathLike)):
        scene = load_scene(scene, params=params, lenient=lenient, mesh_folder=mesh_folder)
    own = not isinstance(scene, CompiledScene)  # compiled here: nobody else holds cs
    cs = _compile(scene, integrator, max_depth, rr_depth)
    scene = None  # a scene file's meshes, read here, are in cs now (27 MB for 10^6 triangles)
    sampler, from_scene = _requested_sampler(cs, sampler)
    opts = RunOptions(seed=seed, time_budget=time_budget, target_error=target_error, device=device, devices=devices,
                      split=split, client=client, lanes=lanes, checkpoint=checkpoint, resume=resume, progress=progress)
    seed = opts.seed
    if spp is not None:
        spp = whole_number("spp", spp, 1, UNBOUNDED_SPP - 1)
    elif opts.time_budget is None and opts.target_error is None:
        spp = int(cs.spp)
    if spp is not None and spp >= UNBOUNDED_SPP:
        raise InputError(f"spp must be below {UNBOUNDED_SPP}, got {spp}")
    # read before the sampler is chosen: a resume of auto continues with the checkpoint's sampler, so that it
    # gives the uninterrupted run's bits (and a checkpoint made before auto existed continues independent)
    acc: Accumulator | None = Accumulator.load(opts.resume) if opts.resume is not None else None
    auto_batch = None  # samples per pixel of a batch that auto sized: one whole-film block (sampler_choice.py)
    if sampler == "auto" and acc is not None and batches is None:
        sampler = _checkpoint_sampler(acc, opts.resume)
        sampler_note = f"sampler auto: {sampler} (the checkpoint's)"
    else:
        sampler, sampler_note, auto_batch = _render_sampler(cs, sampler, from_scene, spp, spp_per_block, batches,
                                                            opts.time_budget is None and opts.target_error is None)
    if batches is not None:
        if sampler != "sobol":
            raise InputError(f"batches: only the sobol sampler estimates its variance from batches, not {sampler!r}")
        if spp_per_block is not None:
            raise InputError("batches and spp_per_block both set the samples of a batch: give one of them")
        batches = whole_number("batches", batches, MIN_BATCHES, UNBOUNDED_SPP - 1)
    # sobol's batches: the keyword's, the scene's integrator.batches (checked when it was read), or the default
    min_batches = batches or (getattr(cs, "batches", None) if sampler == "sobol" else None) or DEFAULT_BATCHES

    bdpt = bdpt_settings(cs, mis, strategy, unweighted, roulette)
    pixel_filter = getattr(cs, "pixel_filter", BOX)
    near_clip = float(getattr(cs, "near_clip", 0.0))
    far_clip = getattr(cs, "far_clip", None)
    # what compiling and building the tables freed stays resident otherwise (mcocl/host_memory.py)
    release_free_heap()
    tables = scene_tables(cs)
    if own:  # what the tables were made from is not needed again (CompiledScene.without_primitives)
        cs = cs.without_primitives()
    release_free_heap()
    meta = {
        "kind": "render",
        "scene": tables_digest(tables),
        "width": cs.width,
        "height": cs.height,
        "integrator": cs.integrator,
        "max_depth": cs.max_depth,
        "rr_depth": cs.rr_depth,
        "seed": seed,
        # None for independent: the checkpoints written before the option had no key, and read as None
        "sampler": sampler if sampler != "independent" else None,
        **({"bdpt": repr(bdpt)} if cs.integrator == "bdpt" else {}),
        # no key for the box: the checkpoints written before filters existed have none
        **({"filter": repr(pixel_filter)} if pixel_filter != BOX else {}),
        **({"near_clip": near_clip} if near_clip > 0.0 else {}),
        **({"far_clip": far_clip} if far_clip is not None else {}),
    }
    spp_limit = spp if spp is not None else UNBOUNDED_SPP
    resume = opts.resume
    if acc is not None:
        acc.check_meta(meta, resume)
        saved_block = acc.meta_int("spp_per_block", resume, 1, UNBOUNDED_SPP - 1)
        if spp_per_block is not None and whole_number("spp_per_block", spp_per_block) != saved_block:
            raise InputError(f"checkpoint {resume} uses spp_per_block={saved_block}, not {spp_per_block}")
        if batches is not None and sampler == "sobol":
            want = _default_block_spp(cs, spp, sampler, batches,
                                      opts.time_budget is None and opts.target_error is None)
            if want != saved_block:
                raise InputError(f"checkpoint {resume} has batches of {saved_block} spp, not the {want} of "
                                 f"batches={batches}; resume it without batches")
        spp_per_block = saved_block
        saved_limit = acc.meta_int("spp_limit", resume, 1, UNBOUNDED_SPP)
        acc.check_shape((cs.height, cs.width, STATS), resume)
        # sobol's blocks as the checkpoint cut them (no key: whole-film blocks, as before the cut existed)
        block_pixels = (_saved_block_pixels(acc, resume, cs.width * cs.height)
                        if sampler == "sobol" and cs.integrator not in SPLAT_INTEGRATORS else 0)
    elif auto_batch is not None:
        spp_per_block = auto_batch
    elif spp_per_block is None:
        spp_per_block = _default_block_spp(cs, spp, sampler, min_batches,
                                           opts.time_budget is None and opts.target_error is None)
    else:
        spp_per_block = whole_number("spp_per_block", spp_per_block, 1, UNBOUNDED_SPP - 1)
    if acc is None:
        # a sobol batch of more paths than an independent block is cut into blocks of pixel ranges (not one
        # that auto sized: a whole-film block, so that a render stopped in its first batch has every pixel)
        block_pixels = (sobol_block_pixels(spp_per_block, default_spp_per_block(cs.width, cs.height) * cs.width
                                           * cs.height, cs.width, cs.height, TILE_PIXELS)
                        if sampler == "sobol" and auto_batch is None and cs.integrator not in SPLAT_INTEGRATORS
                        else 0)
    if sampler == "sobol" and cs.integrator == "bdpt" and spp_per_block * cs.width * cs.height > BDPT_SOBOL_BLOCK:
        # the light subpaths of a block are one scrambling's points (kernels/render/bdpt.cl, "Quasi-Monte Carlo")
        raise InputError(f"spp_per_block: bdpt's sobol blocks hold at most {BDPT_SOBOL_BLOCK} samples, not "
                         f"{spp_per_block} x {cs.width} x {cs.height}; take fewer samples per block or "
                         "sampler='independent'")

    centre, radius = bounding_sphere(cs.bounds)
    job = RenderJob(tables, cs.width, cs.height, cs.integrator, cs.max_depth, cs.rr_depth, seed,
                    spp_per_block, spp_limit, opts.lanes, bounding_sphere=(*centre, radius), sampler=sampler,
                    pixel_filter=pixel_filter, near_clip=near_clip, far_clip=far_clip, block_pixels=block_pixels,
                    **bdpt)
    ranges = job.film_ranges
    held_note = ""
    if acc is not None and spp_limit < saved_limit:
        job.spp_limit = saved_limit
        held = job.spp_done(acc.blocks_done)
        if held > spp_limit:
            # The checkpoint already holds more than spp asks for: its samples stay in the image (nothing
            # computed is thrown away), so the counts are its own, not spp's.
            held_note = f"the checkpoint already holds {held} spp, more than the {spp} asked for: nothing was added"
        else:
            job.spp_limit = spp_limit
    if acc is not None and -(-acc.blocks_done // ranges) * spp_per_block > saved_limit and saved_limit != job.spp_limit:
        raise InputError(
            f"checkpoint {resume} ends in a partial block ({saved_limit} spp, blocks of {spp_per_block}); "
            f"resume it with spp={saved_limit}, or start renders with a multiple of {spp_per_block} spp")
    ctx = runtime.device_context(opts.device)
    runner = job.runner(ctx)
    # what the kernel build freed (its compiler's working memory, about 12 MB) would stay resident under the
    # render's film buffers (bench/scene_memory.py's image stage; mcocl/host_memory.py)
    release_free_heap()
    if acc is None:
        # the key only for cut films: a whole-film checkpoint stays what it was before the cut existed
        acc = Accumulator(job.stat_shape, {**meta, "spp_per_block": spp_per_block,
                                           **({"block_pixels": block_pixels} if block_pixels else {})})
    acc.meta["spp_limit"] = job.spp_limit
    spp_before = job.spp_done(acc.blocks_done)

    def error_of(mean: np.ndarray, variance: np.ndarray, count: np.ndarray) -> float:
        # sobol's few batches: the mean stderr with its chi bias divided out (mcocl/render/sobol_film.py)
        if sampler == "sobol":
            return batch_relative_error(mean, variance, count)
        return relative_error(mean, variance)

    def target(a: Accumulator) -> bool:
        if opts.target_error is None or job.spp_done(a.blocks_done) < 2:
            return False
        if sampler == "sobol" and a.blocks_done < min_batches * ranges:  # fewer replicates than asked for
            return False
        img = film_image(a.totals)
        err = error_of(img.mean, img.variance, img.count)
        return math.isfinite(err) and err <= opts.target_error

    callback, bar = opts.progress_reporter(f"render [{cs.integrator}]", "spp", job.spp_per_pixel_block)
    if bar is not None:
        pixels = cs.width * cs.height

        def callback(p: Progress) -> None:
            bar.extra = f", {p.blocks_per_second * job.spp_per_pixel_block * pixels / 1e6:.3g} M samples/s"
            bar.update(p)

    max_blocks = -(-spp // spp_per_block) * ranges if spp is not None else None
    if held_note:  # nothing to add
        max_blocks = acc.blocks_done
    halting = opts.halting(max_blocks, target if opts.target_error is not None else None)
    report = execute(job, acc, halting, opts.placement, progress=callback, runner=runner, ctx=ctx)
    if bar is not None:
        bar.close()

    img = film_image(acc.totals)
    nonfinite = img.nonfinite
    spp_done = job.spp_done(acc.blocks_done)
    notes = list(getattr(report, "notes", []) or []) + [n for n in (held_note, sampler_note) if n]
    if sampler == "sobol":
        whole, part = divmod(acc.blocks_done, ranges)
        notes.append(f"sobol: variance from {whole} independent Owen scramblings (batches) of "
                     f"{spp_per_block} samples per pixel" + ("; a pixel of fewer than 2 batches has no variance" if whole < 2 else "")
                     + (f"; the next batch covers {part} of its {ranges} pixel ranges (blocks)" if part else ""))
    if job.integrator == "lt":
        notes.append(f"light tracing: variance from {acc.blocks_done} independent batches of "
                     f"{spp_per_block} light paths per pixel; specular surfaces seen directly are black")
    elif job.splats and sampler != "sobol":  # bdpt's sobol batches have the note above
        notes.append(f"bdpt: variance from {acc.blocks_done} independent batches of {spp_per_block} samples per pixel")
    result = RenderResult(
        mean=img.mean,
        variance=img.variance,
        count=img.count,
        spp=spp_done,
        nonfinite=nonfinite,
        seconds=report.seconds,
        build_seconds=runner.build_seconds,
        relative_error=error_of(img.mean, img.variance, img.count),
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
        sampler=sampler,
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

