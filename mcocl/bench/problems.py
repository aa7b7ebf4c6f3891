"""Users' integration problems from JSON files (``mcocl bench integrate --problem FILE``).

A file holds one problem object, a list of them, or ``{"problems": [...]}``::

    {"problems": [
      {"name": "gauss-2d",
       "expression": "exp(-x[0]*x[0] - x[1]*x[1])",
       "dim": 2,
       "exact": 0.557746285351034,
       "description": "a smooth bump",                       (optional)
       "numpy": "np.exp(-x[0]**2 - x[1]**2)",                (optional)
       "proposals": ["truncnorm:mu=0,sigma=0.7"],            (optional)
       "proposal_names": ["normal"],                         (optional)
       "shares": [1, 1],                                     (optional, 2+ proposals)
       "control": {"expression": "1 - x[0]*x[0]", "integral": 0.6667},   (optional)
       "estimators": {"roulette-half": {"roulette": 0.5}}    (optional)
      }]}

Required: ``name``, ``expression`` (OpenCL C over ``float x[dim]``), ``dim``
and ``exact``.  A proposal is anything ``mcocl.integrate(proposal=...)``
takes (a short string, a factor object, a list of factors).  ``numpy`` is a
Python expression over ``x`` of shape ``(dim, n)`` for the NumPy baseline;
without it the bench translates simple OpenCL C expressions itself (integer
literals become real numbers) or says that it cannot.  ``estimators`` adds
named estimators as keyword arguments of ``mcocl.integrate``, limited to the
estimator options (:data:`ESTIMATOR_OPTIONS`).  A problem file is data: its
``numpy`` twin is parsed by a whitelisting translator, never evaluated as Python,
and it cannot name files, devices or schedulers.

Every error names the file, the problem and the field; unknown fields are
errors too (a typo must not silently drop a proposal).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..datafile import loads_json, read_utf8
from ..errors import InputError
from .integrate_problem import IntegrationProblem
from .numpy_baseline import compile_numpy

# The keyword arguments of mcocl.integrate that choose an estimator; everything else (where to
# write, where to connect, which device, how long) is the bench's business, never a data file's.
ESTIMATOR_OPTIONS = ("sampler", "proposal", "proposals", "shares", "heuristic", "beta", "control",
                     "control_integral", "roulette", "design_samples")

REQUIRED = ("name", "expression", "dim", "exact")
OPTIONAL = ("description", "numpy", "proposals", "proposal_names", "shares", "control", "estimators")


def _problem_list(data: Any, where: str) -> list[Any]:
    if isinstance(data, dict) and "problems" in data:
        extra = set(data) - {"problems"}
        if extra:
            raise InputError(f"{where}: unknown top-level field(s) {sorted(extra)}; expected only 'problems'")
        data = data["problems"]
    elif isinstance(data, dict):
        data = [data]
    if not isinstance(data, list) or not data:
        raise InputError(f"{where}: expected a problem object, a non-empty list of them, or {{\"problems\": [...]}}")
    return data


def _text(v: Any, what: str) -> str:
    if not isinstance(v, str) or not v.strip():
        raise InputError(f"{what}: expected a non-empty string, got {v!r}")
    return v


def _number(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{what}: expected a finite number, got {v!r}")
    return float(v)


def parse_problem(obj: Any, where: str, source: str = "") -> IntegrationProblem:
    """One problem from its JSON object; ``where`` names the file and index for messages.

    Raises:
        InputError: a missing, unknown or malformed field (named).
    """
    if not isinstance(obj, dict):
        raise InputError(f"{where}: expected an object with fields {list(REQUIRED)}, got {type(obj).__name__}")
    name = obj.get("name")
    label = f"{where} ({name!r})" if isinstance(name, str) and name.strip() else f"{where} (no name)"
    for k in REQUIRED:
        if k not in obj:
            raise InputError(f"{label}: missing field {k!r} (required: {', '.join(REQUIRED)})")
    unknown = sorted(set(obj) - set(REQUIRED) - set(OPTIONAL))
    if unknown:
        raise InputError(f"{label}: unknown field(s) {unknown}; known: {', '.join(REQUIRED + OPTIONAL)}")

    def field(k: str) -> str:
        return f"{label}, field {k!r}"

    name = _text(obj["name"], field("name"))
    expression = _text(obj["expression"], field("expression"))
    dim = obj["dim"]
    if isinstance(dim, bool) or not isinstance(dim, int) or not 1 <= dim <= 64:
        raise InputError(f"{field('dim')}: expected an integer from 1 to 64, got {dim!r}")
    exact = _number(obj["exact"], field("exact"))
    description = _text(obj["description"], field("description")) if "description" in obj else ""
    numpy_expr = _text(obj["numpy"], field("numpy")) if "numpy" in obj else None
    if numpy_expr is not None:
        try:
            compile_numpy(numpy_expr, dim)
        except ValueError as e:
            raise InputError(f"{field('numpy')}: {e}") from None

    proposals = obj.get("proposals", [])
    if not isinstance(proposals, list):
        raise InputError(f"{field('proposals')}: expected a list of proposals, got {proposals!r}")
    names = obj.get("proposal_names", [])
    if not isinstance(names, list) or any(not isinstance(n, str) or not n.strip() for n in names):
        raise InputError(f"{field('proposal_names')}: expected a list of names, got {names!r}")
    if names and len(names) != len(proposals):
        raise InputError(f"{field('proposal_names')}: {len(names)} names for {len(proposals)} proposals")
    shares = obj.get("shares")
    if shares is not None:
        if len(proposals) < 2:
            raise InputError(f"{field('shares')}: shares apply to two or more proposals (there are {len(proposals)})")
        if not isinstance(shares, list) or len(shares) != len(proposals) or any(
            isinstance(s, bool) or not isinstance(s, int) or s < 1 for s in shares
        ):
            raise InputError(f"{field('shares')}: expected {len(proposals)} positive integers, got {shares!r}")

    control = control_integral = None
    if "control" in obj:
        c = obj["control"]
        if not isinstance(c, dict) or set(c) != {"expression", "integral"}:
            raise InputError(f"{field('control')}: expected {{\"expression\": ..., \"integral\": ...}}, got {c!r}")
        control = _text(c["expression"], field("control") + ".expression")
        control_integral = _number(c["integral"], field("control") + ".integral")

    extra = obj.get("estimators", {})
    if not isinstance(extra, dict) or any(not isinstance(v, dict) for v in extra.values()):
        raise InputError(f"{field('estimators')}: expected {{name: {{keyword: value}}}}, got {extra!r}")
    for ename, kw in extra.items():
        refused = sorted(set(kw) - set(ESTIMATOR_OPTIONS))
        if refused:
            raise InputError(f"{field('estimators')}.{ename}: {', '.join(map(repr, refused))} "
                             f"{'is not an estimator option' if len(refused) == 1 else 'are not estimator options'}"
                             f" (allowed: {', '.join(ESTIMATOR_OPTIONS)}; outputs, devices and run limits are "
                             "options of the bench command, not of a problem file)")

    p = IntegrationProblem(name, expression, dim, exact, description, numpy_expr, proposals, list(names), shares,
                           control, control_integral, {}, source=source or where)
    dup = sorted(set(extra) & set(p.estimator_options()))
    if dup:
        raise InputError(f"{field('estimators')}: the name(s) {dup} are taken by the standard estimators")
    p.extra = dict(extra)
    return p


def load_problem_file(path: str | Path) -> list[IntegrationProblem]:
    """The problems of one JSON file (parsed, not yet compiled: see ``IntegrationProblem.check``)."""
    p = Path(path)
    text = read_utf8(p, f"problem file {str(p)!r}")
    try:
        data = loads_json(text, f"problem file {str(p)!r}")
    except json.JSONDecodeError as e:
        raise InputError(f"problem file {str(p)!r}: not valid JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None
    return [parse_problem(o, f"{p}: problem #{i + 1}", str(p)) for i, o in enumerate(_problem_list(data, str(p)))]


def load_problem_files(paths: list[str]) -> list[IntegrationProblem]:
    """Every problem of several files; names must be unique."""
    out: list[IntegrationProblem] = []
    seen: dict[str, str] = {}
    for path in paths:
        for prob in load_problem_file(path):
            if prob.name in seen:
                raise InputError(f"{prob.source}: problem name {prob.name!r} is used twice (also in {seen[prob.name]})")
            seen[prob.name] = prob.source
            out.append(prob)
    return out
