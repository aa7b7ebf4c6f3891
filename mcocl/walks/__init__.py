"""Integral equations of the second kind by random walks (lecture: "Řešení
integrálních rovnic" .. "Odhad příští události"), and the Nyström reference."""

from .api import FredholmResult, solve_fredholm
from .codegen import ESTIMATORS
from .nystrom import NystromSolution, nystrom, spectral_radius

__all__ = ["ESTIMATORS", "FredholmResult", "NystromSolution", "nystrom", "solve_fredholm", "spectral_radius"]
