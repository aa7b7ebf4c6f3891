"""OpenCL devices, contexts, queues and program builds.

The runtime is the only module that talks to pyopencl's platform layer:
- :func:`list_devices` enumerates the devices of every platform;
- :func:`select_device` picks one by index, name substring or ``PYOPENCL_CTX``;
- :func:`device_context` gives the (cached) context and in-order queue of a device;
- :func:`build` compiles an engine kernel with user snippets pasted in, with a
  build cache keyed by (source, options, device), and turns compiler errors into
  :class:`~mcocl.errors.KernelBuildError` quoting the user's own lines.

Kernel sources live in the top-level ``kernels/`` (the package data
``mcocl/kernels`` of a wheel, see :data:`KERNEL_DIR`).  Includes
are resolved here, not by the OpenCL compiler, so that the flattened text is a
complete cache key and so that ``#line`` markers make compiler messages point
at ``rng/philox.cl:40`` instead of a temporary file.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
import threading
import time
import warnings
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pyopencl as cl

from . import heartbeat
from .build_output import build_log_requested, compiler_stderr_captured, show_build_log
from .errors import DeviceError, InputError, KernelBuildError
from .host_simd import host_simd_width
from .pocl_cache import cache_folder, cache_problem, no_device_hint
from .pocl_cache_record import check_entry, entry_used, record_key
from .usercode import UserFunction, explain_build_log, probe_source


def _kernel_dir() -> Path:
    """Where the ``.cl`` files are.

    A source checkout (run from it, or installed editable) has them in the
    top-level ``kernels/`` beside ``mcocl/``; a wheel installs them as the
    package data ``mcocl/kernels``, found through the import system.  The
    checkout's folder comes first so that a second checkout on PYTHONPATH
    uses its own kernels, not those of the checkout installed editable.
    """
    beside = Path(__file__).resolve().parent.parent / "kernels"
    if (beside / "lanes.cl").is_file() and (beside / "__init__.py").is_file():
        return beside
    try:
        spec = importlib.util.find_spec("mcocl.kernels")
    except ImportError:
        spec = None
    for loc in (spec.submodule_search_locations or []) if spec is not None else []:
        if Path(loc, "lanes.cl").is_file():
            return Path(loc).resolve()
    return beside


KERNEL_DIR = _kernel_dir()
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')

# Options every engine build gets.  No fast-math: -cl-finite-math-only would
# let the compiler delete the NaN/Inf checks that keep bad samples out of sums.
BASE_OPTIONS: tuple[str, ...] = ("-cl-std=CL1.2",)


@dataclass(frozen=True)
class DeviceInfo:
    """One OpenCL device as :func:`list_devices` reports it."""

    index: int
    platform_index: int
    device_index: int
    name: str
    platform: str
    platform_version: str
    type: str
    compute_units: int
    global_mem_mb: int
    fp64: bool
    lanes: int
    problem: str | None = None

    def describe(self) -> str:
        """A one-line human description."""
        text = (
            f"[{self.index}] {self.name} ({self.type}, {self.compute_units} compute units, "
            f"{self.global_mem_mb} MiB, fp64 {'yes' if self.fp64 else 'no'}, {self.lanes} lanes) "
            f"— {self.platform_version}"
        )
        return text + (f"\n    unusable, builds fail: {self.problem}" if self.problem else "")


def _type_name(t: int) -> str:
    names = []
    for flag, name in ((cl.device_type.CPU, "CPU"), (cl.device_type.GPU, "GPU"), (cl.device_type.ACCELERATOR, "accelerator")):
        if t & flag:
            names.append(name)
    return "/".join(names) or "other"


def _all_devices() -> list[tuple[int, int, cl.Device]]:
    try:
        platforms = cl.get_platforms()
    except cl.Error as e:  # no ICD loader configuration, no platform
        raise DeviceError(
            f"no OpenCL platform found ({e}); install one, e.g. pip install 'mcocl[pocl]' for the PoCL CPU device"
        ) from None
    out = []
    for pi, p in enumerate(platforms):
        try:
            devs = p.get_devices()
        except cl.Error:
            continue
        for di, d in enumerate(devs):
            out.append((pi, di, d))
    return out


def has_fp64(device: cl.Device) -> bool:
    """True when the device supports double precision (cl_khr_fp64)."""
    return "cl_khr_fp64" in device.extensions.split() or bool(getattr(device, "double_fp_config", 0))


def default_lanes(device: cl.Device) -> int:
    """How many samples a work-item carries in vector lanes on this device.

    CPUs get their preferred float vector width (8 with AVX2, 16 with AVX-512:
    measured fastest on PoCL, see bench/), or the host's SIMD width where the
    device reports less than 4 (a driver may report 1 for a CPU with wide vectors);
    GPUs vectorise across work-items by themselves and get 1.  ``MCOCL_LANES``
    overrides.
    """
    env = os.environ.get("MCOCL_LANES")
    if env:
        try:
            lanes = int(env)
        except ValueError:
            lanes = 0
        if lanes < 1:
            raise InputError(f"the environment variable MCOCL_LANES must be a whole number such as 1, 2, 4, 8 "
                             f"or 16, got {env!r}")
    elif device.type & cl.device_type.CPU:
        reported = max(int(device.preferred_vector_width_float), int(device.native_vector_width_float))
        lanes = reported if reported >= 4 else max(reported, host_simd_width())
    else:
        lanes = 1
    for allowed in (16, 8, 4, 2, 1):
        if lanes >= allowed:
            return allowed
    return 1


def list_devices() -> list[DeviceInfo]:
    """Every device of every OpenCL platform, with a global index."""
    infos = []
    for k, (pi, di, d) in enumerate(_all_devices()):
        p = d.platform
        infos.append(
            DeviceInfo(
                index=k,
                platform_index=pi,
                device_index=di,
                name=d.name.strip(),
                platform=p.name.strip(),
                platform_version=p.version.strip(),
                type=_type_name(d.type),
                compute_units=int(d.max_compute_units),
                global_mem_mb=int(d.global_mem_size // (1 << 20)),
                fp64=has_fp64(d),
                lanes=default_lanes(d),
                problem=device_problem(d),
            )
        )
    return infos


def _match(items: list, spec: str, key) -> list:
    if spec.isdigit():
        k = int(spec)
        return [items[k]] if k < len(items) else []
    s = spec.lower()
    return [it for it in items if s in key(it).lower()]


def select_device(spec: int | str | cl.Device | None = None) -> cl.Device:
    """Choose one device.

    Args:
        spec: ``None`` — ``PYOPENCL_CTX`` if set (``"P"`` or ``"P:D"``, each an
            index or a name substring, as pyopencl reads it), else the first
            device found; an ``int`` or digit string — the global index shown
            by ``mcocl devices``; any other string — a case-insensitive
            substring of the device name, platform name or platform version;
            a ``pyopencl.Device`` is returned as is.  The default skips
            devices that cannot build a trivial kernel (:func:`device_problem`).

    Raises:
        DeviceError: nothing matches; the message lists what exists.
    """
    if isinstance(spec, cl.Device):
        return spec
    devs = _all_devices()
    if not devs:
        raise DeviceError("no OpenCL device found; pip install 'mcocl[pocl]' gives a CPU device" + no_device_hint())
    listing = "\n".join(i.describe() for i in list_devices())
    if spec is None:
        env = os.environ.get("PYOPENCL_CTX", "").strip()
        if not env:
            return _first_usable(devs)
        pspec, _, dspec = env.partition(":")
        platforms = sorted({pi for pi, _, _ in devs})
        plats = _match(platforms, pspec, lambda pi: _platform_text(devs, pi)) if pspec else platforms
        cands = [d for pi, _, d in devs if pi in plats]
        if dspec:
            cands = _match(cands, dspec, lambda d: d.name)
        if not cands:
            raise DeviceError(f"PYOPENCL_CTX={env!r} matches no device; devices:\n{listing}")
        return cands[0]
    if isinstance(spec, (int, np.integer)):
        spec = str(int(spec))
    if not isinstance(spec, str) or not spec.strip():
        raise DeviceError(f"device must be an index or a name substring, got {spec!r}")
    hits = _match(devs, spec.strip(), lambda t: f"{t[2].name} {t[2].platform.name} {t[2].platform.version}")
    if not hits:
        raise DeviceError(f"no device matches {spec!r}; devices:\n{listing}")
    return hits[0][2]


_PROBE_SOURCE = "__kernel void mcocl_probe(__global float* a) { a[get_global_id(0)] = exp(1.0f); }"
_problems: dict[int, str | None] = {}


def device_problem(device: cl.Device) -> str | None:
    """Why ``device`` cannot build OpenCL C, or None when it can (cached per device).

    An OpenCL implementation can list a device that builds nothing: the PoCL
    wheel's LLVM 14 does not know CPUs newer than it (AMD Zen 5 among them)
    and fails every build with "unknown target CPU 'generic'".  A trivial
    build tells such a device apart before a job is placed on it.
    """
    key = device.int_ptr
    if key not in _problems:
        try:
            ctx = cl.Context([device])
            cl.Program(ctx, _PROBE_SOURCE).build(options=list(BASE_OPTIONS))
            _problems[key] = None
        except cl.Error as e:
            lines = [ln.strip() for ln in str(e).splitlines() if "error" in ln.lower() and ln.strip()]
            _problems[key] = (lines[-1] if lines else str(e).splitlines()[0])[:200]
    return _problems[key]


def _first_usable(devs: list[tuple[int, int, cl.Device]]) -> cl.Device:
    """The first device that builds a trivial kernel (the default device)."""
    problems = []
    for _, _, d in devs:
        why = device_problem(d)
        if why is None:
            return d
        problems.append(f"{d.name.strip()} ({d.platform.version.strip()}): {why}")
    raise DeviceError(
        "no OpenCL device can build kernels:\n  " + "\n  ".join(problems)
        + "\nOn Debian or Ubuntu, `apt-get install pocl-opencl-icd` gives a PoCL that knows newer CPUs."
    )


def _platform_text(devs: list, pi: int) -> str:
    for qi, _, d in devs:
        if qi == pi:
            return f"{d.platform.name} {d.platform.version}"
    return ""


class DeviceContext:
    """A device with its context, in-order queue and build parameters.

    ``group`` is the work-group size every launch uses.  It is fixed per
    device because PoCL compiles a kernel anew for every new work-group size
    (about 0.2 s each, docs/pocl-notes.md) and would otherwise choose one
    per global size.  CPUs get 1 (a work-item is already a block of thousands
    of samples); GPUs get 64.
    """

    def __init__(self, device: cl.Device) -> None:
        self.device = device
        self.context = cl.Context([device])
        self.queue = cl.CommandQueue(self.context)
        self.lanes = default_lanes(device)
        self.fp64 = has_fp64(device)
        self.name = device.name.strip()
        self.group = 1 if device.type & cl.device_type.CPU else min(64, int(device.max_work_group_size))

    def work_size(self, n: int) -> tuple[tuple[int], tuple[int]]:
        """(global, local) sizes covering ``n`` work-items; kernels skip ids >= n."""
        g = self.group
        return (max(-(-n // g), 1) * g,), (g,)

    def __repr__(self) -> str:
        return f"DeviceContext({self.name!r}, lanes={self.lanes})"


_contexts: dict[int, DeviceContext] = {}
_contexts_lock = threading.Lock()


def device_context(device: int | str | cl.Device | None = None) -> DeviceContext:
    """The cached :class:`DeviceContext` of a device (see :func:`select_device`)."""
    dev = select_device(device)
    key = dev.int_ptr
    with _contexts_lock:
        ctx = _contexts.get(key)
        if ctx is None:
            ctx = DeviceContext(dev)
            _contexts[key] = ctx
        return ctx


def register_context(ctx: DeviceContext) -> DeviceContext:
    """Make ``ctx`` the cached context of its device, for contexts made outside this module.

    The program cache is keyed by the device alone, so a device must have
    exactly one context (a program built in one context is INVALID_CONTEXT
    in another): after this, :func:`device_context` of ``ctx.device`` returns
    ``ctx`` itself.  :mod:`mcocl.devices` registers each sub-device it creates.

    Raises:
        DeviceError: the device already has another context.
    """
    key = ctx.device.int_ptr
    with _contexts_lock:
        known = _contexts.setdefault(key, ctx)
    if known is not ctx:
        raise DeviceError(f"device {ctx.name!r} already has a context; it cannot get a second one")
    return ctx


@cache
def _read_kernel(rel: str) -> str:
    path = KERNEL_DIR / rel
    if not path.is_file():
        raise FileNotFoundError(f"kernel source {rel} not found under {KERNEL_DIR}")
    return path.read_text()


@cache
def _kernel_parts(rel: str, source: str) -> tuple[tuple[str, str | None], ...]:
    """Kernel file ``rel``'s text split once at its ``#include "..."`` lines: (text, None) for a run of
    other lines, (the ``#line`` marker after it, the included path) for an include.  Splitting every
    file's lines and matching each against the include pattern at every compose took 6 ms of each
    render call.  Keyed by the text too, so that a changed text is split again."""
    parts: list[tuple[str, str | None]] = []
    run: list[str] = []
    for n, line in enumerate(source.splitlines(), start=1):
        m = _INCLUDE.match(line)
        if m:
            if run:
                parts.append(("\n".join(run), None))
                run = []
            parts.append((f'#line {n + 1} "{rel}"', m.group(1)))
        else:
            run.append(line)
    if run:
        parts.append(("\n".join(run), None))
    return tuple(parts)


def kernel_source(rel: str, _seen: set[str] | None = None) -> str:
    """A kernel file with its ``#include "..."`` lines resolved (once each).

    Paths are relative to the kernel folder (:data:`KERNEL_DIR`).  ``#line`` markers keep compiler
    diagnostics pointing at the original file and line.
    """
    seen = _seen if _seen is not None else set()
    if rel in seen:
        return ""
    out: list[str] = []
    _source_lines(rel, seen, out)
    return "\n".join(out)


def _source_lines(rel: str, seen: set[str], out: list[str]) -> None:
    """Append kernel_source(rel)'s pieces to ``out`` (joined by newlines, they are its text): one join
    for the whole program rather than one per file, each copying every file below it again."""
    seen.add(rel)
    out.append(f'#line 1 "{rel}"')
    for text, include in _kernel_parts(rel, _read_kernel(rel)):
        if include is not None:
            if include in seen:
                out.append("")  # an include already resolved: an empty line, as its empty text joined
            else:
                _source_lines(include, seen, out)
        out.append(text)


def compose(
    includes: list[str],
    generated: str = "",
    users: tuple[UserFunction, ...] = (),
    vector_users: bool = True,
    tail: list[str] | tuple[str, ...] = (),
) -> str:
    """One program: engine includes, user snippets, generated text, tail includes.

    User snippets come in their scalar form ``<func>_s`` and, when
    ``vector_users``, their lane form ``<func>_v``; the macro ``<func>`` names
    the one that matches the build's ``LANES``.  ``generated`` is engine text
    produced at run time (glue that calls the snippets); ``tail`` are kernel
    files that use what ``generated`` defines.
    """
    seen: set[str] = set()
    parts = [kernel_source("lanes.cl", seen)]
    parts += [kernel_source(rel, seen) for rel in includes]
    for u in users:
        parts.append(u.render(vector=False))
        if vector_users:
            parts.append(u.render(vector=True))
        parts.append(f"#if LANES == 1\n#define {u.func} {u.func}_s\n#else\n#define {u.func} {u.func}_v\n#endif")
    parts.append('#line 1 "<generated>"')
    parts.append(generated)
    parts += [kernel_source(rel, seen) for rel in tail]
    return "\n".join(parts) + "\n"


def build_digest(source: str, options: list[str] | tuple[str, ...] = ()) -> str:
    """SHA-256 of everything a build depends on: the flattened source and every option.

    ``source`` is the text :func:`compose` gives (every include resolved), so
    an edit to any included file changes the digest; the options are
    :data:`BASE_OPTIONS` followed by ``options``, as :func:`build` passes them.
    Caches of built programs and of results computed by a kernel are keyed by it.
    """
    h = hashlib.sha256()
    for part in (source, *BASE_OPTIONS, *options):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()


_programs: dict[tuple[int, str], cl.Program] = {}
_programs_lock = threading.Lock()


def build(
    ctx: DeviceContext,
    source: str,
    options: list[str] | tuple[str, ...] = (),
    users: tuple[UserFunction, ...] = (),
    what: str = "kernel",
) -> cl.Program:
    """Compile ``source`` for ``ctx``'s device, or return the cached program.

    Raises:
        KernelBuildError: the compiler rejected the source; the message quotes
            the user snippet lines it complained about.
    """
    opts = tuple(BASE_OPTIONS) + tuple(options)
    digest = build_digest(source, options)
    key = (ctx.device.int_ptr, digest)
    with _programs_lock:
        prg = _programs.get(key)
    if prg is not None:
        return prg
    started = time.time()
    with warnings.catch_warnings(), compiler_stderr_captured():
        # PoCL prints ABI notes about wide vectors as warnings, and its clang
        # writes "N warnings generated." to descriptor 2: not the user's business
        # unless build logs are requested (mcocl/build_output.py).
        warnings.simplefilter("ignore", cl.CompilerWarning)
        heartbeat.beat("build")  # a supervisor does not count compile time against --time
        try:
            prg = _compile_with_large_stack(ctx.context, source, list(opts))
        except cl.RuntimeError as e:
            problem = cache_problem(ctx.device.platform.name)
            if problem:  # every build fails then: not the user's code
                raise DeviceError(problem) from None
            show_build_log(what, ctx.name, opts, str(e), failed=True)
            raise explain_build_log(str(e), list(users), what) from None
        finally:
            heartbeat.beat("built")
    if build_log_requested():
        show_build_log(what, ctx.name, opts, prg.get_build_info(ctx.device, cl.program_build_info.LOG))
    bad = _cache_entry_problem(ctx, prg, digest, started)
    if bad is not None:
        if _CACHE_BYPASS in options:  # the fresh build is damaged too: nothing left to trust
            raise DeviceError(f"{bad}; delete PoCL's kernel cache folder {str(cache_folder())!r} and run again")
        print(f"mcocl: warning: {bad}; it was bypassed (a fresh build is used); delete it to stop this warning",
              file=sys.stderr)
        prg = build(ctx, source, [*options, _CACHE_BYPASS], users, what)
    with _programs_lock:
        _programs[key] = prg
    return prg


# Stack of the thread that compiles.  Clang recurses once per operand of a long
# expression: an 18,000-term sum overflowed the 8 MiB stack of the main thread
# and killed the process with SIGSEGV (issue 10); with this much it compiles.
# Only address space is reserved; pages are touched as deep as the recursion goes.
BUILD_STACK_BYTES = 1 << 30


def _compile_with_large_stack(context: cl.Context, source: str, options: list[str]) -> cl.Program:
    """``cl.Program(context, source).build(options)`` on a thread with BUILD_STACK_BYTES of stack."""
    result: dict[str, object] = {}

    def work() -> None:
        try:
            result["program"] = cl.Program(context, source).build(options=options)
        except BaseException as e:  # noqa: BLE001 - re-raised in the calling thread
            result["error"] = e

    try:
        old = threading.stack_size(BUILD_STACK_BYTES)
    except (ValueError, RuntimeError):  # a platform without settable stacks: build in place
        work()
    else:
        try:
            thread = threading.Thread(target=work, name="mcocl-build", daemon=True)
            thread.start()
        finally:
            threading.stack_size(old)
        thread.join()
    if "error" in result:
        raise result["error"]  # type: ignore[misc]
    return result["program"]  # type: ignore[return-value]


# An option that changes PoCL's cache key and nothing else: a program whose
# cache entry is damaged is rebuilt under it (mcocl/pocl_cache_record.py).
_CACHE_BYPASS = "-DMCOCL_POCL_CACHE_BYPASS=1"


def _cache_entry_problem(ctx: DeviceContext, prg: cl.Program, digest: str, started: float) -> str | None:
    """Why the PoCL cache entry this build used cannot be trusted, or None (see mcocl/pocl_cache_record.py)."""
    platform = ctx.device.platform
    if "portable computing language" not in platform.name.lower():
        return None
    entry = entry_used(started, time.time(), prg.get_info(cl.program_info.KERNEL_NAMES).split(";"))
    if entry is None:
        return None
    identity = f"{platform.version}\0{ctx.device.name}\0{ctx.device.driver_version}"
    return check_entry(record_key(digest, identity), entry)


@dataclass
class UserProgram:
    """A program with user snippets, and the lane width it was built for."""

    program: cl.Program
    lanes: int
    note: str | None = None  # why the scalar build was used, if it was


def build_user_program(
    ctx: DeviceContext,
    includes: list[str],
    generated: str,
    users: tuple[UserFunction, ...],
    tail: list[str] | tuple[str, ...] = (),
    options: list[str] | tuple[str, ...] = (),
    what: str = "kernel",
    lanes: int | None = None,
) -> UserProgram:
    """Build a program holding user snippets, in lane form where that is safe.

    The lane build (``LANES`` = ``lanes`` or the device's default) is tried
    first.  It is used only if it compiles *and* every snippet's lane form
    agrees with its scalar form on a set of probe points (a snippet may
    compile on vectors yet mean something else, e.g. a comparison used as a
    number).  Otherwise the scalar build is used and ``note`` says why; the
    scalar build's compile errors are the ones reported to the user, since
    they concern the code as the user wrote it.
    """
    want = ctx.lanes if lanes is None else int(lanes)
    key = (ctx.device.int_ptr, tuple(includes), generated, users, tuple(tail), tuple(options), what, want)
    with _programs_lock:
        done = _user_programs.get(key)
    if done is None:
        done = _build_user_program(ctx, includes, generated, users, tail, options, what, want)
        with _programs_lock:
            _user_programs[key] = done
    return done


_user_programs: dict[tuple, UserProgram] = {}


def _build_user_program(
    ctx: DeviceContext,
    includes: list[str],
    generated: str,
    users: tuple[UserFunction, ...],
    tail: list[str] | tuple[str, ...],
    options: list[str] | tuple[str, ...],
    what: str,
    want: int,
) -> UserProgram:
    note = None
    if want > 1:
        probe = probe_source(users) if users else ""
        src = compose(includes, generated + probe, users, vector_users=True, tail=tail)
        try:
            prg = build(ctx, src, [f"-DLANES={want}", *options], users, what)
        except KernelBuildError:
            note = f"the {what} is not valid on vector lanes; using the scalar build"
        else:
            bad = _probe_mismatch(ctx, prg, users, want)
            if bad is None:
                return UserProgram(prg, want)
            note = f"the lane form of {bad} disagreed with its scalar form; using the scalar build"
    src = compose(includes, generated, users, vector_users=False, tail=tail)
    prg = build(ctx, src, ["-DLANES=1", *options], users, what)
    return UserProgram(prg, 1, note)


_PROBE_POINTS = 64


def _probe_mismatch(ctx: DeviceContext, prg: cl.Program, users: tuple[UserFunction, ...], lanes: int) -> str | None:
    """Run the probe kernel; return the label of the first disagreeing snippet."""
    if not users:
        return None
    nargs = max(sum(max(n, 1) for _, n in u.params) for u in users)
    pts = np.random.default_rng(12345).uniform(0.02, 0.98, size=(nargs, _PROBE_POINTS)).astype(np.float32)
    mf = cl.mem_flags
    bp = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=pts)
    out_s = np.empty((len(users), _PROBE_POINTS), np.float32)
    out_v = np.empty_like(out_s)
    bs = cl.Buffer(ctx.context, mf.WRITE_ONLY, out_s.nbytes)
    bv = cl.Buffer(ctx.context, mf.WRITE_ONLY, out_v.nbytes)
    kernel(prg, "probe_users")(ctx.queue, (_PROBE_POINTS // lanes,), None, bp, bs, bv)
    cl.enqueue_copy(ctx.queue, out_s, bs)
    cl.enqueue_copy(ctx.queue, out_v, bv)
    with np.errstate(invalid="ignore"):
        for k, u in enumerate(users):
            a, b = out_s[k].astype(np.float64), out_v[k].astype(np.float64)
            fin = np.isfinite(a) & np.isfinite(b)
            same_class = (np.isfinite(a) == np.isfinite(b)) & (np.isnan(a) == np.isnan(b))
            close = np.abs(a - b) <= 1e-4 * np.maximum(np.abs(a), np.abs(b)) + 1e-30
            if not np.all(same_class) or not np.all(close[fin]):
                return u.label
    return None


_kernels: dict[tuple[int, str], cl.Kernel] = {}


def kernel(program: cl.Program, name: str) -> cl.Kernel:
    """The kernel ``name`` of ``program``, retrieved once and reused.

    A kernel object carries its arguments, so callers that launch from several
    threads must use one device (one program) per thread, as the scheduler does.
    """
    key = (program.int_ptr, name)
    with _programs_lock:
        k = _kernels.get(key)
        if k is None:
            k = cl.Kernel(program, name)
            _kernels[key] = k
        return k


__all__ = [
    "KERNEL_DIR",
    "DeviceContext",
    "DeviceInfo",
    "KernelBuildError",
    "UserProgram",
    "build",
    "build_digest",
    "build_user_program",
    "compose",
    "default_lanes",
    "device_context",
    "has_fp64",
    "kernel",
    "kernel_source",
    "list_devices",
    "register_context",
    "select_device",
]
