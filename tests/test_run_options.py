"""The options every job shares: one validation, one name per concept, old names deprecated.

No test here runs a kernel: every shared option is checked before any device work.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

import mcocl
from mcocl.cli import main as cli_main
from mcocl.errors import InputError
from mcocl.integration.samplers import SAMPLER_SPECS, SamplerSpec, sampler_spec
from mcocl.render.api import render
from mcocl.run_options import SUPPORTED_LANES, RunOptions

FURNACE = str(Path(__file__).resolve().parent.parent / "scenes" / "furnace.json")

# (keyword, bad value, CLI arguments): the CLI parses the same value from text.
BAD = [
    ("time_budget", -1.0, ["--time", "-1.0"]),
    ("time_budget", 0.0, ["--time", "0.0"]),
    ("time_budget", math.nan, ["--time", "nan"]),
    ("target_error", math.nan, ["--target-error", "nan"]),
    ("target_error", -0.001, ["--target-error", "-0.001"]),
    ("seed", 2**64, ["--seed", str(2**64)]),
    ("seed", -1, ["--seed", "-1"]),
    ("lanes", 3, ["--lanes", "3"]),
    ("lanes", 32, ["--lanes", "32"]),
    ("split", 0, ["--split", "0"]),
    ("split", -2, ["--split", "-2"]),
]

APIS = {
    "integrate": lambda **kw: mcocl.integrate("x[0]", samples=1000, **kw),
    "solve_fredholm": lambda **kw: mcocl.solve_fredholm("0.5f", "1.0f", at=[0.5], walks=1000, **kw),
    "render": lambda **kw: render(FURNACE, spp=1, **kw),
}

CLI = {
    "integrate": ["integrate", "x[0]", "--samples", "1000"],
    "solve_fredholm": ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.5", "--walks", "1000"],
    "render": ["render", FURNACE, "--spp", "1"],
}


def _message(call, **kw) -> str:
    with pytest.raises(InputError) as e:
        call(**kw)
    return str(e.value)


@pytest.mark.parametrize("name,value,argv", BAD, ids=[f"{n}={v!r}" for n, v, _ in BAD])
def test_same_bad_value_same_message_in_every_api_and_the_cli(name, value, argv, capsys) -> None:
    expected = _message(RunOptions, **{name: value})
    assert expected.startswith(name), expected
    for api, call in APIS.items():
        assert _message(call, **{name: value}) == expected, api
    for api, args in CLI.items():
        capsys.readouterr()
        assert cli_main([*args, *argv]) == 2, api
        err = capsys.readouterr().err
        assert err.rstrip().endswith(f"error: {expected}"), (api, err)


def test_lanes_the_kernels_do_not_implement_are_refused_not_replaced() -> None:
    # integrate(lanes=3) used to build the scalar kernel with a note saying the integrand was not valid on lanes
    for call in APIS.values():
        with pytest.raises(InputError, match=re.escape("lanes must be 1, 2, 4, 8 or 16, got 3")):
            call(lanes=3)
    assert all(RunOptions(lanes=w).lanes == w for w in SUPPORTED_LANES)


def test_options_are_normalised_once() -> None:
    o = RunOptions(seed=7.0, time_budget=2, target_error=1, split=2.0, checkpoint=Path("a.ckpt"))
    assert (o.seed, o.time_budget, o.target_error, o.split, o.checkpoint) == (7, 2.0, 1.0, 2, "a.ckpt")
    assert type(o.seed) is int and type(o.split) is int
    # a large seed is kept exactly (no float rounding)
    assert RunOptions(seed=2**63 + 1).seed == 2**63 + 1
    for bad in ({"seed": 1.5}, {"seed": True}, {"seed": "3"}, {"checkpoint": 3}, {"progress": "yes"},
                {"lanes": True}, {"time_budget": "5"}):
        with pytest.raises(InputError, match=next(iter(bad))):
            RunOptions(**bad)
    with pytest.raises(InputError, match="samples=None needs time_budget= or target_error="):
        RunOptions().require_stop("samples", None)
    RunOptions(time_budget=1).require_stop("samples", None)


@pytest.mark.parametrize("api,old,new", [
    ("integrate", "target_stderr", "target_error"),
    ("solve_fredholm", "target_stderr", "target_error"),
    ("render", "noise", "target_error"),
    ("render", "time", "time_budget"),
])
def test_old_names_still_work_and_warn(api, old, new) -> None:
    # the old name reaches the same check as the new one (a bad value shows it without running anything)
    with pytest.warns(DeprecationWarning, match=f"{old}= is deprecated; use {new}="):
        with pytest.raises(InputError, match=f"^{new} must be a positive number"):
            APIS[api](**{old: -1.0})
    with pytest.warns(DeprecationWarning):
        with pytest.raises(InputError, match=f"give {new}= only"):
            APIS[api](**{old: 1.0, new: 1.0})


@pytest.mark.parametrize("api,flag", [("integrate", "--target-stderr"), ("solve_fredholm", "--target-stderr"),
                                      ("render", "--noise")])
def test_old_cli_flags_still_work_and_say_so(api, flag, capsys) -> None:
    assert cli_main([*CLI[api], flag, "-1"]) == 2
    err = capsys.readouterr().err
    assert f"{flag} is deprecated; use --target-error instead" in err
    assert "target_error must be a positive number, got -1.0" in err
    assert cli_main([*CLI[api], flag, "1", "--target-error", "1"]) == 2
    assert f"give --target-error only ({flag} is its deprecated name)" in capsys.readouterr().err


def test_every_sampler_is_one_registered_spec() -> None:
    assert list(SAMPLER_SPECS) == ["independent", "stratified", "nrooks", "sobol", "vegas"]
    for name, spec in SAMPLER_SPECS.items():
        assert isinstance(spec, SamplerSpec) and spec.name == name and sampler_spec(name) is spec
        design = spec.plan(dim=2, points=1, samples=10**6, design_samples=None)
        assert design.sampler == name
        defines = spec.defines(design, 2, 1)
        assert f"-DSAMPLER={spec.kernel_code}" in defines
        assert len({s.kernel_code for s in SAMPLER_SPECS.values()}) == len(SAMPLER_SPECS)
    with pytest.raises(InputError, match="unknown sampler 'halton'; choose one of independent, stratified, nrooks, sobol, vegas"):
        sampler_spec("halton")
    with pytest.raises(InputError, match="design points exist for stratified, nrooks, not 'independent'"):
        SAMPLER_SPECS["independent"].design_point_launch(8, 2)


def test_sample_rounding_per_sampler() -> None:
    # the rules in each spec's docstring
    ind, strat, rooks = (SAMPLER_SPECS[n] for n in ("independent", "stratified", "nrooks"))
    d = ind.plan(1, 2, 10_001, None)
    assert ind.granules(d, 10_001) == (2, 5000)  # 5000 units of 2 points, blocks of 4096
    assert ind.samples_used(d, 2, 5000) == 10_000
    d = strat.plan(2, 1, 1000, None)  # m = floor(sqrt(500)) = 22
    assert (d.strata_m, d.units, d.samples_per_unit) == (22, 484, 2)
    assert strat.granules(d, 1000) == (1, 484) and strat.samples_used(d, 1, 484) == 968
    d = rooks.plan(3, 1, 1000, None)  # n = 1000 // 16 = 62, at least 2 designs
    assert d.units == 62 and rooks.granules(d, 100) == (2, 62)
