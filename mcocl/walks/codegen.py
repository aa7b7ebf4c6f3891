"""Generate the variable part of the random-walk program.

``kernels/walks/walk.cl`` is the fixed skeleton (lanes, refill, guard, sums);
this module writes what varies with the request, as compile-time code
(DESIGN.md §2: variants are ``#define``s, not run-time branches):

- the estimator (``WALK_EST``), the transition variant (``WALK_TRANS``:
  uniform, tabulated or the user's inverse CDF) and the next-event source
  variant (``WALK_SRC``: tabulated or the user's inverse CDF);
- the layout of a step's uniforms (``WALK_U_*``, ``WALK_NU``, ``WALK_BPS``);
- glue that calls the user's per-coordinate samplers.

User snippets (OpenCL C; see :mod:`mcocl.usercode`), their C names and
signatures:

====================  ==============  ==========================================
argument              function        parameters
====================  ==============  ==========================================
``kernel``            ``walk_K``      ``float x[dim], float y[dim]``
``source``            ``walk_g``      ``float x[dim]``
``row_integral``      ``walk_A``      ``float x[dim]``: integral of |K(x, y)| dy
``transition_sampler`` ``walk_T<k>``  ``float x[dim], float u[dim]``: coordinate
                                      k of y ~ |K(x, .)| / A(x)
``source_sampler``    ``walk_Z<k>``   ``float u[dim]``: coordinate k of zeta ~ |g| / G
====================  ==============  ==========================================
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..usercode import UserFunction

ESTIMATORS = {"truncated": 0, "roulette": 1, "subcritical": 2, "nee": 3}
TRANS_UNIFORM, TRANS_TABLE, TRANS_GIVEN = 0, 1, 2
SRC_TABLE, SRC_GIVEN = 0, 1

# Kernel files of the walk program, after the generated text.
WALK_TAIL = ["walks/walk.cl", "walks/tabulate.cl", "walks/sample_check.cl"]


@dataclass
class WalkCode:
    """What codegen produces: generated C text, user snippets and build options."""

    generated: str
    users: tuple[UserFunction, ...]
    options: list[str]
    estimator: str
    transition: int
    source_mode: int | None  # SRC_TABLE / SRC_GIVEN for nee, else None
    uniforms: int  # uniforms per step
    includes: list[str] = field(default_factory=lambda: ["lane_ops.cl"])
    tail: list[str] = field(default_factory=lambda: list(WALK_TAIL))

    @property
    def needs_transition_table(self) -> bool:
        """True when the walk samples its moves from a tabulated |K(x, .)|."""
        return self.transition == TRANS_TABLE

    @property
    def needs_source_table(self) -> bool:
        """True when next-event estimation samples a tabulated |g|."""
        return self.source_mode == SRC_TABLE


def _f(v: float) -> str:
    return f"{float(v)!r}f"


def kernel_user(code: str, dim: int) -> UserFunction:
    """The user's K(x, y) as a snippet."""
    return UserFunction("kernel", code, "walk_K", (("x", dim), ("y", dim)))


def source_user(code: str, dim: int) -> UserFunction:
    """The user's g(x) as a snippet."""
    return UserFunction("source", code, "walk_g", (("x", dim),))


def generate(
    kernel: str,
    source: str,
    dim: int,
    estimator: str,
    row_integral: str | None = None,
    transition_sampler: list[str] | None = None,
    source_integral: float | None = None,
    source_sampler: list[str] | None = None,
) -> WalkCode:
    """The walk program's generated part for one request.

    ``row_integral`` and ``transition_sampler`` (both or neither) replace the
    tabulated subcritical transition; ``source_integral`` and
    ``source_sampler`` (both or neither) replace the tabulated next-event
    density.  The caller has validated the combination.
    """
    est = ESTIMATORS[estimator]
    users = [kernel_user(kernel, dim), source_user(source, dim)]
    if estimator in ("truncated", "roulette"):
        trans = TRANS_UNIFORM
    elif transition_sampler is not None:
        trans = TRANS_GIVEN
        users.append(UserFunction("row_integral", row_integral or "", "walk_A", (("x", dim),)))
        for k, c in enumerate(transition_sampler):
            users.append(UserFunction(f"transition_sampler[{k}]", c, f"walk_T{k}", (("x", dim), ("u", dim))))
    else:
        trans = TRANS_TABLE
    src: int | None = None
    if estimator == "nee":
        src = SRC_GIVEN if source_sampler is not None else SRC_TABLE
        if src == SRC_GIVEN:
            for k, c in enumerate(source_sampler or []):
                users.append(UserFunction(f"source_sampler[{k}]", c, f"walk_Z{k}", (("u", dim),)))

    # Uniforms of one step: [survival] [transition bin] y[dim] [source bin] zeta[dim]
    nu = 0
    layout = {"SURV": 0, "TBIN": 0, "Y": 0, "ZBIN": 0, "Z": 0}
    if estimator != "truncated":
        layout["SURV"] = nu
        nu += 1
    if trans == TRANS_TABLE:
        layout["TBIN"] = nu
        nu += 1
    layout["Y"] = nu
    nu += dim
    if src == SRC_TABLE:
        layout["ZBIN"] = nu
        nu += 1
    if src is not None:
        layout["Z"] = nu
        nu += dim

    lines = [
        "#define WALK_EST_TRUNCATED 0",
        "#define WALK_EST_ROULETTE 1",
        "#define WALK_EST_SUBCRITICAL 2",
        "#define WALK_EST_NEE 3",
        f"#define WALK_EST {est}",
        "#define WALK_TRANS_UNIFORM 0",
        "#define WALK_TRANS_TABLE 1",
        "#define WALK_TRANS_GIVEN 2",
        f"#define WALK_TRANS {trans}",
        "#define WALK_SRC_TABLE 0",
        "#define WALK_SRC_GIVEN 1",
        f"#define WALK_SRC {src if src is not None else SRC_TABLE}",
        f"#define WALK_NU {nu}",
        f"#define WALK_BPS {(nu + 3) // 4}",
    ]
    lines += [f"#define WALK_U_{k} {v}" for k, v in layout.items()]
    if src == SRC_GIVEN:
        lines.append(f"#define WALK_SOURCE_INTEGRAL {_f(source_integral or 0.0)}")
    if trans == TRANS_GIVEN or src == SRC_GIVEN:
        # a user's sampler must map into [0, 1]: a point outside becomes NaN
        # (counted as a non-finite walk) rather than being clamped silently
        lines += [
            "MC_INLINE floatv walk_unit_or_nan(floatv v) {",
            "    return lane_select(lane_open01(v), (floatv)(NAN), (v < 0.0f) | (v > 1.0f));",
            "}",
        ]
    if trans == TRANS_GIVEN:
        lines.append("MC_INLINE void walk_T_all(const floatv *x, const floatv *u, floatv *y) {")
        lines += [f"    y[{k}] = walk_unit_or_nan(walk_T{k}(x, u));" for k in range(dim)]
        lines.append("}")
    if src == SRC_GIVEN:
        lines.append("MC_INLINE void walk_Z_all(const floatv *u, floatv *z) {")
        lines += [f"    z[{k}] = walk_unit_or_nan(walk_Z{k}(u));" for k in range(dim)]
        lines.append("}")
    generated = "\n".join(lines) + "\n"
    return WalkCode(
        generated=generated,
        users=tuple(users),
        options=[f"-DDIM={dim}"],
        estimator=estimator,
        transition=trans,
        source_mode=src,
        uniforms=nu,
    )
