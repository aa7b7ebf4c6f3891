"""Progressive rendering: batching, checkpoints, halting rules, bad input, non-finite samples.

- the same seed gives the bit-identical film however the blocks are grouped
  into launches, and after an interrupted run is resumed from its checkpoint;
- --time and --noise halting stop where they should;
- bad settings and mismatched checkpoints raise InputError naming the problem;
- non-finite samples are counted, reported and kept out of the image.
"""

from __future__ import annotations

import copy
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from device_doubles import small_cornell
from interrupting import interrupt_after_first_fold

from mcocl import runtime
from mcocl.accumulate import Accumulator
from mcocl.errors import InputError
from mcocl.render.api import NonFiniteSampleWarning, render
from mcocl.render.job import RenderJob, scene_tables

SCENES = Path(__file__).resolve().parent.parent / "scenes"



def test_film_does_not_depend_on_how_blocks_are_launched() -> None:
    cs = small_cornell()
    job = RenderJob(scene_tables(cs), cs.width, cs.height, "mis", cs.max_depth, cs.rr_depth, seed=42,
                    spp_per_block=2, spp_limit=16)
    runner = job.runner(runtime.device_context())
    films = []
    for chunks in ([1] * 8, [3, 5], [8], [2, 1, 4, 1]):
        acc = Accumulator(job.stat_shape)
        first = 0
        for n in chunks:
            acc.add(first, runner.collect(runner.enqueue(first, n)))
            first += n
        films.append(acc.totals)
    for f in films[1:]:
        np.testing.assert_array_equal(f, films[0])
    assert films[0][..., 6].min() == 16  # every pixel got its 16 samples


def test_sub_devices_give_the_same_image() -> None:
    """Blocks computed on two sub-devices are folded in block order: the same film as one device."""
    cs = small_cornell(12)
    one = render(cs, spp=8, seed=4, spp_per_block=2)
    two = render(cs, spp=8, seed=4, spp_per_block=2, split=2)
    np.testing.assert_array_equal(one.mean, two.mean)
    np.testing.assert_array_equal(one.variance, two.variance)


def test_resumed_render_is_identical(tmp_path: Path) -> None:
    cs = small_cornell()
    whole = render(cs, spp=12, seed=7, spp_per_block=2)
    ckpt = tmp_path / "run.ckpt"

    part = render(cs, spp=12, seed=7, spp_per_block=2, checkpoint=ckpt, progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt"
    assert 0 < part.spp < 12
    assert Accumulator.load(ckpt).blocks_done * 2 == part.spp
    rest = render(cs, spp=12, seed=7, resume=ckpt)
    assert rest.spp == 12 and rest.stopped_by == "spp" and rest.spp_this_run == 12 - part.spp
    np.testing.assert_array_equal(rest.mean, whole.mean)
    np.testing.assert_array_equal(rest.variance, whole.variance)
    np.testing.assert_array_equal(rest.count, whole.count)


@pytest.mark.parametrize("sampler", ["independent", "sobol"])
def test_resume_asking_fewer_spp_keeps_and_reports_what_the_checkpoint_holds(tmp_path: Path, sampler: str) -> None:
    """A checkpoint of 8 spp resumed with spp=4: the image is the checkpoint's, and so are its counts."""
    cs = small_cornell(8)
    ckpt = tmp_path / "run.ckpt"
    whole = render(cs, spp=8, seed=5, sampler=sampler, checkpoint=ckpt)
    again = render(cs, spp=4, seed=5, sampler=sampler, resume=ckpt)
    assert again.spp == 8 and again.spp_this_run == 0
    assert any("already holds 8 spp" in n for n in again.notes)
    np.testing.assert_array_equal(again.mean, whole.mean)
    np.testing.assert_array_equal(again.variance, whole.variance)
    assert Accumulator.load(ckpt).meta_int("spp_limit", ckpt, 1, 1 << 40) == 8


def test_checkpoint_of_another_render_is_refused(tmp_path: Path) -> None:
    cs = small_cornell(8)
    ckpt = tmp_path / "a.ckpt"
    render(cs, spp=3, seed=1, spp_per_block=2, checkpoint=ckpt)
    with pytest.raises(InputError, match="seed"):
        render(cs, spp=8, seed=2, resume=ckpt)
    with pytest.raises(InputError, match="integrator"):
        render(cs, spp=8, seed=1, integrator="path", resume=ckpt)
    # the run ended in a partial block (3 spp in blocks of 2): only the same spp can resume it
    with pytest.raises(InputError, match="partial block"):
        render(cs, spp=8, seed=1, resume=ckpt)
    assert render(cs, spp=3, seed=1, resume=ckpt).spp == 3
    with pytest.raises(InputError, match="does not exist"):
        render(cs, spp=8, resume=tmp_path / "missing.ckpt")


def test_time_and_noise_halting() -> None:
    r = render(SCENES / "furnace.json", target_error=0.02, seed=3)
    assert r.stopped_by == "noise"
    assert r.relative_error <= 0.02
    r = render(SCENES / "furnace.json", target_error=1e-9, spp=8, seed=3)
    assert r.stopped_by == "spp" and r.spp == 8
    r = render(small_cornell(32), time_budget=0.5, seed=3)
    assert r.stopped_by == "time" and r.spp >= 1 and r.seconds < 5


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"spp": 0}, "spp"),
        ({"spp": 2.5}, "spp"),
        ({"time_budget": -1.0}, "time_budget"),
        ({"target_error": 0}, "target_error"),
        ({"integrator": "photon"}, "integrator"),
        ({"max_depth": -2}, "max_depth"),
        ({"rr_depth": 0}, "rr_depth"),
        ({"seed": -1}, "seed"),
        ({"lanes": 3}, "lanes"),
    ],
)
def test_bad_settings(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        render(SCENES / "furnace.json", **kwargs)


def test_bad_scene() -> None:
    with pytest.raises(InputError):
        render(SCENES / "no_such_scene.json", spp=1)
    with pytest.raises(InputError, match="scene"):
        render(42, spp=1)


def test_nonfinite_samples_are_counted_and_left_out() -> None:
    """An infinite red radiance (bypassing the scene checks): paths that reach the light are Inf or NaN
    and must not reach the image; paths that do not are kept."""
    cs = copy.copy(small_cornell(12))
    cs.emitter_radiance = np.array([[np.inf, 1.0, 1.0, 0.0]], np.float32)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NonFiniteSampleWarning)
        r = render(cs, spp=8, seed=1, sampler="independent")  # count: finite samples, not sobol's batches
    assert r.nonfinite > 0
    assert any(issubclass(w.category, NonFiniteSampleWarning) for w in caught)
    total = r.count.sum() + r.nonfinite
    assert total == 8 * cs.width * cs.height
    seen = r.count > 0
    assert np.all(np.isfinite(r.mean[seen]))
    assert math.isfinite(r.relative_error) or np.isnan(r.relative_error)


def test_lane_build_renders_what_the_scalar_build_renders() -> None:
    """Same seed: the 8-lane packet build and the scalar build trace the same paths (up to float
    rounding, which may flip a rare roulette or edge decision)."""
    cs = small_cornell(16)
    a = render(cs, spp=16, seed=5, lanes=1)
    b = render(cs, spp=16, seed=5, lanes=8)
    assert a.lanes == 1 and b.lanes == 8
    rel = np.abs(a.mean - b.mean) / np.maximum(np.abs(a.mean), 1e-3)
    assert np.mean(rel > 1e-3) <= 0.01, np.mean(rel > 1e-3)
