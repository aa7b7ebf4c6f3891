"""Run a command's device work in a child process that this process watches.

User snippets (an integrand, a kernel K, a source g) are compiled to native
code and run inside the process that launched them: an endless loop in one
never returns from its kernel launch, so neither ``--time`` nor Ctrl-C can
stop it from inside, and a wild write or a compiler crash kills the process
with no message.  The command line therefore runs ``integrate``, ``solve``,
``render`` and ``bench`` as a child (the same command, marked by the
environment) and supervises it from here:

- the child reports when it compiles a program (:mod:`mcocl.heartbeat`);
  with ``--time T`` the child is stopped once it has run ``T + GRACE``
  seconds not counting compilation, which it never does unless a kernel
  launch (a sampling block, or the probe that checks the user's code) is
  stuck;
- Ctrl-C and SIGTERM are passed on to the child, which stops and saves what it
  has (:class:`~mcocl.engine.contract.InterruptFlag`); a child that has not
  ended ``STOP_WAIT`` seconds after the first request is asked a second time
  (it then abandons the launch in flight and saves what it has folded), and
  one still running ``URGENT_STOP_WAIT`` seconds after the second is killed;
- a child killed by a signal (SIGSEGV, SIGBUS, SIGABRT, ...) is reported in
  one line with exit status 2, instead of the shell's bare "Segmentation
  fault";
- a child that crashes after it began to compile is run once more with a
  fresh temporary PoCL kernel cache (a damaged cache entry makes PoCL abort
  or crash every run of that program); when that run succeeds, the message
  names the cache folder as the cause.  A crash during a build that had run
  longer than ``CACHE_LOAD_SECONDS`` is the compiler's own (a cache lookup is
  quick; a long build compiles from source): it is reported as such at once,
  since a rerun would only crash again after as long.

The child runs in its own session, so a terminal's Ctrl-C reaches only this
process, which forwards it exactly once.  ``MCOCL_SUPERVISE=0`` turns the
supervision off (the command then runs in this process, as the API does).
"""

from __future__ import annotations

import ctypes
import os
import select
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ..heartbeat import ENV as HEARTBEAT_ENV
from ..pocl_cache import cache_folder

# Commands whose work runs user code on a device.
SUPERVISED = frozenset({"integrate", "solve", "render", "bench"})
# Seconds a supervised run may outlive its --time before it is stopped.
GRACE = 3.0
# Seconds a child may take to stop after Ctrl-C or SIGTERM before it is killed.
STOP_WAIT = 10.0
# After a second request the child only writes what it has folded: a child still
# running this many seconds later is stuck in a kernel launch and is killed (issue 10:
# two Ctrl-Cs on an endless loop waited the full STOP_WAIT again).
URGENT_STOP_WAIT = 5.0
# Exit status of a run stopped by the supervisor (as for any engine error).
EXIT_ERROR = 2
# A build that crashed after running this long was compiling from source, not
# loading PoCL's cache (a cache hit takes well under a second).
CACHE_LOAD_SECONDS = 5.0


def wanted(argv: Sequence[str] | None, command: str | None) -> bool:
    """True when ``command`` should run supervised: the console entry point
    (``argv`` None), a supervised command, not already the child, not turned off."""
    return (
        argv is None
        and command in SUPERVISED
        and HEARTBEAT_ENV not in os.environ
        and os.environ.get("MCOCL_SUPERVISE", "1") != "0"
    )


def _signal_name(num: int) -> str:
    try:
        return signal.Signals(num).name
    except ValueError:
        return f"signal {num}"


def _what(command: str) -> str:
    return {"integrate": "the integrand", "solve": "the kernel or source", "render": "the renderer",
            "bench": "a benchmarked snippet"}.get(command, "the device code")


@dataclass(frozen=True)
class _Crash:
    """A child killed by ``signum``; ``in_build``: while a build had been running ``build_seconds``."""

    signum: int
    in_build: bool
    build_seconds: float


def _crash_message(command: str, crash: _Crash) -> str:
    if crash.in_build:
        return (
            f"mcocl {command}: error: the compiler crashed while building {_what(command)} "
            f"({_signal_name(crash.signum)}); code this long or this deeply nested is beyond the OpenCL "
            "compiler: shorten it or split it into several statements. If the same code compiled before, "
            f"PoCL's kernel cache {str(cache_folder())!r} may hold a corrupt entry: delete it and run again"
        )
    return (
        f"mcocl {command}: error: {_what(command)} crashed the device process ({_signal_name(crash.signum)}); "
        "checkpoints written before the crash are kept (--checkpoint), nothing else was saved"
    )


def _die_with_parent(parent: int) -> Callable[[], None] | None:
    """What the child runs before exec so that it dies with this process, even one killed by SIGKILL.

    The child lives in its own session, so a ``kill -9`` of this process or of
    its process group would leave it running: with an endless loop in the
    user's code, for ever (issue 10).  Linux's ``prctl(PR_SET_PDEATHSIG)``
    has the kernel send it SIGKILL when this process ends; elsewhere nothing is done.
    """
    if not sys.platform.startswith("linux"):
        return None

    def arm() -> None:
        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            return
        if os.getppid() != parent:  # the parent died before the request was made
            os._exit(1)

    return arm


class _Child:
    """The supervised child and what it has told us."""

    def __init__(self, argv: Sequence[str], env_changes: dict[str, str] | None = None) -> None:
        read_fd, write_fd = os.pipe()
        env = dict(os.environ)
        env.update(env_changes or {})
        env[HEARTBEAT_ENV] = str(write_fd)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mcocl", *argv],
            env=env,
            pass_fds=(write_fd,),
            start_new_session=True,
            preexec_fn=_die_with_parent(os.getpid()),
        )
        os.close(write_fd)
        self.pipe = read_fd
        self.launched = time.monotonic()
        self.builds = 0  # builds started
        self.compiling = 0  # builds under way (several devices build at once)
        self.compile_since = 0.0
        self.compile_seconds = 0.0
        self.stopping: float | None = None  # when the last stop was asked for
        self.killed_for = ""
        self.beats = 0  # events read: none while the child still imports (its first is its first build)
        self.started: float | None = None  # when sampling began (the child's first "start" beat)
        self.compile_before_start = 0.0

    def read_beats(self, timeout: float) -> None:
        ready, _, _ = select.select([self.pipe], [], [], timeout)
        if not ready:
            return
        try:
            data = os.read(self.pipe, 4096)
        except OSError:
            data = b""
        if not data:  # the child closed its end (it is exiting)
            time.sleep(min(timeout, 0.05))
            return
        self._count(data)

    def _count(self, data: bytes) -> None:
        now = time.monotonic()
        for line in data.decode(errors="replace").split():
            self.beats += 1
            if line == "build":
                self.builds += 1
                if self.compiling == 0:
                    self.compile_since = now
                self.compiling += 1
            elif line == "start" and self.started is None:
                self.started = now
                self.compile_before_start = self.compile_seconds
            elif line == "built" and self.compiling > 0:
                self.compiling -= 1
                if self.compiling == 0:
                    self.compile_seconds += now - self.compile_since

    def drain(self) -> None:
        """Read the beats the child wrote before it ended (its pipe is at its end once it has)."""
        while select.select([self.pipe], [], [], 0)[0]:
            try:
                data = os.read(self.pipe, 4096)
            except OSError:
                return
            if not data:
                return
            self._count(data)

    def running_seconds(self, now: float) -> float:
        """The seconds --time is held against, less the time spent compiling: since sampling began
        (the engine's own clock starts there), or since launch while the child is still setting up.

        Counting from the start of sampling keeps Python's start-up and the setup of the run (both
        slow on a busy machine) out of the budget, so a healthy run with a tiny --time still gets
        its first block (issue 10: --time 1e-9 was killed before it, exit 2); an endless loop in
        the probes that run the user's code before sampling is still caught from launch.
        """
        compiling = now - self.compile_since if self.compiling else 0.0
        if self.started is None:
            return now - self.launched - self.compile_seconds - compiling
        return now - self.started - (self.compile_seconds - self.compile_before_start) - compiling

    def uncounted(self, now: float) -> str:
        """What ``running_seconds`` left out, for the message of a run stopped at its --time: the wall
        time then exceeds --time plus GRACE by this much, and the user should see why."""
        seconds = self.compile_seconds + (now - self.compile_since if self.compiling else 0.0)
        if self.started is not None:
            seconds += self.started - self.launched - self.compile_before_start
            what = "start-up and compiling"
        else:
            what = "compiling"
        return f" (not counting {seconds:.1f} s of {what})" if seconds >= 0.05 else ""

    def kill(self, why: str) -> None:
        self.killed_for = why
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def run(argv: Sequence[str], command: str, time_budget: float | None) -> int:
    """Run ``mcocl <argv>`` as a supervised child; return its exit status.

    A child that crashes (SIGABRT, SIGBUS, SIGSEGV, SIGILL) after it began to
    compile is run once more with a fresh, temporary PoCL kernel cache: PoCL
    aborts, or loads a broken library, when an entry of its cache is damaged,
    and would do so on every later run of that program.  Only when the second
    run succeeds is the cache named as the cause.
    """
    code, crash = _run_once(argv, command, time_budget, None)
    if crash is None:
        return code
    if crash.in_build and crash.build_seconds > CACHE_LOAD_SECONDS:  # the compiler's own crash: see the docstring
        print(_crash_message(command, crash), file=sys.stderr)
        return EXIT_ERROR
    with tempfile.TemporaryDirectory(prefix="mcocl-pocl-cache-") as fresh:
        code, again = _run_once(argv, command, time_budget, {"POCL_CACHE_DIR": fresh})
    if again is not None:
        print(_crash_message(command, again), file=sys.stderr)
    elif code == 0:
        folder = str(cache_folder())
        print(f"mcocl {command}: warning: the first attempt crashed ({_signal_name(crash.signum)}) while using PoCL's "
              f"kernel cache {folder!r}, which holds a corrupt entry; it was bypassed (the run was repeated with "
              f"a fresh temporary cache): delete {folder!r} to repair it", file=sys.stderr)
    return code


# Signals a damaged PoCL cache entry raises: PoCL's own abort, or a broken kernel library.
_CACHE_CRASHES = frozenset({signal.SIGABRT, signal.SIGBUS, signal.SIGSEGV, signal.SIGILL})


def _run_once(
    argv: Sequence[str], command: str, time_budget: float | None, env_changes: dict[str, str] | None
) -> tuple[int, _Crash | None]:
    """Run the child once: its exit status, and the signal that crashed it after a build began, if any.

    Such a crash is left to the caller to report (it may retry); every other outcome is reported here.
    """
    child = _Child(argv, env_changes)
    requests: list[int] = []

    def forward(signum: int, frame: object) -> None:
        requests.append(signum)

    old = {s: signal.signal(s, forward) for s in (signal.SIGINT, signal.SIGTERM)}
    forwarded = 0
    try:
        while child.proc.poll() is None:
            child.read_beats(0.2)
            now = time.monotonic()
            while forwarded < len(requests):
                sig = requests[forwarded]
                forwarded += 1
                child.stopping = now
                if forwarded >= 3:
                    child.kill("interrupted three times")
                elif not child.beats:
                    # still importing Python modules, with nothing computed: a KeyboardInterrupt there
                    # would print a traceback from the middle of an import
                    child.kill("interrupted while it was starting; nothing was computed")
                else:
                    try:
                        child.proc.send_signal(sig)
                    except ProcessLookupError:
                        pass
            if child.killed_for:
                continue
            wait = STOP_WAIT if forwarded < 2 else URGENT_STOP_WAIT
            if child.stopping is not None and now - child.stopping > wait and len(requests) == 1:
                # one request not met in STOP_WAIT: a long launch (a big sobol batch) or a stuck one. Ask
                # again, as a second Ctrl-C would: the child then keeps what it has folded and abandons
                # the launch (issue 10: a single Ctrl-C lost the image of the batches already done)
                requests.append(requests[0])
            elif child.stopping is not None and now - child.stopping > wait:
                child.kill(f"it did not stop within {wait:g} s of the request (a kernel launch is stuck)")
            elif time_budget is not None and child.running_seconds(now) > time_budget + GRACE:
                child.kill(
                    f"it outlived --time {time_budget:g} by {GRACE:g} s{child.uncounted(now)}: a kernel launch "
                    "did not return (an endless loop in the user code?)"
                )
        code = child.proc.wait()
        child.drain()
    finally:
        for s, h in old.items():
            # once asked to stop, the process only reports and exits: a further Ctrl-C must not
            # interrupt that with a KeyboardInterrupt (issue 10: two quick Ctrl-Cs gave exit -2)
            signal.signal(s, forward if requests else h)
        os.close(child.pipe)
    if child.killed_for:
        print(f"mcocl {command}: error: stopped the run: {child.killed_for}; "
              "checkpoints already written (--checkpoint) are kept", file=sys.stderr)
        return (130 if requests else EXIT_ERROR), None
    if code < 0:
        if -code in (signal.SIGINT, signal.SIGTERM):
            # killed outright, before it had a handler (still starting, or in a build): say so, as an
            # interrupted run that saved its result would have
            print(f"mcocl {command}: stopped by {_signal_name(-code)} before sampling; nothing was computed "
                  "(checkpoints already written with --checkpoint are kept)", file=sys.stderr)
            return 128 - code, None
        crash = _Crash(-code, child.compiling > 0,
                       time.monotonic() - child.compile_since if child.compiling else 0.0)
        if -code in _CACHE_CRASHES and child.builds and not requests:
            return EXIT_ERROR, crash
        print(_crash_message(command, crash), file=sys.stderr)
        return EXIT_ERROR, None
    return code, None
