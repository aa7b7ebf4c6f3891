"""Bench output: the text table, a CSV of every checkpoint, a JSON summary.

Files written into the output folder, per suite ``S``:

``S-table.txt``        the table printed on stdout
``S-checkpoints.csv``  one row per checkpoint, columns :data:`CSV_COLUMNS`
``S-summary.json``     one object: machine, options, and per problem and
                       estimator the final figures (:data:`SUMMARY_FIELDS`)

The figures are defined in :mod:`.runner` (variance per sample, efficiency,
z, z_rms).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from ..output_files import write_atomically
from .runner import Z_CONSISTENT, BenchResult, EstimatorRecord, ProblemRecord

CSV_COLUMNS = ("suite", "problem", "estimator", "kind", "checkpoint", "seconds", "samples", "estimate", "stderr",
               "error", "nonfinite", "points")
SUMMARY_FIELDS = ("name", "kind", "description", "samples", "points", "seconds", "samples_per_second", "estimate", "stderr",
                  "variance_per_sample", "efficiency", "relative_efficiency", "efficiency_from_error", "error", "z",
                  "consistent", "z_rms",
                  "nonfinite", "failed", "interrupted", "info")
TABLE_HEADER = ("estimator", "samples/s", "var/sample", "efficiency", "rel. eff.", "error at end", "|err| <= 4 se",
                "rms z")


def _si(v: float) -> str:
    if not math.isfinite(v):
        return "-"
    for unit, scale in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if abs(v) >= scale:
            return f"{v / scale:.3g} {unit}"
    return f"{v:.3g}"


def _g(v: float, fmt: str = ".3g") -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return format(v, fmt)


def _consistent(e: EstimatorRecord) -> str:
    c = e.consistent
    if c is None:
        return "-"
    return f"{'yes' if c else 'NO'} (z={_g(e.z, '+.2f')})"


def problem_rows(p: ProblemRecord, error_kind: str = "signed") -> list[tuple[str, ...]]:
    """The table rows of one problem (header first)."""
    rows = [TABLE_HEADER]
    efmt = "+.2e" if error_kind == "signed" else ".2e"
    for e in p.estimators:
        if e.failed:
            rows.append((e.name, "failed", e.failed.splitlines()[0][:60], "", "", "", "", ""))
            continue
        if e.final is None:
            rows.append((e.name, "not run", "", "", "", "", "", ""))
            continue
        name = e.name + (" (interrupted)" if e.interrupted else "")
        rows.append((name, _si(e.samples_per_second), _g(e.variance_per_sample, ".3e"), _g(e.efficiency, ".3e"),
                     _g(p.relative_efficiency(e), ".3g"), _g(e.error, efmt), _consistent(e), _g(e.z_rms, ".2f")))
    return rows


def peer_comparison(p: ProblemRecord) -> str:
    """One line: the most efficient of ours against the most efficient peer ('' without peers).

    Efficiency (from the reported stderr) picks each side's best; the
    actual errors at the end are printed beside it as the cross-check.
    """
    def best(kind: str) -> EstimatorRecord | None:
        runs = [e for e in p.estimators if e.kind == kind and e.final is not None and not e.failed
                and math.isfinite(e.efficiency)]
        return max(runs, key=lambda e: e.efficiency) if runs else None

    ours, peer = best("engine"), best("peer")
    if ours is None or peer is None:
        return ""
    return (f"  best of ours vs best peer at equal time: {ours.name} (efficiency {_g(ours.efficiency, '.3e')}, "
            f"|error| {_g(abs(ours.error), '.2e')}) vs {peer.name} (efficiency {_g(peer.efficiency, '.3e')}, "
            f"|error| {_g(abs(peer.error), '.2e')}): {_g(ours.efficiency / peer.efficiency, '.3g')}x")


def _heading(p: ProblemRecord) -> str:
    s = p.summary
    dim = f"{s['dim']}-D, " if "dim" in s else ""
    if "width" in s and "reference" in s:
        return f"{p.name} ({s['width']}x{s['height']}, reference: {s['reference']}): {p.description}"
    if isinstance(s.get("exact_values"), list):
        exact = "exact " + ", ".join(f"{v:.8g}" for v in s["exact_values"]) + " at the query points"
    else:
        exact = f"exact {s['exact']:.12g}" if isinstance(s.get("exact"), float) else ""
    return f"{p.name} ({dim}{exact}): {p.description}"


def format_table(result: BenchResult) -> str:
    """The whole report as text (one table per problem)."""
    out = [f"mcocl bench {result.suite}: {result.budget:g} s per estimator, seed {result.options.seed}, "
           f"device {result.device or '?'}"]
    out.append(f"efficiency = 1 / (variance per sample x seconds per sample); rel. eff. against '{result.reference}'; "
               f"consistent when |error| <= {Z_CONSISTENT:g} x reported stderr;")
    out.append("rms z = root mean square of error/stderr over the checkpoints: about 1 when the stderr is honest, "
               "<< 1 when it overstates the error, >> 1 when it understates it")
    if result.error_kind == "rmse":
        out.append("error and stderr are root mean squares over the query points (pixels); samples count them all, "
                   "var/sample = stderr^2 x samples per point")
    for p in result.problems:
        out.append("")
        out.append(_heading(p))
        rows = problem_rows(p, result.error_kind)
        widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        for j, r in enumerate(rows):
            cells = [r[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(r[1:], widths[1:])]
            out.append("  " + "  ".join(cells).rstrip())
            if j == 0:
                out.append("  " + "  ".join("-" * w for w in widths))
        sp = p.numpy_speedup
        if math.isfinite(sp):
            out.append(f"  engine vs NumPy ({p.reference}, samples/s, same process): {sp:.1f}x")
        elif p.baseline_unavailable:
            out.append(f"  NumPy baseline: {p.baseline_unavailable}")
        line = peer_comparison(p)
        if line:
            out.append(line)
        for name, why in p.skipped:
            out.append(f"  skipped {name}: {why}")
        for e in p.estimators:
            if e.nonfinite:
                out.append(f"  WARNING {e.name}: {e.nonfinite} NaN/Inf samples left out of the estimate")
    if result.interrupted:
        out.append("")
        out.append("interrupted: the tables show what was computed before Ctrl-C")
    fails = result.failures
    if fails:
        out.append("")
        out.append(f"{len(fails)} run(s) failed:")
        out += [f"  {p} / {e}: {m}" for p, e, m in fails]
    return "\n".join(out) + "\n"


def write_csv(result: BenchResult, path: str | Path) -> None:
    """One row per checkpoint (columns :data:`CSV_COLUMNS`)."""
    write_atomically(path, lambda tmp: _write_csv(result, tmp))


def _write_csv(result: BenchResult, path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for p in result.problems:
            for e in p.estimators:
                for i, c in enumerate(e.checkpoints):
                    w.writerow([result.suite, p.name, e.name, e.kind, i, repr(float(c.seconds)), int(c.samples),
                                repr(float(c.estimate)), repr(float(c.stderr)), repr(float(c.error)), int(c.nonfinite),
                                int(c.points)])


def _clean(v: Any) -> Any:
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return v


def estimator_summary(p: ProblemRecord, e: EstimatorRecord) -> dict[str, Any]:
    """The final figures of one estimator (keys :data:`SUMMARY_FIELDS`)."""
    f = e.final
    return {
        "name": e.name, "kind": e.kind, "description": e.description, "samples": e.samples,
        "points": f.points if f else None,
        "seconds": e.seconds, "samples_per_second": e.samples_per_second,
        "estimate": f.estimate if f else None, "stderr": e.stderr,
        "variance_per_sample": e.variance_per_sample, "efficiency": e.efficiency,
        "relative_efficiency": p.relative_efficiency(e), "efficiency_from_error": e.efficiency_from_error,
        "error": e.error, "z": e.z, "consistent": e.consistent,
        "z_rms": e.z_rms, "nonfinite": e.nonfinite, "failed": e.failed or None, "interrupted": e.interrupted,
        "info": e.info,
    }


def summary(result: BenchResult) -> dict[str, Any]:
    """The JSON summary (strict JSON: NaN and infinities become null)."""
    return _clean({
        "suite": result.suite,
        "budget_seconds": result.budget,
        "started": result.started,
        "wall_seconds": result.wall_seconds,
        "interrupted": result.interrupted,
        "error_kind": result.error_kind,
        "reference_estimator": result.reference,
        "machine": result.machine(),
        "options": asdict(result.options),
        "consistency_bound_z": Z_CONSISTENT,
        "problems": [
            {**p.summary, "description": p.description, "numpy_speedup": p.numpy_speedup,
             "baseline_unavailable": p.baseline_unavailable or None,
             "skipped": [{"estimator": n, "reason": r} for n, r in p.skipped],
             "estimators": [estimator_summary(p, e) for e in p.estimators]}
            for p in result.problems
        ],
    })


def write_json(result: BenchResult, path: str | Path) -> None:
    """Write :func:`summary`."""
    text = json.dumps(summary(result), indent=2) + "\n"
    write_atomically(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_reports(result: BenchResult, out: str | Path) -> dict[str, Path]:
    """Table, CSV and JSON into ``out`` (created); returns their paths by kind."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    paths = {"table": d / f"{result.suite}-table.txt", "csv": d / f"{result.suite}-checkpoints.csv",
             "json": d / f"{result.suite}-summary.json"}
    table = format_table(result)
    write_atomically(paths["table"], lambda tmp: tmp.write_text(table, encoding="utf-8"))
    write_csv(result, paths["csv"])
    write_json(result, paths["json"])
    return paths
