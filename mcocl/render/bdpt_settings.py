"""The settings of bidirectional path tracing (``integrator="bdpt"``, kernels/render/bdpt.cl), checked."""

from __future__ import annotations

from typing import Any

from ..errors import InputError
from ..validate import whole_number
from .compiled import CompiledScene
from .job import MIS_BETAS

# The most vertices of one subpath, the kernel's BDPT_MAX_VERTICES (kernels/render/bdpt.cl, never redefined).
BDPT_MAX_VERTICES = 24


def bdpt_settings(cs: CompiledScene, mis: Any = "power", strategy: Any = None, unweighted: Any = False,
                  roulette: Any = True) -> dict[str, Any]:
    """The RenderJob keywords ``mis``, ``strategy``, ``unweighted``, ``roulette`` for scene ``cs``.

    Empty unless ``cs.integrator`` is ``bdpt`` (the other integrators take none
    of them, so that giving one to them is an error, not silently ignored).

    Raises:
        InputError: an unknown heuristic, a malformed strategy, ``unweighted``
            without a strategy, ``roulette`` not a bool, or one of them for another integrator.
    """
    if cs.integrator != "bdpt":
        if mis != "power" or strategy is not None or unweighted or roulette is not True:
            raise InputError(f"mis, strategy, unweighted and roulette are bdpt's settings, not {cs.integrator}'s")
        return {}
    if mis not in MIS_BETAS:
        raise InputError(f"mis: unknown heuristic {mis!r}; choose one of {', '.join(MIS_BETAS)}")
    if strategy is not None:
        # a pair of whole numbers: int() would take (1.5, 2) for (1, 2) and the string "12" for (1, 2)
        if not isinstance(strategy, (tuple, list)) or len(strategy) != 2:
            raise InputError(f"strategy: expected two whole numbers s,t, got {strategy!r}")
        try:
            s, t = (whole_number("strategy", x, -(2**63)) for x in strategy)
        except InputError:
            raise InputError(f"strategy: expected two whole numbers s,t, got {strategy!r}") from None
        if s < 0 or t < 1:
            raise InputError(f"strategy: s >= 0 light vertices and t >= 1 camera vertices, got ({s}, {t})")
        if max(s, t) > BDPT_MAX_VERTICES:
            # the kernel's subpaths end there: a longer strategy would render nothing, silently
            raise InputError(f"strategy: ({s}, {t}) has more than {BDPT_MAX_VERTICES} vertices on one subpath, "
                             "bdpt's limit")
        if s + t < 2:
            raise InputError(f"strategy: a path needs s + t >= 2 vertices, got ({s}, {t})")
        if cs.max_depth >= 0 and s + t - 1 > cs.max_depth:
            raise InputError(f"strategy: ({s}, {t}) makes paths of {s + t - 1} segments, above max_depth "
                             f"{cs.max_depth}")
        strategy = (s, t)
    elif unweighted:
        raise InputError("unweighted: only with a strategy")
    if not isinstance(roulette, bool):
        raise InputError(f"roulette: expected True or False, got {roulette!r}")
    return {"mis": mis, "strategy": strategy, "unweighted": bool(unweighted), "roulette": roulette}


__all__ = ["BDPT_MAX_VERTICES", "bdpt_settings"]
