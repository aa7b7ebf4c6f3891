"""``mcocl render``: images written, JSON summary, Ctrl-C, bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from interrupting import ctrl_c_render_cli

from mcocl.render.image_io import read_exr

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def mcocl(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mcocl", *args], capture_output=True, text=True, timeout=300, **kw)


def test_render_writes_exr_and_png(tmp_path: Path) -> None:
    out, png = tmp_path / "f.exr", tmp_path / "f.png"
    p = mcocl("render", str(SCENES / "furnace.json"), "--spp", "4", "--max-depth", "3", "--out", str(out),
              "--png", str(png), "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["spp"] == 4 and d["integrator"] == "mis" and d["max_depth"] == 3 and d["out"] == str(out)
    img = read_exr(out)
    assert img.mean.shape == (24, 32, 3) and img.variance is not None
    assert np.all(img.samples == 4)
    np.testing.assert_allclose(img.mean.mean(axis=(0, 1)), [0.488, 0.875, 0.992], rtol=0.05)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert img.metadata.get("integrator") == "mis"


def test_ctrl_c_writes_the_image_so_far_and_exits_130(tmp_path: Path) -> None:
    out = tmp_path / "c.exr"
    # independent: every pixel has the same samples at a stop (a sobol batch of 25,000 spp would be cut
    # into pixel ranges, and a stop inside it leaves the ranges not reached without a batch)
    code, _, err = ctrl_c_render_cli([str(SCENES / "cornell.json"), "--spp", "100000", "--sampler", "independent",
                                      "--out", str(out)])
    assert code == 130, err
    img = read_exr(out)
    assert img.mean.shape == (256, 256, 3)
    spp = int(img.samples.max())
    assert 0 < spp < 100000 and np.all(img.samples == spp)
    assert np.all(np.isfinite(img.mean)) and img.mean.mean() > 0.05


def test_bad_scene_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"camera": {"origin": [0, 0, 1], "target": [0, 0, 0], "fov": 40, "width": 4,
                                          "height": 4}, "shapes": [{"type": "sphere", "material": "nope"}]}))
    p = mcocl("render", str(bad), "--spp", "1", "--out", str(tmp_path / "x.exr"))
    assert p.returncode == 2
    assert "shapes[0].material" in p.stderr and "Traceback" not in p.stderr
    p = mcocl("render", str(SCENES / "furnace.json"), "--integrator", "photon")
    assert p.returncode == 2 and "invalid choice" in p.stderr
