"""Every bad file or number is an InputError naming it, never a traceback (issue 10, classes 3 and 4).

Checkpoints: truncated, empty, bit-flipped, edited or not a checkpoint at all.
Data files: not UTF-8, nested 100,000 deep.  Numbers past what the kernels
take.  And messages that tell the truth (an image is "not a checkpoint", an
unusable PoCL cache is not "failed to compile", ``mcocl devices`` exits 2).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import mcocl
from mcocl import runtime
from mcocl.accumulate import Accumulator
from mcocl.bench.problems import load_problem_file
from mcocl.cli import main
from mcocl.errors import DeviceError, InputError
from mcocl.render.scene import check_integrator_settings
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
POLY = "x[0]*x[0] + 0.5f"


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("ckpt") / "run.npz"
    mcocl.integrate(POLY, samples=1 << 14, seed=3, checkpoint=str(path))
    return path


def _damaged(tmp_path: Path, data: bytes) -> str:
    p = tmp_path / "bad.npz"
    p.write_bytes(data)
    return str(p)


def test_damaged_checkpoints_are_refused(checkpoint, tmp_path):
    raw = checkpoint.read_bytes()
    cases = {
        "empty": b"",
        "truncated": raw[: len(raw) // 2],
        "header only": raw[:30],
        "an image": b"\x89PNG\r\n\x1a\n" + bytes(100),
        "a pickle": b"\x80\x04\x95" + bytes(40),
    }
    for k in (100, 200, len(raw) // 3, len(raw) // 2, len(raw) - 30):  # bit flips in headers, data, directory
        flipped = bytearray(raw)
        flipped[k] ^= 0x10
        cases[f"bit flip at {k}"] = bytes(flipped)
    for what, data in cases.items():
        with pytest.raises(InputError, match=r"checkpoint .*bad\.npz") as ei:
            mcocl.integrate(POLY, samples=1 << 15, seed=3, resume=_damaged(tmp_path, data))
        assert "pickled" not in str(ei.value), what
    assert mcocl.integrate(POLY, samples=1 << 15, seed=3, resume=str(checkpoint)).samples == 1 << 15


@pytest.mark.parametrize(("key", "value"), [("shift", 1e300), ("shift", None), ("design", {"sampler": "x"}),
                                            ("design", None), ("unit_limit", 1e300)])
def test_edited_checkpoint_fields_are_refused(checkpoint, tmp_path, key, value):
    acc = Accumulator.load(checkpoint)
    acc.meta[key] = value
    acc.meta["partial_tail"] = True
    path = tmp_path / "edited.npz"
    acc.save(path)  # a consistent digest: only the field checks stand between it and the run
    with pytest.raises(InputError, match=rf"edited\.npz.*{key}"):
        mcocl.integrate(POLY, samples=1 << 14, seed=3, resume=str(path))
    # an edit that keeps the old digest (a well-formed archive) is refused by the digest
    with np.load(checkpoint) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["shift"] = meta["shift"] + 1.0
    arrays["meta"] = np.array(json.dumps(meta, sort_keys=True))
    with open(tmp_path / "forged.npz", "wb") as fh:
        np.savez(fh, **arrays)
    with pytest.raises(InputError, match="digest does not match"):
        mcocl.integrate(POLY, samples=1 << 14, seed=3, resume=str(tmp_path / "forged.npz"))


def test_resume_from_an_image_says_it_is_not_a_checkpoint(tmp_path, capsys):
    img = tmp_path / "image.exr"
    img.write_bytes(b"v/1\x01" + bytes(200))
    assert main(["integrate", POLY, "--resume", str(img)]) == 2
    err = capsys.readouterr().err
    assert "is not an mcocl checkpoint" in err and "pickled" not in err


DEEP = "[" * 100_000 + "]" * 100_000


@pytest.mark.parametrize(("data", "words"), [
    (b"\xff\xfe{\x00}", "not UTF-8 text"),
    (DEEP.encode(), "nested too deeply"),
    (b'{"camera": ' + ("[" * 100_000).encode(), "nested too deeply"),
])
def test_unreadable_data_files_are_input_errors(tmp_path, data, words):
    p = tmp_path / "f.json"
    p.write_bytes(data)
    with pytest.raises(InputError, match=words):
        load_scene(p)
    with pytest.raises(InputError, match=words):
        load_problem_file(p)


def test_numbers_past_what_the_kernels_take(tmp_path):
    scene = json.loads((SCENES / "cornell.json").read_text())
    for edit, where in [
        (lambda s: s["integrator"].update(max_depth=10**12), "integrator.max_depth"),
        (lambda s: s["camera"].update(width=100_000, height=100_000), "camera.width"),
        (lambda s: s["shapes"][0].update(transform=[{"translate": [-3.4e38, 0, 0]}]), r"translate\[0\]"),
        (lambda s: s["shapes"][0].update(transform=[{"scale": 1e10}, {"scale": 1e10}]), "transform"),
    ]:
        s = json.loads(json.dumps(scene))
        edit(s)
        p = tmp_path / "s.json"
        p.write_text(json.dumps(s))
        with pytest.raises(InputError, match=where):
            load_scene(p)
    mesh = {"type": "mesh", "material": next(iter(scene["materials"])), "vertices": [[0, 0, 0]] * 3,
            "faces": [[0, 1, 10**23]]}
    p.write_text(json.dumps({**scene, "shapes": [mesh]}))
    with pytest.raises(InputError, match=r"faces\[0\]"):
        load_scene(p)
    with pytest.raises(InputError, match="max_depth"):
        check_integrator_settings("mis", 99_999_999_999, 5, 64)
    with pytest.raises(InputError, match="samples"):
        mcocl.integrate(POLY, samples=1e30)
    with pytest.raises(InputError, match="seed"):
        mcocl.integrate(POLY, samples=10, seed=2**64)


def test_cli_numbers_exit_2_with_one_line(capsys, tmp_path):
    for argv, word in ((["integrate", POLY, "--samples", "1e30"], "samples"),
                       (["render", str(SCENES / "cornell.json"), "--max-depth", "99999999999",
                         "--out", str(tmp_path / "x.exr")], "max_depth")):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err and word in err
    assert not list(tmp_path.iterdir())


def test_mcocl_lanes_must_be_a_number(monkeypatch):
    dev = runtime.select_device()
    monkeypatch.setenv("MCOCL_LANES", "abc")
    with pytest.raises(InputError, match="MCOCL_LANES"):
        runtime.default_lanes(dev)


def test_devices_without_a_device_exits_2(monkeypatch, capsys):
    monkeypatch.setattr(runtime, "list_devices", lambda: [])
    assert main(["devices"]) == 2
    assert "no OpenCL device" in capsys.readouterr().err


def test_an_unusable_pocl_cache_is_named(monkeypatch, tmp_path):
    from mcocl.pocl_cache import cache_problem

    (tmp_path / "file").write_text("x")
    monkeypatch.setenv("POCL_CACHE_DIR", str(tmp_path / "file" / "kcache"))
    assert "POCL_CACHE_DIR" in cache_problem("Portable Computing Language")
    assert cache_problem("NVIDIA CUDA") is None
    monkeypatch.setenv("POCL_CACHE_DIR", str(tmp_path / "ok"))
    assert cache_problem("Portable Computing Language") is None
    # a build that fails while the cache is unusable reports the cache, not the code
    monkeypatch.setattr(runtime, "cache_problem", lambda name: "PoCL's kernel cache folder is not writable")
    ctx = runtime.device_context(None)
    with pytest.raises(DeviceError, match="kernel cache folder"):
        runtime.build(ctx, "__kernel void k(__global float* a) { a[0] = undefined_name; }")


def test_obj_face_index_past_int64_is_an_input_error(tmp_path):
    (tmp_path / "big.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 100000000000000000000000\n")
    scene = json.loads((SCENES / "cornell.json").read_text())
    mesh = {"type": "mesh", "material": next(iter(scene["materials"])), "obj": "big.obj"}
    p = tmp_path / "s.json"
    p.write_text(json.dumps({**scene, "shapes": [mesh]}))
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj"):
        load_scene(p)


def test_bench_budget_past_a_day_is_refused(capsys):
    with pytest.raises(SystemExit) as ei:
        main(["bench", "--budget", "1e30", "integrate"])
    assert ei.value.code == 2 and "at most 86400 seconds" in capsys.readouterr().err


@pytest.mark.parametrize("exposure", [1e30, -1e30, float("nan"), float("inf"), "2", True])
def test_png_exposure_out_of_range_is_an_input_error(exposure, tmp_path):
    from mcocl.render.image_io import srgb_encode, write_png

    with pytest.raises(InputError, match="exposure must be a finite number of stops between -64 and 64"):
        srgb_encode(np.ones((2, 2, 3)), exposure=exposure)
    with pytest.raises(InputError, match="exposure"):
        write_png(tmp_path / "x.png", np.ones((2, 2, 3)), exposure)
    assert not list(tmp_path.iterdir())
    assert srgb_encode(np.full((1, 1, 3), 2.0**-64), exposure=64.0)[0, 0, 0] == 255
