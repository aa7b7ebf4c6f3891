"""Monte Carlo integration (lecture: "Monte Carlo integrace" .. "Řídící funkce")."""

from .api import HeavyTailWarning, IntegrationResult, NonFiniteWarning, integrate
from .proposals import Proposal, analytic, exponential, power, tabulated, tabulated2d, truncnorm, uniform

__all__ = [
    "IntegrationResult",
    "HeavyTailWarning",
    "NonFiniteWarning",
    "Proposal",
    "analytic",
    "exponential",
    "integrate",
    "power",
    "tabulated",
    "tabulated2d",
    "truncnorm",
    "uniform",
]
