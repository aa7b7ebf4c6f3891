"""Snippets past the operator limit are refused before compiling (issue 10).

An 18,000-term expression crashed PoCL's compiler and the process; the limit
and the measurements behind it are in mcocl/snippet_size.py.
"""

from __future__ import annotations

import pytest

import mcocl
from mcocl import runtime
from mcocl.errors import InputError
from mcocl.snippet_size import MAX_SNIPPET_OPERATORS, check_snippet_size, operator_count


def test_operators_are_counted_as_c_tokens() -> None:
    # <=, ?, unary -, * and += ; not the exponent sign, the ':' of ?:, '->', comments or strings
    code = 'float s = 0; s += x[0] <= 1e-3f ? -x[0] * 2.0f : p->q; // a+b\n/* c-d */ printf("+-");'
    assert operator_count(code) == 6  # =, +=, <=, ?, -, *
    assert operator_count("0x1p-3f + 1.5e+2") == 1


@pytest.mark.parametrize(("call", "label"), [
    (lambda code: mcocl.integrate(code, samples=1000), "integrand"),
    (lambda code: mcocl.solve_fredholm(kernel="0.5f", source=code, at=[0.5], walks=1000), "source"),
])
def test_an_18000_term_snippet_is_refused_before_compiling(call, label, monkeypatch) -> None:
    def no_build(*args, **kwargs):
        raise AssertionError("the snippet reached the compiler")

    # Refused, not compiled: any build attempt fails the test (no wall-clock bound needed).
    monkeypatch.setattr(runtime, "build", no_build)
    monkeypatch.setattr(runtime, "build_user_program", no_build)
    monkeypatch.setattr(runtime, "_compile_with_large_stack", no_build)
    with pytest.raises(InputError, match=rf"^{label}: the code has 17,999 operators; the limit is "
                                         rf"{MAX_SNIPPET_OPERATORS:,} "):
        call("+".join(["x[0]"] * 18_000))


def test_a_2000_operator_snippet_compiles_and_the_limit_is_exact() -> None:
    # A chain of unary minus: as many operators as a sum, but quicker to compile.
    chain = "- " * 2000 + "x[0]"  # an even count: the identity
    r = mcocl.integrate(chain, samples=1 << 14, seed=3)
    assert abs(r.estimate - 0.5) < 5 * r.stderr
    at_limit = "+".join(["x[0]"] * (MAX_SNIPPET_OPERATORS + 1))
    check_snippet_size("integrand", at_limit)  # accepted (not compiled here: about a minute)
    with pytest.raises(InputError, match=rf"has {MAX_SNIPPET_OPERATORS + 1:,} operators"):
        check_snippet_size("integrand", at_limit + "+x[0]")
