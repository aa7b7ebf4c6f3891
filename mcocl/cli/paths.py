"""The command line's files: every declared output checked before any work, no input overwritten.

Each command calls :func:`check_files` first with its outputs (``--out``,
``--png``, ``--checkpoint``, bench's ``--out`` folder) and its inputs (the
scene, problem files, ``--resume``), so a render of an hour never ends in
"No such file or directory" with the image lost, and ``--out scene.json``
never replaces the scene.
"""

from __future__ import annotations

import os
from collections.abc import Iterable

from ..errors import InputError
from ..output_files import check_distinct, check_output_file, check_output_folder

Named = Iterable[tuple[str, "str | os.PathLike[str] | None"]]


# The kind of file each output option writes (mcocl.output_files.SIGNATURES): an
# existing file is replaced only when it is of that kind.
OUTPUT_KINDS = {"--png": "png", "--checkpoint": "checkpoint"}


def check_files(outputs: Named = (), inputs: Named = (), folders: Named = (), resume: str | None = None,
                kinds: dict[str, str] | None = None) -> None:
    """Refuse unusable outputs before anything runs.

    Args:
        outputs: ``(option, path)`` of files to be written (``None`` skipped).
        inputs: ``(option, path)`` of files that are read and must survive.
        folders: ``(option, path)`` of output folders (created if missing).
        resume: the ``--resume`` checkpoint: it must exist, and it may be the
            same file as ``--checkpoint`` (continuing a run in place), but no
            other output may overwrite it.
        kinds: more ``option: kind`` pairs for :data:`OUTPUT_KINDS` (render's ``--out`` is an EXR).

    Raises:
        InputError: naming the option and the reason.
    """
    outs = [(w, p) for w, p in outputs if p is not None]
    for w, p in outs:
        check_output_file(p, w)
    for w, p in folders:
        if p is not None:
            check_output_folder(p, w)
    if resume is not None and not os.path.isfile(resume):
        raise InputError(f"--resume {resume!r}: no such checkpoint file")
    ins = [(w, p) for w, p in inputs if p is not None]
    check_distinct(outs, ins)
    if resume is not None:
        check_distinct([(w, p) for w, p in outs if w != "--checkpoint"], [("--resume", resume)])
    kind_of = {**OUTPUT_KINDS, **(kinds or {})}
    for w, p in outs:  # last: "is the scene, an input" says more than "is not an OpenEXR image"
        check_output_file(p, w, kind_of.get(w))


__all__ = ["check_files"]
