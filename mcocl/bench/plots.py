"""PNG plots of a bench (matplotlib, imported only when plotting).

``S-error-vs-time.png``  one panel per problem, log-log: the actual |error|
                         of each estimator against its sampling time (solid,
                         markers at the checkpoints) and the standard error
                         it reported (dotted, same colour), with a grey
                         dashed line of slope -1/2 (error ~ 1/sqrt(t), the
                         rate of every unbiased estimator at a fixed
                         throughput) for reference.  Lines lower down are
                         better; the vertical gap between two parallel lines
                         is the square root of their efficiency ratio.
``S-efficiency.png``     one panel per problem: each estimator's efficiency
                         relative to ``independent`` (log scale bars).

Uses the Agg canvas directly (no pyplot state, no display needed).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..errors import PlottingUnavailableError
from ..output_files import write_atomically
from .runner import BenchResult, ProblemRecord


def _figure(width: float, height: float) -> Any:
    """A matplotlib Figure on an Agg canvas (imports matplotlib here, lazily)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise PlottingUnavailableError(
            "the bench plots need matplotlib, which is not installed: pip install 'mcocl[plot]' "
            "(or pip install matplotlib), or run the bench with --no-plot; the table, CSV and JSON were written"
        ) from None
    fig = Figure(figsize=(width, height), dpi=110)
    FigureCanvasAgg(fig)
    return fig


def _grid(n: int) -> tuple[int, int]:
    cols = min(3, max(n, 1))
    return -(-max(n, 1) // cols), cols


def _panel_errors(ax: Any, p: ProblemRecord, colors: dict[str, Any], error_label: str) -> None:
    ref_anchor = None
    for e in p.estimators:
        pts = [(c.seconds, abs(c.error), c.stderr) for c in e.checkpoints
               if c.seconds > 0 and math.isfinite(c.error)]
        if not pts or e.failed:
            continue
        col = colors[e.name]
        t = [q[0] for q in pts]
        err = [max(q[1], 1e-300) for q in pts]
        style = "--" if e.kind == "numpy" else "-"
        ax.plot(t, err, style, marker="o", markersize=2.5, linewidth=1.2, color=col, label=e.name)
        se = [(q[0], q[2]) for q in pts if math.isfinite(q[2]) and q[2] > 0]
        if se:
            ax.plot([q[0] for q in se], [q[1] for q in se], ":", linewidth=0.9, color=col)
        if e.name == p.reference or ref_anchor is None:
            if se:
                ref_anchor = se[len(se) // 2]
    if ref_anchor is not None:
        t0, s0 = ref_anchor
        all_t = [c.seconds for e in p.estimators for c in e.checkpoints if c.seconds > 0]
        lo, hi = min(all_t), max(all_t)
        ax.plot([lo, hi], [s0 * math.sqrt(t0 / lo), s0 * math.sqrt(t0 / hi)], "--", color="0.55", linewidth=1.0,
                label="1/√t")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_title(p.name, fontsize=9)
    ax.set_xlabel("seconds", fontsize=8)
    ax.set_ylabel(error_label, fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(True, which="major", linewidth=0.3, alpha=0.5)
    ax.legend(fontsize=6, loc="best", ncol=2, framealpha=0.6)


# Fixed colours for the estimators most panels share; the others take the
# remaining tab10 colours in panel order.
FIXED_COLORS = {
    "integrate": {"independent": "C0", "stratified": "C1", "nrooks": "C2", "numpy": "black"},
    "solve": {"roulette": "C0", "subcritical": "C1", "nee": "C2", "truncated": "C7", "numpy": "black"},
    "render": {"path": "C0", "nee": "C3", "mis": "C2"},
}
OTHER_COLORS = ("C3", "C4", "C5", "C6", "C8", "C9", "C7")


def _colors(p: ProblemRecord, suite: str) -> dict[str, Any]:
    fixed = FIXED_COLORS.get(suite, {})
    others = iter([c for c in OTHER_COLORS if c not in fixed.values()] * 4)
    return {e.name: fixed.get(e.name) or next(others) for e in p.estimators}


def plot_error_vs_time(result: BenchResult, path: str | Path) -> Path:
    """The error-versus-time figure (see the module docstring)."""
    probs = [p for p in result.problems if any(e.checkpoints for e in p.estimators)]
    rows, cols = _grid(len(probs))
    fig = _figure(4.2 * cols, 3.3 * rows)
    label = "|error| (—), reported stderr (··)" if result.error_kind == "signed" else "RMSE (—), stderr (··)"
    for i, p in enumerate(probs):
        _panel_errors(fig.add_subplot(rows, cols, i + 1), p, _colors(p, result.suite), label)
    fig.suptitle(f"mcocl bench {result.suite}: error versus time ({result.device or 'OpenCL'})", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    write_atomically(path, fig.savefig)
    return Path(path)


def plot_efficiency(result: BenchResult, path: str | Path) -> Path:
    """Bars of efficiency relative to ``independent`` per problem (log scale)."""
    probs = [p for p in result.problems if p.get(p.reference) is not None]
    rows, cols = _grid(len(probs))
    fig = _figure(4.2 * cols, 2.8 * rows)
    from matplotlib.ticker import NullFormatter

    for i, p in enumerate(probs):
        ax = fig.add_subplot(rows, cols, i + 1)
        colors = _colors(p, result.suite)
        bars = [(e.name, p.relative_efficiency(e)) for e in p.estimators if e.final and not e.failed]
        bars = [(n, r) for n, r in bars if math.isfinite(r) and r > 0]
        ax.barh([n for n, _ in bars], [r for _, r in bars], color=[colors[n] for n, _ in bars])
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.axvline(1.0, color="0.4", linewidth=0.8)
        ax.invert_yaxis()
        ax.set_title(p.name, fontsize=9)
        ax.set_xlabel(f"efficiency / efficiency({p.reference})", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, axis="x", linewidth=0.3, alpha=0.5)
    fig.suptitle(f"mcocl bench {result.suite}: efficiency relative to {result.reference}", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    write_atomically(path, fig.savefig)
    return Path(path)


def write_plots(result: BenchResult, out: str | Path) -> dict[str, Path]:
    """Both figures into ``out``; returns their paths.

    Raises:
        PlottingUnavailableError: matplotlib is missing (message says how to install it).
    """
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    paths = {"error_plot": plot_error_vs_time(result, d / f"{result.suite}-error-vs-time.png")}
    if any(p.get(p.reference) is not None for p in result.problems):
        paths["efficiency_plot"] = plot_efficiency(result, d / f"{result.suite}-efficiency.png")
    return paths
