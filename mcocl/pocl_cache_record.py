"""mcocl's own record of PoCL's kernel cache entries: a swapped or edited entry is noticed.

PoCL reuses a cached program whenever the hash of (source, options, device)
matches a folder of its cache (:func:`mcocl.pocl_cache.cache_folder`); it
never checks that the files inside still belong to that program.  A swapped
``program.bc`` or kernel ``.so`` would therefore run another program's code
and give a wrong result with exit status 0.  (A damaged file makes PoCL abort
instead; the supervised command line retries such a run with a fresh cache,
see :mod:`mcocl.cli.supervise`.)

After every build mcocl finds the cache entry the build used (the entry whose
``last_accessed`` stamp PoCL set during the build and whose ``program.bc``
names the program's kernels) and compares SHA-256 digests of its files with
the record it wrote the first time that program (by :func:`mcocl.runtime.build_digest`)
was built for that device: trust on first use, files recorded as they appear.
The records live in ``mcocl-records/`` inside PoCL's cache folder, so clearing
the cache clears them too.  The check is skipped (never fails) when the entry
cannot be identified uniquely, e.g. while another process builds at the same
instant, or when the records cannot be written.

PoCL's bitcode is not byte-for-byte reproducible: it embeds the name of the
temporary source file (``tempfile_XXXXXX.cl``), so two processes that build
one program at the same instant leave the entry with either's bytes.  The
record therefore keeps ``program.bc`` as its size and the digests of its
chunks (:func:`bitcode_fingerprint`), and a bitcode of the same size that
differs in at most ``REBUILD_CHUNKS`` chunks is taken for PoCL's own rebuild
(:func:`rebuilt_alike`); another program's bitcode differs in size or almost
everywhere.  The kernel libraries (``.so``) are reproducible and keep whole
digests.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

from .pocl_cache import cache_folder

RECORDS = "mcocl-records"
# Seconds of slack around the build when matching last_accessed stamps: file
# times come from the kernel's coarse clock (a tick of a few milliseconds).
SLACK = 0.01
# A rebuild of one program changes two places of its bitcode (the temporary
# file's name in the string table and in the module's source-file record).
REBUILD_CHUNKS = 4
# Bitcode chunks: at least this many bytes, at most MAX_CHUNKS of them per file.
MIN_CHUNK = 256
MAX_CHUNKS = 512


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def bitcode_fingerprint(data: bytes) -> str:
    """``size:digest,digest,...``: the bitcode's size and short digests of its chunks."""
    chunk = max(MIN_CHUNK, -(-len(data) // MAX_CHUNKS))
    parts = (hashlib.sha256(data[i:i + chunk]).hexdigest()[:16] for i in range(0, len(data), chunk))
    return f"{len(data)}:{','.join(parts)}"


def rebuilt_alike(recorded: str, now: str) -> bool:
    """True when two bitcode fingerprints differ only as PoCL's rebuilds of one program differ."""
    size_a, _, chunks_a = recorded.partition(":")
    size_b, _, chunks_b = now.partition(":")
    a, b = chunks_a.split(","), chunks_b.split(",")
    return size_a == size_b and len(a) == len(b) and sum(x != y for x, y in zip(a, b)) <= REBUILD_CHUNKS


def _entry_files(entry: Path) -> dict[str, str]:
    """Fingerprints of the files that decide what runs: the program bitcode and every kernel library."""
    files = {"program.bc": bitcode_fingerprint((entry / "program.bc").read_bytes())}
    for so in sorted(entry.glob("*/*/*.so")):
        files[so.relative_to(entry).as_posix()] = _file_digest(so)
    return files


def entry_used(since: float, until: float, kernel_names: list[str]) -> Path | None:
    """The cache entry a build between ``since`` and ``until`` used, or None if not exactly one."""
    root = cache_folder()
    found = []
    try:
        prefixes = [p for p in os.scandir(root) if p.is_dir() and len(p.name) == 2]
        for prefix in prefixes:
            for entry in os.scandir(prefix.path):
                try:
                    stamp = os.stat(os.path.join(entry.path, "last_accessed")).st_mtime
                except OSError:
                    continue
                if since - SLACK <= stamp <= until + SLACK:
                    found.append(Path(entry.path))
    except OSError:
        return None
    # Keep only entries whose bitcode names our kernels, even when one entry
    # alone was touched: PoCL may stamp another program's entry in the same
    # instant (a probe build, a program it loads), and trusting that one would
    # pin this program's record to the wrong entry.
    names = [n.encode() for n in kernel_names if len(n) >= 4]  # short names match any file
    found = [e for e in found if names and _names_all(e / "program.bc", names)]
    return found[0] if len(found) == 1 else None


def _names_all(bitcode: Path, names: list[bytes]) -> bool:
    try:
        data = bitcode.read_bytes()
    except OSError:
        return False
    return all(n in data for n in names)


def _record_path(key: str) -> Path:
    return cache_folder() / RECORDS / key[:2] / f"{key}.json"


def record_key(build_digest: str, device_identity: str) -> str:
    """The record's name: the program's build digest on one device and driver."""
    return hashlib.sha256(f"{build_digest}\0{device_identity}".encode()).hexdigest()


def check_entry(key: str, entry: Path) -> str | None:
    """Compare ``entry`` with the record ``key``; add files not yet recorded.

    Returns a one-line description of the first file that differs from the
    record, or None when everything recorded matches (or nothing could be read).
    """
    try:
        now = _entry_files(entry)
    except OSError:
        return None
    path = _record_path(key)
    try:
        recorded = json.loads(path.read_text())
        files = dict(recorded["files"])
        if recorded["entry"] != entry.name:
            # PoCL filed the program under another entry (its cache was cleared or
            # rebuilt): a record of one entry says nothing of another; trust anew.
            files = {}
    except (OSError, ValueError, KeyError, TypeError):
        files = {}
    rebuilt = False
    for name, digest in files.items():
        if name == "program.bc" and name in now and now[name] != digest and (
                ":" not in digest or rebuilt_alike(digest, now[name])):
            # PoCL rebuilt the program into its entry (another process, the same instant),
            # or the record predates fingerprints (a whole-file digest): record it anew
            rebuilt = True
        elif name in now and now[name] != digest:
            return (f"PoCL's kernel cache entry {str(entry)!r} does not hold the program mcocl built there "
                    f"({name} changed since it was first built: a corrupt or swapped cache entry)")
    if rebuilt:
        files["program.bc"] = now["program.bc"]
    if rebuilt or not files or any(name not in files for name in now):
        files.update({k: v for k, v in now.items() if k not in files})
        _write_atomically(path, json.dumps({"entry": entry.name, "files": files}, sort_keys=True))
    return None


def _write_atomically(path: Path, text: str) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".rec-")
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except OSError:  # a read-only cache: the check is a defence, not a requirement
        pass


__all__ = ["RECORDS", "bitcode_fingerprint", "check_entry", "entry_used", "rebuilt_alike", "record_key"]
