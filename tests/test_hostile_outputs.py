"""Outputs are checked before any work starts, inputs are never overwritten (issue 10, class 2).

Every case here must fail in well under a second: the check comes before the
scene is compiled or a sample is drawn, so a slow test would mean work ran
first.  Writes go through unique temporary names, so writers of one file
never collide.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mcocl.accumulate import Accumulator
from mcocl.cli import main
from mcocl.output_files import write_atomically

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell.json"


def _render(tmp_path: Path, *extra: str) -> tuple[int, float]:
    t0 = time.perf_counter()
    status = main(["render", str(SCENE), "--spp", "100000", "--quiet", *extra])
    return status, time.perf_counter() - t0


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--out", "{tmp}/missing/x.exr"], ["--out", "does not exist"]),
        (["--out", "{tmp}"], ["--out", "is a folder"]),
        (["--out", "{tmp}/a.exr", "--png", "{tmp}/missing/p.png"], ["--png", "does not exist"]),
        (["--out", "{tmp}/a.exr", "--checkpoint", "{tmp}/missing/c.npz"], ["--checkpoint", "does not exist"]),
        (["--out", "{tmp}/a.exr", "--png", "{tmp}/a.exr"], ["--out and --png name the same file"]),
        (["--out", "{tmp}/a.exr", "--checkpoint", "{tmp}/a.exr"], ["--out and --checkpoint name the same file"]),
        (["--out", str(SCENE)], ["--out", "is the scene, an input"]),
        (["--out", "{tmp}/a.exr", "--png", str(SCENE)], ["--png", "is the scene, an input"]),
        (["--out", "{tmp}/a.exr", "--resume", "{tmp}/missing.npz"], ["--resume", "no such checkpoint"]),
        (["--out", "{tmp}/ro/a.exr"], ["--out", "not writable"]),
    ],
)
def test_render_outputs_are_checked_before_work(args, words, tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    if os.access(ro, os.W_OK) and "ro" in " ".join(args):
        pytest.skip("running as root: a read-only folder is writable")
    before = SCENE.read_bytes()
    status, seconds = _render(tmp_path, *[a.replace("{tmp}", str(tmp_path)) for a in args])
    err = capsys.readouterr().err
    assert status == 2
    assert "Traceback" not in err and err.count("\n") == 1
    for w in words:
        assert w in err
    assert seconds < 5.0  # nothing was rendered (100000 spp would take minutes)
    assert SCENE.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ro"]


def test_bench_out_is_checked_before_work(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    assert main(["bench", "integrate", "--budget", "100", "--out", str(tmp_path / "file")]) == 2
    assert "--out" in capsys.readouterr().err
    assert (tmp_path / "file").read_text() == "x"


def test_integrate_checkpoint_is_checked_before_work(tmp_path, capsys):
    assert main(["integrate", "x[0]", "--samples", "1e12", "--checkpoint", str(tmp_path / "no" / "c.npz")]) == 2
    assert "--checkpoint" in capsys.readouterr().err


def test_concurrent_writers_of_one_checkpoint_never_collide(tmp_path):
    path = tmp_path / "shared.npz"
    errors: list[BaseException] = []

    def writer(value: float) -> None:
        acc = Accumulator((64,), {"kind": "test"})
        acc.totals[:] = value
        try:
            for _ in range(30):
                acc.save(path)
        except BaseException as e:  # noqa: BLE001 - collected for the assertion
            errors.append(e)

    threads = [threading.Thread(target=writer, args=(v,)) for v in (1.0, 2.0, 3.0)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    back = Accumulator.load(path)
    assert back.totals[0] in (1.0, 2.0, 3.0) and np.all(back.totals == back.totals[0])
    assert [p.name for p in tmp_path.iterdir()] == ["shared.npz"]  # no temporary file left


def test_failed_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "out.txt"
    path.write_text("old")

    def fail(tmp: Path) -> None:
        tmp.write_text("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomically(path, fail)
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_api_checkpoint_is_checked_before_work(tmp_path):
    import mcocl
    from mcocl.errors import InputError

    t0 = time.perf_counter()
    with pytest.raises(InputError, match="checkpoint.*does not exist"):
        mcocl.integrate("x[0]", samples=1 << 40, checkpoint=str(tmp_path / "no" / "c.npz"))
    with pytest.raises(InputError, match="checkpoint.*is a folder"):
        mcocl.render(SCENE, spp=100000, checkpoint=str(tmp_path))
    assert time.perf_counter() - t0 < 5.0


def test_convert_never_overwrites_its_scene(tmp_path, capsys):
    xml = tmp_path / "s.xml"
    xml.write_bytes((SCENE.parent / "xml" / "cornell.xml").read_bytes())
    before = xml.read_bytes()
    assert main(["convert", str(xml), "-o", str(xml)]) == 2
    assert "is the scene, an input" in capsys.readouterr().err
    assert xml.read_bytes() == before
    assert main(["convert", str(xml), "-o", str(tmp_path / "missing" / "o.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.xml"]


@pytest.mark.parametrize("option", ["--out", "--png", "--checkpoint"])
def test_outputs_replace_only_files_of_their_own_kind(option, tmp_path, capsys):
    """--out quad.obj replaced the scene's mesh with an image (exit 0): an existing file is now replaced
    only when it is empty or an earlier output of the same kind (EXR, PNG, checkpoint)."""
    mesh = tmp_path / "quad.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    args = {"--out": str(tmp_path / "a.exr"), option: str(mesh)}
    status, seconds = _render(tmp_path, *[x for kv in args.items() for x in kv])
    err = capsys.readouterr().err
    assert status == 2 and "exists and is not" in err and "mcocl replaces only its own earlier outputs" in err
    assert mesh.read_text().startswith("v 0 0 0") and seconds < 5.0
    assert main(["integrate", "x[0]", "--samples", "1e12", "--checkpoint", str(mesh)]) == 2
    assert "is not an mcocl checkpoint" in capsys.readouterr().err


def test_earlier_outputs_are_replaced(tmp_path):
    furnace = SCENE.parent / "furnace.json"
    files = [str(tmp_path / n) for n in ("f.exr", "f.png", "f.npz")]
    argv = ["render", str(furnace), "--spp", "1", "--quiet", "--out", files[0], "--png", files[1], "--checkpoint",
            files[2]]
    assert main(argv) == 0
    (tmp_path / "empty.exr").write_bytes(b"")
    assert main([*argv[:-6], "--out", str(tmp_path / "empty.exr")]) == 0
    assert main(argv) == 0  # a second run replaces its own outputs
