"""Writing result files safely: checked before the work, replaced atomically after it.

Two rules (issue 10): an output is checked before any work starts, so a long
run never ends in "cannot write" with its result lost; and a file is written
under a unique temporary name in its own folder and renamed over the target,
so an interrupted write never leaves a truncated file and two runs writing the
same file (one ``--checkpoint`` shared by two renders) never collide: each
rename is atomic, the last one wins, and both runs succeed.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path

from .errors import InputError

# The process's umask, read once (os.umask can only be read by setting it): a new output gets
# the permissions open() would give it, not mkstemp's private 0600.
_UMASK = os.umask(0o022)
os.umask(_UMASK)


# How each kind of output file begins.  An existing file is replaced only when
# it is empty or an earlier output of the same kind (issue 10: ``--out
# quad.obj`` replaced the scene's mesh; any other file of the user's could have
# gone the same way).
SIGNATURES = {
    "exr": (b"v/1\x01", "an OpenEXR image"),  # OpenEXR's magic number
    "png": (b"\x89PNG\r\n\x1a\n", "a PNG image"),  # PNG spec 5.2
    "checkpoint": (b"PK\x03\x04", "an mcocl checkpoint"),  # a NumPy .npz archive is a zip file
}


def check_output_file(path: str | os.PathLike[str], what: str, kind: str | None = None) -> Path:
    """Refuse an output file that cannot be written, before any work is done.

    The file must not be a folder, its folder must exist and be writable, and
    an existing file must be writable and, when ``kind`` (a key of
    :data:`SIGNATURES`) is given, empty or a file of that kind.

    Raises:
        InputError: naming ``what`` (e.g. ``--out``) and the reason.
    """
    p = Path(path)
    if str(path) == "" or p.name in ("", ".", ".."):
        raise InputError(f"{what} {str(path)!r}: not a file name")
    if p.is_dir():
        raise InputError(f"{what} {str(p)!r} is a folder; give a file name")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{what} {str(p)!r}: the folder {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{what} {str(p)!r}: the folder {str(parent)!r} is not writable")
    if p.exists() and not p.is_file():
        raise InputError(f"{what} {str(p)!r} exists and is not a regular file")
    if kind is not None and p.is_file():
        magic, name = SIGNATURES[kind]
        try:
            with open(p, "rb") as fh:
                head = fh.read(len(magic))
        except OSError:
            head = magic  # unreadable: the write itself will say why
        if head and not head.startswith(magic):
            raise InputError(f"{what} {str(p)!r} exists and is not {name}; mcocl replaces only its own earlier "
                             "outputs: remove the file or choose another name")
    return p


def check_output_folder(path: str | os.PathLike[str], what: str) -> Path:
    """Refuse an output folder that cannot be created or written, before any work is done."""
    p = Path(path)
    if p.exists():
        if not p.is_dir():
            raise InputError(f"{what} {str(p)!r} exists and is not a folder")
        if not os.access(p, os.W_OK | os.X_OK):
            raise InputError(f"{what} {str(p)!r}: the folder is not writable")
        return p
    # created with its parents: the nearest existing ancestor must be a writable folder
    anc = p.absolute().parent
    while not anc.exists():
        anc = anc.parent
    if not anc.is_dir() or not os.access(anc, os.W_OK | os.X_OK):
        raise InputError(f"{what} {str(p)!r}: cannot create it in {str(anc)!r} (not a writable folder)")
    return p


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def check_distinct(outputs: Iterable[tuple[str, str | os.PathLike[str] | None]],
                   inputs: Iterable[tuple[str, str | os.PathLike[str] | None]] = ()) -> None:
    """Refuse outputs that are the same file as each other or as an input file.

    Args:
        outputs, inputs: ``(option name, path or None)`` pairs; ``None`` is skipped.

    Raises:
        InputError: naming both options.
    """
    outs = [(w, Path(p)) for w, p in outputs if p is not None]
    ins = [(w, Path(p)) for w, p in inputs if p is not None]
    for i, (wa, a) in enumerate(outs):
        for wb, b in outs[i + 1:]:
            if _same_file(a, b):
                raise InputError(f"{wa} and {wb} name the same file {str(a)!r}; give each its own")
        for wb, b in ins:
            if _same_file(a, b):
                raise InputError(f"{wa} {str(a)!r} is {wb}, an input; writing it would destroy it")


def write_atomically(path: str | os.PathLike[str], write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` for a unique temporary file beside ``path``, then rename it over ``path``.

    The temporary name is unique per call (:func:`tempfile.mkstemp`), so
    concurrent writers of one path never write into the same file; it keeps
    ``path``'s suffix, which some writers (OpenEXR, NumPy) look at.  On any
    failure the temporary file is removed and ``path`` is left as it was.
    """
    p = Path(path)
    fd, name = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp" + p.suffix, dir=p.parent if str(p.parent) else ".")
    os.close(fd)
    tmp = Path(name)
    try:
        try:
            mode = p.stat().st_mode & 0o777
        except OSError:
            mode = 0o666 & ~_UMASK
        os.chmod(tmp, mode)
        write(tmp)
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


__all__ = ["SIGNATURES", "check_distinct", "check_output_file", "check_output_folder", "write_atomically"]
