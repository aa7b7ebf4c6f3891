"""The default render sampler ``auto`` (mcocl/render/sampler_choice.py).

- The rule: which sampler each request resolves to (path integrators with spp >= 8, time or
  noise halting, batches or a fitting spp_per_block: sobol; bdpt whose batches hold 2 or more
  samples: sobol; lt, spp < 8 and an spp_per_block that does not fit: independent).
- A render by ``auto`` is bit for bit the explicit sampler it resolved to, and reports it
  (RenderResult, to_dict, the EXR header, the notes).
- Resuming: an independent checkpoint (what every checkpoint before ``auto`` was) continues
  independent under ``auto`` and gives the uninterrupted run's bits; an ``auto`` checkpoint that
  resolved to sobol continues sobol even where the resumed spp alone would not choose it.
- ``batches`` chooses sobol (API and scene key) and is refused with lt/bdpt (bdpt's sobol batches
  are its blocks); a Mitsuba file's ``independent`` sampler stays explicit, a file without a sampler gets ``auto``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from device_doubles import small_cornell
from interrupting import interrupt_after_first_fold

from mcocl.accumulate import Accumulator
from mcocl.errors import InputError
from mcocl.render.api import render
from mcocl.render.image_io import read_exr
from mcocl.render.mitsuba import read_mitsuba
from mcocl.render.sampler_choice import AUTO_BATCH_PATHS, MAX_BATCH_SPP, resolve_auto_sampler
from mcocl.render.scene import DEFAULT_RENDER_SAMPLER, parse_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"


@pytest.mark.parametrize("integrator,spp,block,batches,pixels,bounded,want,batch", [
    ("mis", 8, None, None, 64, True, "sobol", 2),  # 4 batches of 2
    ("mis", 7, None, None, 64, True, "independent", None),  # a batch of 1 sample
    ("path", 1, None, None, 64, True, "independent", None),
    ("nee", 1024, None, None, 64, True, "sobol", 256),
    ("mis", 64, None, None, 384 * 256, True, "sobol", 16),  # 1.6 M paths: one whole-film block
    ("mis", 64, None, None, 512 * 512, True, "sobol", 16),  # 2^22 paths exactly
    ("mis", 256, None, None, 512 * 512, True, "sobol", 16),  # capped at 2^22 paths: 16 batches of 16
    ("mis", 256, None, None, 1000 * 1000, True, "sobol", 4),  # the largest power of two that fits
    ("mis", 64, None, None, 1920 * 1080, True, "sobol", 2),
    ("mis", 64, None, None, 2048 * 2048, True, "independent", None),  # not even 2 samples fit a block
    ("mis", None, None, None, 64, False, "sobol", 64),  # time or noise halting: the default block
    ("mis", None, None, None, 256 * 256, False, "sobol", 16),
    ("mis", None, None, None, 1024 * 1024, False, "independent", None),  # the default block holds 1 spp
    ("mis", 16, None, None, 256 * 256, False, "sobol", 4),  # an upper bound: 4 batches within it
    ("mis", 2, None, 2, 64, True, "sobol", None),  # batches ask for sobol
    ("mis", 16, 8, None, 64, True, "sobol", None),  # two batches of 8
    ("mis", 15, 8, None, 64, True, "independent", None),  # one batch of 8 and one of 7: fewer than 2 whole batches
    ("mis", 64, 1, None, 64, True, "independent", None),  # batches of one sample
    ("mis", None, 4, None, 64, False, "sobol", None),
    ("mis", None, MAX_BATCH_SPP + 1, None, 64, False, "independent", None),  # beyond one scrambling's points
    ("lt", 64, None, None, 64, True, "independent", None),
    # bdpt (kernels/render/bdpt.cl, "Quasi-Monte Carlo"): sobol when its batches (blocks) hold 2 or more samples
    ("bdpt", None, None, None, 64, False, "sobol", None),  # time or noise halting: the default block
    ("bdpt", None, None, None, 2048 * 2048, False, "independent", None),  # the default block holds 1 spp
    ("bdpt", 64, None, None, 128 * 128, True, "sobol", None),  # 4 batches of 16
    ("bdpt", 7, None, None, 64, True, "sobol", None),  # batches of 2, 2, 2 and 1
    ("bdpt", 4, None, None, 64, True, "independent", None),  # batches of 1 sample are no net
    ("bdpt", 16, 8, None, 64, True, "sobol", None),
    ("bdpt", 15, 8, None, 64, True, "independent", None),
    ("bdpt", None, 1, None, 64, False, "independent", None),
    ("bdpt", None, 1 << 12, None, 1 << 13, False, "independent", None),  # 2^25 samples: past one scrambling
])
def test_auto_rule(integrator, spp, block, batches, pixels, bounded, want, batch) -> None:
    got, why, size = resolve_auto_sampler(integrator, spp, block, batches, pixels, bounded)
    assert got == want and why and size == batch
    if size is not None:
        assert size * pixels <= AUTO_BATCH_PATHS


def test_auto_batches_are_whole_film_blocks() -> None:
    """A batch that auto sized is one block over the whole film, so a render stopped in its first
    batch has every pixel (explicit sobol of the same spp cuts the batch into pixel ranges)."""
    cs = small_cornell(64)  # 4096 pixels: a batch of 512 spp is 2^21 paths, two default blocks
    part = render(cs, spp=2048, seed=3, progress=interrupt_after_first_fold())
    assert part.sampler == "sobol" and part.spp_per_block == 512 and part.stopped_by == "interrupt"
    assert part.count.min() == part.count.max() >= 1
    assert np.isfinite(part.mean).all()


def test_default_is_auto() -> None:
    data = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4}}
    assert DEFAULT_RENDER_SAMPLER == "auto" and parse_scene(data).sampler == "auto"


def test_auto_is_the_explicit_sampler_bit_for_bit(tmp_path: Path) -> None:
    cs = small_cornell(8)
    auto = render(cs, spp=8, seed=5)
    sobol = render(cs, spp=8, seed=5, sampler="sobol")
    assert auto.sampler == sobol.sampler == "sobol"
    for k in ("mean", "variance", "count"):
        np.testing.assert_array_equal(getattr(auto, k), getattr(sobol, k))
    assert np.all(auto.count == 4)  # 4 batches of 2: the sobol film's count
    assert any(n.startswith("sampler auto: sobol") for n in auto.notes)
    low = render(cs, spp=4, seed=5)
    ind = render(cs, spp=4, seed=5, sampler="independent")
    assert low.sampler == ind.sampler == "independent" and np.all(low.count == 4)
    np.testing.assert_array_equal(low.mean, ind.mean)
    np.testing.assert_array_equal(low.variance, ind.variance)
    assert not any("sampler auto" in n for n in ind.notes)  # an explicit sampler needs no note
    lt = render(cs, spp=8, seed=5, integrator="lt")
    assert lt.sampler == "independent"
    # bdpt: auto takes its sobol back end, bit for bit, once its batches hold 2 samples
    bd = render(cs, spp=8, seed=5, integrator="bdpt")
    bd_sobol = render(cs, spp=8, seed=5, integrator="bdpt", sampler="sobol")
    assert bd.sampler == bd_sobol.sampler == "sobol" and bd.spp_per_block == 2
    np.testing.assert_array_equal(bd.mean, bd_sobol.mean)
    np.testing.assert_array_equal(bd.variance, bd_sobol.variance)
    # reported: to_dict (the CLI's --json) and the EXR header
    assert auto.to_dict()["sampler"] == "sobol" and auto.metadata()["sampler"] == "sobol"
    auto.save_exr(tmp_path / "a.exr")
    low.save_exr(tmp_path / "b.exr")
    assert read_exr(tmp_path / "a.exr").metadata["sampler"] == "sobol"
    assert read_exr(tmp_path / "b.exr").metadata["sampler"] == "independent"


def test_noise_halting_resolves_to_sobol() -> None:
    r = render(SCENES / "furnace.json", target_error=0.5, seed=4)
    assert r.sampler == "sobol" and r.stopped_by == "noise" and r.count.min() >= 4


def test_resume_of_an_independent_checkpoint_stays_independent(tmp_path: Path) -> None:
    cs = small_cornell(8)
    whole = render(cs, spp=12, seed=7, spp_per_block=2, sampler="independent")
    ckpt = tmp_path / "ind.ckpt"
    part = render(cs, spp=12, seed=7, spp_per_block=2, sampler="independent", checkpoint=ckpt,
                  progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt" and 0 < part.spp < 12
    assert Accumulator.load(ckpt).meta.get("sampler") is None  # as every checkpoint before auto
    rest = render(cs, spp=12, seed=7, resume=ckpt)  # auto: spp 12 alone would choose sobol
    assert rest.sampler == "independent" and rest.spp == 12
    assert any("the checkpoint's" in n for n in rest.notes)
    for k in ("mean", "variance", "count"):
        np.testing.assert_array_equal(getattr(rest, k), getattr(whole, k))
    with pytest.raises(InputError, match="sampler"):  # an explicit sobol still refuses it
        render(cs, spp=12, seed=7, sampler="sobol", resume=ckpt)


def test_resume_of_an_auto_sobol_checkpoint_stays_sobol(tmp_path: Path) -> None:
    cs = small_cornell(8)
    whole = render(cs, spp=12, seed=7, spp_per_block=2)
    assert whole.sampler == "sobol"  # 6 batches of 2
    ckpt = tmp_path / "auto.ckpt"
    part = render(cs, spp=12, seed=7, spp_per_block=2, checkpoint=ckpt, progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt" and 0 < part.spp < 12 and part.sampler == "sobol"
    rest = render(cs, spp=12, seed=7, resume=ckpt)
    assert rest.sampler == "sobol"
    for k in ("mean", "variance", "count"):
        np.testing.assert_array_equal(getattr(rest, k), getattr(whole, k))


def test_batches_choose_sobol_and_are_refused_with_light_tracing() -> None:
    cs = small_cornell(8)
    r = render(cs, spp=4, seed=1, batches=2)
    assert r.sampler == "sobol" and np.all(r.count == 2)
    np.testing.assert_array_equal(r.mean, render(cs, spp=4, seed=1, batches=2, sampler="sobol").mean)
    # bdpt has a sobol back end (kernels/render/bdpt.cl): batches choose it there too; lt has none
    r = render(cs, spp=4, seed=1, integrator="bdpt", batches=2)
    assert r.sampler == "sobol" and np.all(r.count == 2)
    with pytest.raises(InputError, match="batches.*not 'lt'"):
        render(cs, spp=4, integrator="lt", batches=2)
    with pytest.raises(InputError, match="batches"):
        render(cs, spp=4, batches=2, sampler="independent")


def test_scene_batches_choose_sobol() -> None:
    data = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
            "integrator": {"batches": 2}}
    assert parse_scene(data).sampler == "sobol"
    data["integrator"]["type"] = "lt"
    with pytest.raises(InputError, match="integrator.batches"):
        parse_scene(data)
    data["integrator"] = {"batches": 2, "sampler": "independent"}
    with pytest.raises(InputError, match="integrator.batches"):
        parse_scene(data)


SENSOR = """<sensor type="perspective"><float name="fov" value="40"/>{sampler}
<film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>"""


@pytest.mark.parametrize("sampler,want", [
    ('<sampler type="independent"><integer name="sample_count" value="16"/></sampler>', "independent"),
    ('<sampler type="stratified"><integer name="sample_count" value="16"/></sampler>', "sobol"),
    ("", None),  # no key: the default, auto
])
def test_mitsuba_sampler_mapping(tmp_path: Path, sampler: str, want: str | None) -> None:
    p = tmp_path / "s.xml"
    p.write_text(f'<?xml version="1.0"?>\n<scene version="3.0.0">{SENSOR.format(sampler=sampler)}</scene>\n')
    data = read_mitsuba(p)
    assert data["integrator"].get("sampler") == want
    if want is None:  # the converted file says so
        assert any("default sampler 'auto'" in c for c in data["camera"]["comment"])
