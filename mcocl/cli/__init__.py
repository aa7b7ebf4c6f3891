"""The ``mcocl`` command line: one sub-command per module in this package.

Each sub-command module defines ``register(subparsers)``, which adds its parser
and sets ``func`` (called with the parsed arguments, returning an exit status).
Errors of the engine (:class:`~mcocl.errors.MCOCLError`) become one message on
stderr and exit status 2; Ctrl-C exits with 130 after saving what was computed.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings

from ..errors import MCOCLError

VERBOSE_HELP = "show the OpenCL compiler's build logs (as MCOCL_BUILD_LOG=1 does)"

# Sub-commands, in the order --help lists them.
COMMANDS = ("devices", "integrate", "solve", "render", "convert", "bench")

EPILOG = """\
examples:
  mcocl devices
  mcocl integrate "exp(-x[0]*x[0])" --dim 1 --samples 1e6 --sampler nrooks --seed 7
  mcocl integrate "exp(-x[0]*x[0] - x[1]*x[1])" --dim 2 --samples 1e7 --json
  mcocl integrate "exp(-(x[0]+x[1]+x[2]))*cos(x[3])" --dim 4 --sampler sobol --samples 1e7
  mcocl render scenes/cornell.json --spp 64 --out cornell.exr --png cornell.png
  mcocl render scene.xml -D spp=256 --integrator bdpt --out scene.exr
  mcocl <command> --help       more about one command

Every per-sample computation runs in OpenCL kernels; results depend only on the
seed (and the lane width, in the last bits, for snippets that call math
built-ins), never on the device, the work split or interruptions.
"""


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every available sub-command."""
    parser = argparse.ArgumentParser(
        prog="mcocl",
        description="mcocl — an OpenCL Monte Carlo engine: integration, integral equations, light transport.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"mcocl {__version__}")
    parser.add_argument("--verbose", action="store_true", help=VERBOSE_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            mod = importlib.import_module(f".{name}_cmd", __name__)
        except ModuleNotFoundError as e:
            if e.name == f"{__name__}.{name}_cmd":
                continue  # command not part of this build
            raise
        mod.register(sub)
    for cmd in sub.choices.values():
        # also after the command (mcocl render ... --verbose); SUPPRESS keeps the
        # sub-command's default from overwriting a --verbose given before it
        cmd.add_argument("--verbose", action="store_true", default=argparse.SUPPRESS, help=VERBOSE_HELP)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mcocl`` console script."""
    import signal

    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:  # see mcocl/__init__.py: from here on, KeyboardInterrupt
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        code = _run(argv)
    except KeyboardInterrupt:
        # Ctrl-C before the command's own handling is set up (while the
        # sub-commands import NumPy and pyopencl): nothing ran yet, no traceback.
        print("mcocl: interrupted", file=sys.stderr)
        code = 130
    if code in (130, 143) and argv is None:
        # Stopped on request and reported: a repeated request has nothing left to stop.  Python resets
        # its own handlers as it exits, and a SIGTERM then killed the process (exit -15 in place of the
        # reported 130, issue 10); an ignored signal stays ignored.
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
    one_device = sys.modules.get("mcocl.engine.one_device")
    if argv is None and one_device is not None and one_device.ABANDONED:
        # a launch abandoned by a repeated stop request still runs on the device, and releasing
        # OpenCL under it as Python exits crashed PoCL (SIGSEGV, exit 2, after the image was
        # written; issue 10): the outputs are written, so leave without tearing anything down
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


def _run(argv: list[str] | None) -> int:
    """Parse the command line and run the command (supervised, unless told otherwise)."""
    # imported here, under main's Ctrl-C handling, like everything a command needs
    from ..build_output import set_build_log
    from . import supervise

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    if supervise.wanted(argv, args.command):
        return supervise.run(sys.argv[1:], args.command, getattr(args, "time_budget", None))
    if args.verbose:
        set_build_log(True)
    if args.command in supervise.SUPERVISED:  # the commands that run on a device
        from ..engine.contract import InterruptFlag

        # a run stopped by Ctrl-C or SIGTERM still reports and saves its result when the request is repeated
        InterruptFlag.linger = True
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        try:
            return int(args.func(args) or 0)
        except MCOCLError as e:
            print(f"mcocl {args.command}: error: {e}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print(f"mcocl {args.command}: interrupted", file=sys.stderr)
            return 130
        finally:
            if "mcocl.engine.contract" in sys.modules:  # in-process callers (tests) get the default back
                sys.modules["mcocl.engine.contract"].InterruptFlag.linger = False


if __name__ == "__main__":  # python -m mcocl.cli
    sys.exit(main())
