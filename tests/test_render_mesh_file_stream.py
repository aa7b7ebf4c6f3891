"""OBJ and PLY files read from the open file a chunk at a time (issue 13: the file's bytes never held whole).

- read_obj / read_ply of a file give the same arrays (dtype, shape, bytes) and
  the same errors as parsing the file's bytes, at chunk sizes that cut the file
  into many pieces;
- the file is not read whole (read_regular_file is not called; an ASCII PLY's
  body is not read by the whole-body parse);
- a named pipe is refused without blocking, a folder and a missing file name
  their reason, as read_regular_file's callers did.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from mcocl import datafile
from mcocl.errors import InputError
from mcocl.render import obj_reader, ply_reader, shapes

OBJ = (b"# mesh\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nvt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvn 0 0 1\r\n"
       b"g a\r\nusemtl m\r\nf 1/1/1 2/2/1 3/3/1 4/1/1\r\nf -4/1/1 -3/2/1 -2/3/1")
PLY = (b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
       b"element face 3\nproperty list uchar int vertex_indices\nend_header\n"
       b"0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n4 0 1 2 3\n3 2 3 0\n")


def same(a, b) -> bool:
    """Whether two meshes hold equal arrays (dtype, shape and bytes), None where one is None."""
    return all((x is None and y is None) or (x is not None and y is not None and x.dtype == y.dtype
                                              and x.shape == y.shape and x.tobytes() == y.tobytes())
               for x, y in zip((a.vertices, a.faces, a.normals, a.uvs), (b.vertices, b.faces, b.normals, b.uvs)))


@pytest.fixture
def no_whole_read(monkeypatch):
    """Fail a test that reads its mesh file whole."""
    def refuse(path):
        raise AssertionError(f"{path} read whole")
    monkeypatch.setattr(datafile, "read_regular_file", refuse)
    monkeypatch.setattr(shapes, "read_regular_file", refuse, raising=False)


def same_error(read, parse, path) -> str:
    """The error of reading ``path`` as a file, asserted equal to that of parsing its bytes."""
    with pytest.raises(InputError) as got:
        read(path, "k")
    with pytest.raises(InputError) as ref:
        parse(path.read_bytes(), f"k: {path}")
    assert str(got.value) == str(ref.value)
    return str(got.value)


@pytest.mark.parametrize("chunk", [1 << 21, 16, 5])
def test_obj_file_reads_as_its_bytes(tmp_path, monkeypatch, no_whole_read, chunk):
    p = tmp_path / "m.obj"
    p.write_bytes(OBJ)
    monkeypatch.setattr(obj_reader, "CHUNK_BYTES", chunk)
    want = shapes.PlyMesh(*obj_reader.parse_obj(OBJ, f"k: {p}"))
    assert same(shapes.read_obj(p, "k"), want)
    p.write_bytes(OBJ.replace(b"f -4", b"f -9"))
    assert ":13:" in same_error(shapes.read_obj, obj_reader.parse_obj, p)


@pytest.mark.parametrize("chunk", [1 << 18, 16, 3])
def test_ascii_ply_file_streams_as_its_bytes(tmp_path, monkeypatch, no_whole_read, chunk):
    p = tmp_path / "m.ply"
    p.write_bytes(PLY)
    monkeypatch.setattr(ply_reader, "ASCII_CHUNK_BYTES", chunk)
    want = ply_reader.parse_ply(PLY, f"k: {p}")
    monkeypatch.setattr(ply_reader, "_parse_ply_bytes", lambda *a, **k: pytest.fail("read whole"))
    got = shapes.read_ply(p, "k")
    assert same(got, want) and len(got.faces) == 4


def test_a_ply_the_stream_leaves_is_read_whole_with_the_same_error(tmp_path):
    p = tmp_path / "bad.ply"
    p.write_bytes(PLY.replace(b"3 2 3 0", b"2 2 3"))
    assert "face 2 has 2 corners" in same_error(shapes.read_ply, ply_reader.parse_ply, p)


@pytest.mark.parametrize("read, kind", [(shapes.read_obj, "OBJ"), (shapes.read_ply, "PLY")])
def test_pipes_folders_and_missing_files_are_refused(tmp_path, read, kind):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for path, reason in ((fifo, "not a regular file"), (tmp_path, "Is a directory"),
                         (tmp_path / "none", "No such file or directory")):
        with pytest.raises(InputError, match=f"cannot read {kind} file .*{reason}"):
            read(path, "k")


def test_open_regular_file_refuses_a_device():
    with pytest.raises(OSError, match="not a regular file"):
        datafile.open_regular_file("/dev/zero")


def _triangles_ply(order: str, n: int, vertex_type: str = "f4", index: str = "i4") -> bytes:
    """A binary PLY of ``n`` random triangles over ``n // 2`` vertices, one record layout per element."""
    from test_render_ply import header

    rng = np.random.default_rng(n)
    rec = np.zeros(n, np.dtype([("c", "u1"), ("i", order + index, (3,))]))
    rec["c"], rec["i"] = 3, rng.integers(0, n // 2, (n, 3))
    verts = rng.standard_normal((n // 2, 3)).astype(order + vertex_type)
    kind = {"f4": "float", "f8": "double"}[vertex_type]
    vprops = f"{kind} x\nproperty {kind} y\nproperty {kind} z"
    names = {"i4": "int", "u4": "uint", "i2": "short"}
    return (header({"<": "binary_little_endian", ">": "binary_big_endian"}[order], n // 2, n, vprops,
                   f"list uchar {names[index]} vertex_indices") + verts.tobytes() + rec.tobytes())


def _binary_plys() -> list[tuple[bytes, bool]]:
    """(a binary PLY, whether its elements each have one record size: read element by element)."""
    from test_render_ply import binary_ply

    return [(binary_ply("<"), False), (binary_ply(">"), False),  # faces of differing lengths: read whole
            (binary_ply("<", [[0, 1, 2, 3], [2, 3, 4, 5], [5, 4, 1, 0]]), True),  # quads: fans, with the edges
            (binary_ply(">", [[0, 1, 2], [2, 3, 4]], count="i2", index="u4"), True),
            (_triangles_ply("<", 30_000), True), (_triangles_ply(">", 3_000, "f8", "i2"), True),
            (_triangles_ply("<", 3_000, index="u4"), True)]


@pytest.mark.parametrize("piece", [1 << 20, 1000, 1])
@pytest.mark.parametrize("case", range(7))
def test_binary_ply_file_reads_element_by_element_as_its_bytes(tmp_path, monkeypatch, no_whole_read, case, piece):
    data, by_elements = _binary_plys()[case]
    monkeypatch.setattr(ply_reader, "BINARY_PIECE_BYTES", piece)  # 1: a record at a time
    p = tmp_path / "m.ply"
    p.write_bytes(data)
    want = ply_reader.parse_ply(data, f"k: {p}")
    if by_elements:  # the whole-file parse is not reached
        monkeypatch.setattr(ply_reader, "_parse_ply_bytes", lambda *a, **k: pytest.fail("read whole"))
    assert same(shapes.read_ply(p, "k"), want)


def _face_count(data: bytes, face: int, count: int) -> bytes:
    """``data`` (a :func:`_triangles_ply` of 1,500 float vertices) with face ``face``'s corner count set to ``count``."""
    at = data.index(b"end_header\n") + 11 + 1500 * 12 + 13 * face
    return data[:at] + bytes([count]) + data[at + 1:]


@pytest.mark.parametrize("cut", [
    lambda d: d.replace(b"element vertex 1500", b"element vertex 1501"),
    lambda d: d.replace(b"element face 3000", b"element face 2999"),
    lambda d: d.replace(b"element face 3000", b"element face 3001"),
    lambda d: d[:-7],
    lambda d: d + b"\0",
    lambda d: _face_count(d, 1, 2),  # a face of 2 corners (its record shorter: the layouts differ)
    lambda d: _face_count(d, 5, 0),
    lambda d: _face_count(d, 0, 200),  # the first record's lists overrun the first look at the element
])
@pytest.mark.parametrize("piece", [1 << 20, 1000])
def test_binary_ply_errors_as_its_bytes(tmp_path, monkeypatch, cut, piece):
    monkeypatch.setattr(ply_reader, "BINARY_PIECE_BYTES", piece)
    p = tmp_path / "bad.ply"
    p.write_bytes(cut(_triangles_ply("<", 3_000)))
    same_error(shapes.read_ply, ply_reader.parse_ply, p)


@pytest.mark.parametrize("bad", [None, 0, 5, 6, 7, 1000, -1])
def test_utf8_check_a_block_at_a_time_as_of_the_bytes(tmp_path, monkeypatch, bad):
    """datafile.check_utf8_file (the OBJ key's check) gives decode_utf8's verdict and message for the whole
    file, with blocks of 7 bytes cutting 2-, 3- and 4-byte characters, and a bad byte anywhere."""
    text = bytearray("v 0 0 0 # é\n€ x\n\U0001f600 é€\n".encode() * 40)
    if bad is not None:
        text[bad] = 0xFF
    if bad == 1000:
        text[bad - 1:bad + 1] = b"\xe2\x82"  # a character cut short by an ASCII byte
    p = tmp_path / "m.obj"
    p.write_bytes(bytes(text))
    monkeypatch.setattr(datafile, "UTF8_BLOCK", 7)
    try:
        datafile.decode_utf8(bytes(text), "k")
    except InputError as e:
        with pytest.raises(InputError) as got:
            datafile.check_utf8_file(p, "k")
        assert str(got.value) == str(e)
    else:
        datafile.check_utf8_file(p, "k")
    p.write_bytes(bytes(text) + b"\xe2\x82")  # the file ends inside a character
    with pytest.raises(InputError) as got:
        datafile.check_utf8_file(p, "k")
    with pytest.raises(InputError) as ref:
        datafile.decode_utf8(bytes(text) + b"\xe2\x82", "k")
    assert str(got.value) == str(ref.value)
