"""The ``sobol`` render's blocks: pixel ranges of a batch (mcocl/render/sobol_film.py, "Blocks and batches").

- sobol_block_pixels cuts a batch of more paths than an independent block into
  T ranges of whole work-item tiles, about one independent block each, and
  leaves smaller batches whole (T = 1).
- The image is bit-identical whatever T (whole-film blocks, the default cut, an
  uneven cut with a short last range), with launch splits, and after an
  interrupt inside a batch and a resume; a checkpoint without the key (whole-film
  blocks, as before the cut) resumes with whole-film blocks and the same bits.
- An interrupt inside a batch leaves per-pixel counts one batch apart, and the
  film handles pixels of fewer than 2 batches (variance NaN, left out of the error).
- Ctrl-C of a CLI sobol render of 2^24-path batches writes the image so far.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest
from device_doubles import small_cornell
from interrupting import ctrl_c_render_cli, interrupt_after_first_fold

from mcocl.accumulate import Accumulator
from mcocl.render import api
from mcocl.render.image_io import read_exr
from mcocl.render.job import TILE_PIXELS, default_spp_per_block
from mcocl.render.sobol_film import sobol_block_pixels

SCENES = Path(__file__).resolve().parent.parent / "scenes"
ROOT = Path(__file__).resolve().parent.parent



def same_image(a, b) -> None:
    """Bit-identical mean, variance and counts."""
    np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(a.variance, b.variance)
    np.testing.assert_array_equal(a.count, b.count)


def test_block_pixels_cut_big_batches_into_independent_block_sizes() -> None:
    w = h = 256
    paths = default_spp_per_block(w, h) * w * h  # 2^20
    assert sobol_block_pixels(16, paths, w, h, TILE_PIXELS) == 0  # a batch of 2^20 paths stays whole
    assert sobol_block_pixels(256, paths, w, h, TILE_PIXELS) == 4096  # 2^24 paths: 16 ranges of 2^20
    for spp_b, (w, h) in [(67, (256, 256)), (1000, (33, 17)), (3, (1920, 1080)), (256, (1920, 1080))]:
        paths = default_spp_per_block(w, h) * w * h
        px = sobol_block_pixels(spp_b, paths, w, h, TILE_PIXELS)
        if spp_b * w * h <= paths:
            assert px == 0
            continue
        ranges = -(-w * h // px)
        assert px % TILE_PIXELS == 0 and 1 < ranges and (ranges - 1) * px < w * h
        assert px * spp_b <= 2 * paths or px == TILE_PIXELS  # about an independent block's paths
        assert ranges <= -(-spp_b * w * h // paths)


def test_image_does_not_depend_on_the_cut(monkeypatch: pytest.MonkeyPatch) -> None:
    cs = small_cornell(32)  # an independent block: 64 spp x 1024 px; a batch of 256 spp is 4 of them
    cut = api.render(cs, spp=1024, seed=3, sampler="sobol")
    assert cut.spp == 1024 and cut.spp_per_block == 256 and np.all(cut.count == 4)
    split = api.render(cs, spp=1024, seed=3, sampler="sobol", split=2)
    same_image(split, cut)
    monkeypatch.setattr(api, "sobol_block_pixels", lambda *a: 0)  # one block per batch, as before the cut
    same_image(api.render(cs, spp=1024, seed=3, sampler="sobol"), cut)
    monkeypatch.setattr(api, "sobol_block_pixels", lambda *a: 3 * TILE_PIXELS)  # 6 ranges, the last of 64 px
    same_image(api.render(cs, spp=1024, seed=3, sampler="sobol"), cut)


def test_interrupt_inside_a_batch_then_resume(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cs = small_cornell(32)
    monkeypatch.setattr(api, "sobol_block_pixels", lambda *a: 3 * TILE_PIXELS)  # 6 blocks a batch
    whole = api.render(cs, spp=64, seed=5, sampler="sobol")
    ckpt = tmp_path / "run.ckpt"
    part = api.render(cs, spp=64, seed=5, sampler="sobol", checkpoint=ckpt, progress=interrupt_after_first_fold())
    saved = Accumulator.load(ckpt)
    assert part.stopped_by == "interrupt" and saved.meta["block_pixels"] == 3 * TILE_PIXELS
    done = saved.blocks_done
    assert 0 < done < 24 and part.spp == (done // 6 * 16 * 1024 + done % 6 * 3 * TILE_PIXELS * 16) // 1024
    # pixels of the ranges folded so far have one batch more than the rest
    per_pixel = np.full(32 * 32, done // 6, np.float32)
    per_pixel[:done % 6 * 3 * TILE_PIXELS] += 1
    np.testing.assert_array_equal(part.count.reshape(-1), per_pixel)
    few = part.count < 2
    assert np.all(np.isnan(part.variance[few])) and np.all(np.isfinite(part.variance[~few]))
    assert np.all(np.isnan(part.mean[part.count == 0])) and np.all(np.isfinite(part.mean[part.count > 0]))
    assert np.isnan(part.relative_error) if few.all() else np.isfinite(part.relative_error)
    monkeypatch.setattr(api, "sobol_block_pixels", lambda *a: 0)  # the checkpoint's cut wins
    same_image(api.render(cs, spp=64, seed=5, sampler="sobol", resume=ckpt), whole)


def test_checkpoint_of_whole_film_blocks_resumes_as_it_was(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A checkpoint without ``block_pixels`` (written before the cut, or with T = 1) counts whole-film batches."""
    cs = small_cornell(32)
    whole = api.render(cs, spp=1024, seed=9, sampler="sobol", batches=8)  # cut: 2 ranges of a batch of 128
    ckpt = tmp_path / "old.ckpt"
    monkeypatch.setattr(api, "sobol_block_pixels", lambda *a: 0)
    part = api.render(cs, spp=1024, seed=9, sampler="sobol", batches=8, checkpoint=ckpt,
                      progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt" and "block_pixels" not in Accumulator.load(ckpt).meta
    monkeypatch.undo()
    same_image(api.render(cs, spp=1024, seed=9, sampler="sobol", resume=ckpt), whole)


def test_ctrl_c_of_a_big_batch_writes_the_image(tmp_path: Path) -> None:
    """1024 spp on the 256 x 256 Cornell box: batches of 2^24 paths, blocks of 2^20; Ctrl-C stops within a batch."""
    out = tmp_path / "s.exr"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    code, summary, err = ctrl_c_render_cli([str(SCENES / "cornell.json"), "--sampler", "sobol", "--spp", "1024",
                                            "--out", str(out)], env)
    assert code == 130, err
    assert re.search(r"stopped\s+by interrupt", summary), summary
    img = read_exr(out)
    assert img.mean.shape == (256, 256, 3)
    batches = img.samples.reshape(-1)
    assert batches.max() <= batches.min() + 1 and 0 < batches.max() < 4  # stopped inside the batches
    seen = batches > 0
    assert np.all(np.isfinite(img.mean.reshape(-1, 3)[seen])) and img.mean.reshape(-1, 3)[seen].mean() > 0.05
