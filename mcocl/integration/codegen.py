"""Generate the estimator part of the integration kernel.

``kernels/integrate/integrate.cl`` is the fixed skeleton (blocks, lanes,
samplers, sums); this module writes what varies with the user's request:
``unit_value(tau)``, the primary estimate of one point tuple from its
uniforms, and the compile-time constants.  Variants are compile-time code,
not run-time branches (DESIGN.md §2).

The estimators (lecture, "Monte Carlo integrace" to "Řídící funkce"):

plain          v = f(tau) - g(tau)
importance     x = P^-1(tau), v = (f(x) - g(x)) / p(x)
combined       one point per sample of each technique i (n_i of them):
               v = sum_i 1/n_i sum_l w_i(x_il) (f(x_il) - g(x_il)) / p_i(x_il)
roulette       (lecture: "Ruská ruleta pro jeden integrál") with the first
               uniform: v = V(tau0 / P, ...) / P if tau0 < P, else 0

where g is the control variate (its integral J is added by the host).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..usercode import UserFunction
from .proposals import Proposal

HEURISTICS = {"average": 0, "max": 1, "balance": 2, "power": 3}


@dataclass
class EstimatorCode:
    """What codegen produces: generated C text, user snippets and the table buffer."""

    generated: str
    users: tuple[UserFunction, ...]
    tables: np.ndarray  # uint32, at least one element
    points: int  # point tuples per unit
    includes: list[str] = field(default_factory=list)


def _proposal_functions(t: int, prop: Proposal, tag: str, offsets: list[list[int]]) -> str:
    """``warp_t<t>`` (uniforms -> x, returns pdf) and ``pdf_t<t>`` (x -> pdf) for one proposal."""
    warp = [f"MC_INLINE floatv warp_t{t}(const floatv *u, floatv *x, global const uint *tables) {{",
            "    floatv pdf = (floatv)(1.0f);"]
    pdfs = []
    k = 0
    for fi, f in enumerate(prop.factors):
        tabs = [f"(tables + {o})" for o in offsets[fi]]
        ftag = f"{tag}_f{fi}"
        us = [f"u[{k + j}]" for j in range(f.ndim)]
        xs = [f"x[{k + j}]" for j in range(f.ndim)]
        warp.append("    " + f.warp_code(ftag, us, xs, "pdf", tabs))
        pdfs.append(f.pdf_code(ftag, xs, tabs))
        k += f.ndim
    warp += ["    return pdf;", "}"]
    pdf = [f"MC_INLINE floatv pdf_t{t}(const floatv *x, global const uint *tables) {{",
           "    return " + " * ".join(pdfs) + ";", "}"]
    return "\n".join(warp + pdf) + "\n"


def generate(
    integrand: UserFunction,
    dim: int,
    proposals: list[Proposal],
    shares: list[int],
    heuristic: str,
    beta: float,
    control: UserFunction | None,
    roulette: float | None,
    precision: str = "single",
) -> EstimatorCode:
    """The estimator code for one request (see the module docstring).

    ``precision="double"`` (the plain estimator and a control variate only;
    mcocl/integration/api.py refuses the rest) writes ``unit_value`` over
    ``doublev``, the value type of integrate.cl's REAL_DOUBLE build.
    """
    if precision == "double" and (proposals or roulette is not None):
        raise ValueError("precision='double' generates the plain estimator only")
    realv = "doublev" if precision == "double" else "floatv"
    users: list[UserFunction] = [integrand]
    if control is not None:
        users.append(control)
    tables: list[np.ndarray] = []
    offset = 0
    funcs = []
    for t, prop in enumerate(proposals):
        offsets: list[list[int]] = []
        for fi, f in enumerate(prop.factors):
            users.extend(f.users(f"proposal{t}_f{fi}"))
            offs = []
            for tab in f.tables():
                offs.append(offset)
                tables.append(tab.astype(np.uint32))
                offset += len(tab)
            offsets.append(offs)
        funcs.append(_proposal_functions(t, prop, f"proposal{t}", offsets))

    g = "integrand(x)" if control is None else "(integrand(x) - control(x))"
    body = [f"MC_INLINE {realv} unit_value({realv} *tau, global const uint *tables) {{"]
    if roulette is not None:
        body += [
            "    const floatv rr_u = tau[0];",
            f"    const intv rr_live = rr_u < {float(roulette)!r}f;",
            f"    tau[0] = clamp_open01(rr_u * {1.0 / float(roulette)!r}f);",
        ]
    if not proposals:
        points = 1
        body += [f"    const {realv} *x = tau;", f"    {realv} v = {g};"]
    elif len(proposals) == 1:
        points = 1
        body += [
            f"    floatv x[{dim}];",
            "    floatv p = warp_t0(tau, x, tables);",
            f"    floatv v = {g} / p;",
        ]
    else:
        k = len(proposals)
        points = sum(shares)
        body += ["    floatv v = (floatv)(0.0f);", f"    const float shares[{k}] = {{{', '.join(f'{float(n)!r}f' for n in shares)}}};"]
        point = 0
        for i in range(k):
            for _ in range(shares[i]):
                body += [
                    "    {",
                    f"        floatv x[{dim}];",
                    f"        floatv p = warp_t{i}(tau + {point * dim}, x, tables);",
                    f"        floatv q[{k}];",
                ]
                for j in range(k):
                    pj = "p" if j == i else f"pdf_t{j}(x, tables)"
                    body.append(f"        q[{j}] = shares[{j}] * {pj};")
                if heuristic == "average":
                    body.append(f"        floatv w = mis_weight_average({i}, shares, {k});")
                elif heuristic == "max":
                    body.append(f"        floatv w = mis_weight_max({i}, q, {k});")
                elif heuristic == "balance":
                    body.append(f"        floatv w = mis_weight_balance({i}, q, {k});")
                else:
                    body.append(f"        floatv w = mis_weight_power({i}, q, {k}, {float(beta)!r}f);")
                # a zero weight contributes nothing, even where f/p is not finite
                body += [
                    f"        floatv c = w * {g} / (shares[{i}] * p);",
                    "        v += lane_select(c, (floatv)(0.0f), w <= 0.0f);",
                    "    }",
                ]
                point += 1
    if roulette is not None:
        body.append(f"    v = lane_select((floatv)(0.0f), v * {1.0 / float(roulette)!r}f, rr_live);")
    body += ["    return v;", "}"]
    generated = "".join(funcs) + "\n".join(body) + "\n"
    tab = np.concatenate(tables) if tables else np.zeros(1, np.uint32)
    includes = ["sampling/warps.cl", "sampling/piecewise.cl", "sampling/mis.cl"]
    return EstimatorCode(generated, tuple(users), tab, points, includes)
