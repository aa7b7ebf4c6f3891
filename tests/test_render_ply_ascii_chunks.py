"""The ASCII PLY body read a chunk of lines at a time (mcocl/render/ply_reader.py, issue 13).

- a file spread over many chunks (normals, UVs, colours, quads, an extra element,
  blank lines, tabs, a line longer than a chunk) reads as the same arrays, dtypes
  and values as the whole-body parse, and the chunked read is what produced them;
- faults in a late chunk (a non-number, a non-integer index, a truncated body,
  numbers left over, a face of two corners) give the whole-body parse's error,
  naming the file.
"""

from __future__ import annotations

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render import ply_reader
from mcocl.render.ply_reader import parse_ply

RNG = np.random.default_rng(11)
NV, NF = 300, 400
VERTS = RNG.standard_normal((NV, 8))
QUADS = RNG.integers(0, NV, (NF, 4))
HEAD = ("ply\nformat ascii 1.0\nelement vertex {nv}\n" + "".join(f"property float {p}\n" for p in
        ("x", "y", "z", "nx", "ny", "nz", "u", "v")) + "property uchar red\nelement face {nf}\n"
        "property list uchar int vertex_indices\nelement edge 2\nproperty int a\nproperty int b\nend_header\n")


def body(faces: list[str], nf: int | None = None, blank: bool = False) -> bytes:
    """An ASCII PLY of the vertices (one very long line among them, followed by a blank line if
    ``blank``) and the given face lines."""
    rows = [" ".join(f"{x:.17g}" for x in r) + f"\t{k % 256}\n" for k, r in enumerate(VERTS)]
    rows[100] = rows[100].rstrip("\n") + " " * 300 + ("\n\n" if blank else "\n")
    text = HEAD.format(nv=NV, nf=len(faces) if nf is None else nf) + "".join(rows) + "".join(faces) + "1 2\n3 4\n"
    return text.encode()


def quads() -> list[str]:
    """One face line per quad."""
    return ["4 " + " ".join(map(str, q)) + "\n" for q in QUADS]


def whole_body(data: bytes, monkeypatch) -> ply_reader.PlyMesh:
    """The mesh as the whole-body parse reads it (the chunked read refused)."""
    with monkeypatch.context() as m:
        def refuse(*args):
            raise ply_reader._UnstreamedError
        m.setattr(ply_reader, "_parse_ascii_streamed", refuse)
        return parse_ply(data, "whole.ply")


@pytest.mark.parametrize("blank", [False, True])
def test_many_chunks_read_as_the_whole_body(monkeypatch, blank):
    # A blank line among the vertices puts the section boundary out of the line count's reach:
    # the chunked read declines and the whole-body parse reads the file, to the same arrays.
    data = body(quads(), blank=blank)
    ref = whole_body(data, monkeypatch)
    monkeypatch.setattr(ply_reader, "ASCII_CHUNK_BYTES", 64)
    outcomes = []
    real = ply_reader._parse_ascii_streamed

    def recorded(*args):
        try:
            out = real(*args)
        except ply_reader._UnstreamedError:
            outcomes.append("declined")
            raise
        outcomes.append("streamed")
        return out
    monkeypatch.setattr(ply_reader, "_parse_ascii_streamed", recorded)
    got = parse_ply(data, "chunks.ply")
    assert outcomes == ["declined" if blank else "streamed"] and got.faces.shape == (2 * NF, 3)
    for name in ("vertices", "faces", "normals", "uvs"):
        a, b = getattr(got, name), getattr(ref, name)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name


@pytest.mark.parametrize("last, nf, message", [
    ("4 1 2 x 3\n", None, "not a number"),
    ("4 1 2 2.5 3\n", None, "not an integer"),
    ("4 1 2 3 4\n", NF + 1, "overrun"),
    ("4 1 2 3 4 5\n", None, "after the last element"),
    ("2 1 2\n", None, f"face {NF - 1} has 2 corners"),
])
def test_faults_in_a_late_chunk_give_the_whole_body_error(monkeypatch, last, nf, message):
    data = body(quads()[:-1] + [last], nf)
    with pytest.raises(InputError) as ref:
        whole_body(data, monkeypatch)
    monkeypatch.setattr(ply_reader, "ASCII_CHUNK_BYTES", 64)
    with pytest.raises(InputError) as got:
        parse_ply(data, "whole.ply")
    assert str(got.value) == str(ref.value)
    assert str(got.value).startswith("whole.ply: ") and message in str(got.value)


@pytest.mark.parametrize("faces", ["3 0 1 2 4 0 1 2 3\n3 1 2 3 4 3 2 1 0\n", "4 0 1 2 3 3 0 1 2\n4 1 2 3 0 3 1 2 3\n"])
def test_two_lists_of_one_name_read_the_last_as_the_whole_body(monkeypatch, faces):
    data = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 2\nproperty list uchar int vertex_indices\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" + faces).encode()
    ref = whole_body(data, monkeypatch)
    got = parse_ply(data, "dup.ply")
    assert got.faces.dtype == ref.faces.dtype and np.array_equal(got.faces, ref.faces)
    assert np.array_equal(got.vertices, ref.vertices)


def mixed() -> list[str]:
    """Face lines of differing lengths: every third a triangle (its quad's first three corners), else a quad."""
    return [("3 " + " ".join(map(str, q[:3])) if k % 3 == 1 else "4 " + " ".join(map(str, q))) + "\n"
            for k, q in enumerate(QUADS)]


def test_faces_of_differing_lengths_stream_as_the_whole_body(monkeypatch):
    data = body(mixed()).replace(b"\n\n", b"\n")  # (a blank line leaves the body to the whole-body parse)
    ref = whole_body(data, monkeypatch)
    monkeypatch.setattr(ply_reader, "ASCII_CHUNK_BYTES", 64)
    polygons = []
    real = ply_reader._stream_polygons
    monkeypatch.setattr(ply_reader, "_stream_polygons", lambda *a: polygons.append(1) or real(*a))
    got = parse_ply(data, "mixed.ply")
    assert polygons and got.faces.shape == (2 * NF - len(range(1, NF, 3)), 3)
    for name in ("vertices", "faces", "normals", "uvs"):
        a, b = getattr(got, name), getattr(ref, name)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name


@pytest.mark.parametrize("last, nf, message", [
    ("4 1 2 x 3\n", None, "not a number"),
    ("4 1 2 3 4\n", NF + 1, "overrun"),
    ("4 1 2 3 4 5\n", None, "after the last element"),
    ("2 1 2\n", None, f"face {NF - 1} has 2 corners"),
    ("70000 1 2 3\n", None, "overrun"),
])
def test_faults_among_faces_of_differing_lengths_give_the_whole_body_error(monkeypatch, last, nf, message):
    data = body(mixed()[:-1] + [last], nf).replace(b"\n\n", b"\n")
    with pytest.raises(InputError) as ref:
        whole_body(data, monkeypatch)
    monkeypatch.setattr(ply_reader, "ASCII_CHUNK_BYTES", 64)
    with pytest.raises(InputError) as got:
        parse_ply(data, "whole.ply")
    assert str(got.value) == str(ref.value) and message in str(got.value)
