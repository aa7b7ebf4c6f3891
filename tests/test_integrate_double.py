"""precision="double": integrands evaluated and summed in double (issue 12).

The float32 evaluation floors the relative error near 2^-24 (rounding_floor);
the double mode must get below that floor on a smooth integrand, against its
closed form, within its reported standard error; it must be deterministic,
and every combination it does not build must be refused with a message.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest
from vector_lanes import needs_vector_lanes

import mcocl
from mcocl.errors import InputError
from mcocl.integration.api import require_fp64
from mcocl.usercode import UserFunction

# A product peak: 1 / (a^-2 + (x - u)^2) integrates to a (atan(a (1 - u)) + atan(a u)) per dimension.
PEAK = "1.0f / ((0.01f + (x[0]-0.3f)*(x[0]-0.3f)) * (0.25f + (x[1]-0.6f)*(x[1]-0.6f)))"
PEAK_EXACT = math.prod(a * (math.atan(a * (1 - u)) + math.atan(a * u)) for a, u in ((10.0, 0.3), (2.0, 0.6)))
FLOAT_FLOOR = 2.0**-24  # mcocl.integration.job.ROUNDING_FLOOR


def test_sobol_in_double_gets_below_the_float_floor() -> None:
    r = mcocl.integrate(PEAK, dim=2, samples=1 << 22, sampler="sobol", replicates=8, seed=5, precision="double")
    rel_err = abs(r.estimate - PEAK_EXACT) / PEAK_EXACT
    assert r.stderr / PEAK_EXACT < FLOAT_FLOOR / 4  # the reported error is below float's floor ...
    assert rel_err < FLOAT_FLOOR / 4  # ... and so is the actual one
    assert abs(r.estimate - PEAK_EXACT) <= 4 * r.stderr
    assert "evaluated in double" in r.estimator
    # the same run in float32 reports the floor it cannot go below
    s = mcocl.integrate(PEAK, dim=2, samples=1 << 22, sampler="sobol", replicates=8, seed=5)
    assert s.rounding_floor / PEAK_EXACT >= FLOAT_FLOOR / 2 > 8 * r.rounding_floor / PEAK_EXACT


def test_independent_in_double_is_unbiased() -> None:
    r = mcocl.integrate(PEAK, dim=2, samples=1 << 20, seed=3, precision="double")
    assert abs(r.estimate - PEAK_EXACT) <= 4 * r.stderr


@needs_vector_lanes
@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_double_is_deterministic_across_runs_and_lane_widths(sampler: str) -> None:
    kw = dict(dim=2, samples=1 << 17, sampler=sampler, seed=11, precision="double")
    a = mcocl.integrate(PEAK, **kw)
    b = mcocl.integrate(PEAK, **kw)
    c = mcocl.integrate(PEAK, lanes=1, **kw)
    assert a.lanes > 1 and c.lanes == 1
    assert (a.estimate, a.stderr) == (b.estimate, b.stderr) == (c.estimate, c.stderr)


def test_double_differs_from_single_only_by_rounding() -> None:
    kw = dict(dim=2, samples=1 << 16, sampler="sobol", seed=2)
    d = mcocl.integrate(PEAK, precision="double", **kw)
    s = mcocl.integrate(PEAK, **kw)
    assert d.estimate != s.estimate  # another build, not the float one
    assert abs(d.estimate - s.estimate) <= 1e-6 * PEAK_EXACT  # the same points, to float's resolution


@pytest.mark.parametrize(("kw", "words"), [
    (dict(precision="quad"), "unknown precision"),
    (dict(precision="double", sampler="stratified"), "not 'stratified'"),
    (dict(precision="double", sampler="vegas"), "not 'vegas'"),
    (dict(precision="double", proposal="exponential:rate=2"), "proposal="),
    (dict(precision="double", roulette=0.5), "roulette="),
])
def test_what_double_does_not_build_is_refused(kw: dict, words: str) -> None:
    with pytest.raises(InputError, match="precision") as e:
        mcocl.integrate("x[0]", dim=1, samples=1 << 12, **kw)
    assert words in str(e.value)


def test_a_device_without_fp64_is_refused() -> None:
    no_fp64 = SimpleNamespace(name="Tiny GPU", extensions="cl_khr_fp16 cl_khr_byte_addressable_store")
    with pytest.raises(InputError, match="'Tiny GPU' has no double-precision arithmetic"):
        require_fp64(no_fp64)
    require_fp64(SimpleNamespace(name="ok", extensions="cl_khr_fp64 cl_khr_fp16"))


def test_double_snippets_read_float_literals_as_double() -> None:
    code = "float r = 0.3f + .5f + 1.f + 2e-3f + 1.5e+2F; return r * 0x1p-3f + x1f[0];"
    text = UserFunction("integrand", code, "integrand", (("x1f", 1),), "double").render(vector=True)
    assert "0.3 + .5 + 1. + 2e-3 + 1.5e+2;" in text
    assert "0x1p-3f" in text and "x1f[0]" in text  # hex literals and names untouched
    assert "#define float doublev" in text and "MC_INLINE doublev integrand_v(const doublev *x1f)" in text
    single = UserFunction("integrand", code, "integrand", (("x1f", 1),)).render(vector=False)
    assert "0.3f" in single and "#define float" not in single  # the default form is unchanged
