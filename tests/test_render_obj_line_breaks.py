"""OBJ line breaks and whitespace normalised a chunk at a time (mcocl/render/obj_reader.py, issue 13).

- the same mesh written with \\n, \\r\\n, \\r alone, tabs and no final break reads
  as the same arrays in one chunk and in many;
- a bad record in a late chunk of a \\r\\n file is refused naming its line.
"""

from __future__ import annotations

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render import obj_reader
from mcocl.render.obj_reader import parse_obj

RNG = np.random.default_rng(4)
V = RNG.standard_normal((200, 3)).round(4)
T = RNG.integers(0, 200, (300, 3))


def text(brk: str = "\n", sep: str = " ") -> bytes:
    """The mesh with ``vt``/``vn`` records and ``i/i/i`` corners, lines ended by ``brk``, fields by ``sep``."""
    lines = ["# a comment", *(f"v{sep}{a}{sep}{b}{sep}{c}" for a, b, c in V),
             *(f"vt {a} {b}" for a, b, _ in V), *(f"vn{sep}{c} {a} {b}" for a, b, c in V),
             *("f " + " ".join(f"{i + 1}/{i + 1}/{i + 1}" for i in t) for t in T)]
    return brk.join(lines).encode()  # no final break


@pytest.mark.parametrize("chunk", [None, 64, 1000])
@pytest.mark.parametrize("brk, sep", [("\r\n", " "), ("\r", " "), ("\n", "\t"), ("\r\n", "\t \f")])
def test_line_breaks_read_as_plain_newlines(monkeypatch, chunk, brk, sep):
    want = parse_obj(text() + b"\n", "plain.obj")
    if chunk:
        monkeypatch.setattr(obj_reader, "CHUNK_BYTES", chunk)
    got = parse_obj(text(brk, sep), "m.obj")
    for a, b in zip(got, want):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("chunk", [None, 64])
def test_a_bad_record_in_a_late_chunk_names_its_line(monkeypatch, chunk):
    if chunk:
        monkeypatch.setattr(obj_reader, "CHUNK_BYTES", chunk)
    lines = text("\r\n").split(b"\r\n")
    lines[580] = b"vn 1 2 x"  # line 581: a normal
    with pytest.raises(InputError, match=r"^m\.obj:581: a normal needs three numbers"):
        parse_obj(b"\r\n".join(lines), "m.obj")
    lines[580] = b"vn 0 0 1"
    lines[-2] = b"f 1/1/1 2/2/2 201/1/1"
    with pytest.raises(InputError, match=rf"^m\.obj:{len(lines) - 1}: face index 200 is outside 0\.\.199"):
        parse_obj(b"\r\n".join(lines), "m.obj")
