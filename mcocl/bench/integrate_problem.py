"""An integration problem of the bench: an integrand, its exact integral, its estimators.

Which estimators a problem gets follows from what it carries:

============================  =================================================
always                        ``independent``, ``stratified``, ``nrooks``
one proposal                  ``importance`` (``proposal=``)
two or more proposals         one single-proposal estimator per proposal (named
                              by ``proposal_names``), then the combined
                              estimators ``average``, ``max``, ``balance``,
                              ``power`` (``proposals=``, ``shares=``)
a control variate             ``control`` (``control=``, ``control_integral=``)
``extra``                     named keyword sets of ``mcocl.integrate``
                              (e.g. ``roulette``)
``peers`` (``--peers``)       mcocl's ``sobol`` and ``vegas`` samplers, and the
                              peers ``scipy-sobol`` and ``vegas-package``
                              (:mod:`.integrate_peers`) on the NumPy twin
============================  =================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..errors import InputError, KernelBuildError
from ..integration import integrate
from .integrate_peers import ScipySobolRun, VegasPackageRun, missing_peers
from .integrate_run import DoublingRun, IntegrationRun, RestartedRun
from .numpy_baseline import DEFAULT_CHUNK, NumpyPlainRun, TranslationError, compile_numpy, translate_opencl
from .suite import BaselineSpec, EstimatorSpec

SAMPLER_ESTIMATORS = ("independent", "stratified", "nrooks")
# Samples per design: stratified 2^20 (m^dim strata of 2 samples, m = floor((2^19)^(1/dim)));
# N-rooks 2^16-point Latin hypercubes.  The same as mcocl.integrate's defaults for runs without a
# sample count; fixed here because the bench's steps give sample counts (which would size the design).
DESIGN_SAMPLES = {"stratified": 1 << 20, "nrooks": 1 << 16}
# mcocl's estimators beside the peers, each rerun afresh per checkpoint: Sobol' with its
# default 16 replicates and doubled samples (DoublingRun), VEGAS given the checkpoint's time
# (RestartedRun); resuming would add replicates or iterations of a fixed size instead.
PEER_SAMPLERS = {"sobol": {"sampler": "sobol"}, "vegas": {"sampler": "vegas"}}
PEER_RUNS = {"sobol": DoublingRun, "vegas": RestartedRun}
COMBINED_ESTIMATORS = ("average", "max", "balance", "power")


@dataclass
class IntegrationProblem:
    """An integral over [0, 1]^dim with a known value.

    Attributes:
        name: short unique name (table headings, ``--only``).
        expression: OpenCL C integrand over ``float x[dim]``.
        dim: dimension.
        exact: the exact integral.
        description: one line: what the problem tests.
        numpy: NumPy twin over ``x`` of shape ``(dim, n)``; None: translate
            ``expression`` if it is simple enough.
        proposals: proposal specs as :func:`mcocl.integrate` takes them.
        proposal_names: estimator names of the single proposals.
        shares: samples per proposal per unit of the combined estimators.
        control: control variate g (OpenCL C), with ``control_integral`` J.
        extra: more estimators: name -> keyword arguments of ``mcocl.integrate``.
        source: where the problem was defined (``built-in`` or a file).
        only_estimators: run only these (the quick subset), None: all.
        seed, device, lanes, chunk: run settings filled in by the suite.
        peers: add mcocl's sobol and vegas and the peers (``--peers``).
        budget: seconds per estimator (sizes the vegas package's iterations).
    """

    name: str
    expression: str
    dim: int
    exact: float
    description: str = ""
    numpy: str | None = None
    proposals: list[Any] = field(default_factory=list)
    proposal_names: list[str] = field(default_factory=list)
    shares: list[int] | None = None
    control: str | None = None
    control_integral: float | None = None
    extra: dict[str, dict[str, Any]] = field(default_factory=dict)
    source: str = "built-in"
    only_estimators: list[str] | None = None
    seed: int = 1
    device: Any = None
    lanes: int | None = None
    chunk: int = DEFAULT_CHUNK
    peers: bool = False
    budget: float = 1.0

    def estimator_options(self) -> dict[str, dict[str, Any]]:
        """Estimator name -> keyword arguments of :func:`mcocl.integrate`, in table order."""
        out: dict[str, dict[str, Any]] = {"independent": {"sampler": "independent"}}
        out.update({s: {"sampler": s, "design_samples": DESIGN_SAMPLES[s]} for s in ("stratified", "nrooks")})
        if len(self.proposals) == 1:
            out[self.proposal_names[0] if self.proposal_names else "importance"] = {"proposal": self.proposals[0]}
        elif len(self.proposals) > 1:
            names = self.proposal_names or [f"proposal{i + 1}" for i in range(len(self.proposals))]
            for n, p in zip(names, self.proposals):
                out[n] = {"proposal": p}
            for h in COMBINED_ESTIMATORS:
                out[h] = {"proposals": list(self.proposals), "shares": self.shares, "heuristic": h}
        if self.control is not None:
            out["control"] = {"control": self.control, "control_integral": self.control_integral}
        for n, kw in self.extra.items():
            out[n] = dict(kw)
        if self.peers:
            out.update({n: dict(kw) for n, kw in PEER_SAMPLERS.items()})
        return out

    def _describe(self, name: str, kw: dict[str, Any]) -> str:
        if "proposals" in kw:
            return f"combined estimator, {kw['heuristic']} weights, one sample per proposal"
        if "proposal" in kw:
            return "importance sampling"
        if "control" in kw:
            return f"control variate g = {kw['control']}"
        if "roulette" in kw:
            return f"Russian roulette, survival P = {kw['roulette']}"
        if kw.get("sampler") == "sobol":
            return "Owen-scrambled Sobol', 16 replicates, samples doubled per checkpoint (rerun afresh)"
        if kw.get("sampler") == "vegas":
            return "VEGAS adaptive importance sampling, run afresh for each checkpoint's time"
        return {"independent": "plain secondary estimator",
                "stratified": f"jittered strata, 2 samples each, designs of <= {DESIGN_SAMPLES['stratified']} samples",
                "nrooks": f"Latin hypercube designs of {DESIGN_SAMPLES['nrooks']} points"}.get(kw.get("sampler", ""), name)

    def estimators(self) -> list[EstimatorSpec]:
        """The estimator specs (runs start, and compile, when called)."""
        specs = []
        for name, kw in self.estimator_options().items():
            if self.only_estimators is not None and name not in self.only_estimators:
                continue

            run = PEER_RUNS.get(kw.get("sampler", ""), IntegrationRun) if name in PEER_SAMPLERS else IntegrationRun

            def start(kw: dict[str, Any] = kw, run: type = run) -> IntegrationRun | RestartedRun:
                return run(self.expression, self.dim, self.exact, kw, self.seed, self.device, self.lanes)

            specs.append(EstimatorSpec(name, start, self._describe(name, kw)))
        if self.peers:
            specs += [s for s in self._peer_specs()
                      if self.only_estimators is None or s.name in self.only_estimators]
        return specs

    def _peer_specs(self) -> list[EstimatorSpec]:
        """The peers that can run here (their package installed, a NumPy twin)."""
        missing = dict(self.unavailable())
        expr = self.numpy_expression()[0]
        specs = []
        if "scipy-sobol" not in missing:
            def sobol() -> ScipySobolRun:
                return ScipySobolRun(compile_numpy(expr, self.dim), self.dim, self.exact, self.seed)

            specs.append(EstimatorSpec("scipy-sobol", sobol, "scipy.stats.qmc.Sobol(scramble=True), 16 replicates, "
                                       "NumPy twin", kind="peer"))
        if "vegas-package" not in missing:
            def vegas() -> VegasPackageRun:
                return VegasPackageRun(compile_numpy(expr, self.dim), self.dim, self.exact, self.seed, self.budget)

            specs.append(EstimatorSpec("vegas-package", vegas, "vegas.Integrator, NumPy twin, first quarter of the "
                                       "time adapts only", kind="peer"))
        return specs

    def unavailable(self) -> list[tuple[str, str]]:
        """(peer, why it cannot run) for the peers left out (only with ``peers``)."""
        if not self.peers:
            return []
        expr, how = self.numpy_expression()
        if expr is not None:
            try:
                compile_numpy(expr, self.dim)
            except ValueError as e:
                expr, how = None, f"NumPy twin {expr!r}: {e}"
        if expr is None:
            return [(name, f"peers evaluate the NumPy twin; {how}") for name in ("scipy-sobol", "vegas-package")]
        return list(missing_peers().items())

    def numpy_expression(self) -> tuple[str | None, str]:
        """(NumPy twin, how it was obtained) or (None, why there is none)."""
        if self.numpy is not None:
            return self.numpy, "given"
        try:
            return translate_opencl(self.expression), "translated from the OpenCL C expression"
        except TranslationError as e:
            return None, f"no NumPy twin: {e} (add a \"numpy\" field to the problem)"

    def baseline(self) -> BaselineSpec:
        """The plain estimator in NumPy float64, or why there is none."""
        expr, how = self.numpy_expression()
        if expr is None:
            return BaselineSpec(None, unavailable=how)
        try:
            func = compile_numpy(expr, self.dim)
        except ValueError as e:
            return BaselineSpec(None, unavailable=f"NumPy twin {expr!r}: {e}")

        def start() -> NumpyPlainRun:
            return NumpyPlainRun(func, self.dim, self.exact, self.seed, self.chunk)

        return BaselineSpec(start, f"NumPy float64, Generator(PCG64), chunks of {self.chunk} ({how})")

    def summary(self) -> dict[str, Any]:
        """JSON facts about the problem."""
        return {"name": self.name, "dim": self.dim, "exact": self.exact, "expression": self.expression,
                "description": self.description, "source": self.source,
                "proposals": self.proposals or None, "control": self.control}

    def check(self) -> None:
        """Compile every part of the problem before anything runs.

        Raises:
            InputError: naming the problem and the field (``expression``,
                ``proposals[i]``, ``control``, ``estimators.<name>`` (the extra estimators), ``numpy``).
        """
        where = f"problem {self.name!r} ({self.source})"
        if self.numpy is not None:
            try:
                compile_numpy(self.numpy, self.dim)
            except ValueError as e:
                raise InputError(f"{where}, field 'numpy': {e}") from None
        parts: list[tuple[str, dict[str, Any]]] = [("expression", {})]
        parts += [(f"proposals[{i}]", {"proposal": p}) for i, p in enumerate(self.proposals)]
        if len(self.proposals) > 1:
            parts.append(("shares", {"proposals": list(self.proposals), "shares": self.shares}))
        if self.control is not None:
            parts.append(("control", {"control": self.control, "control_integral": self.control_integral}))
        parts += [(f"estimators.{n}", kw) for n, kw in self.extra.items()]
        for fld, kw in parts:
            try:
                integrate(self.expression, self.dim, 1, seed=self.seed, device=self.device, lanes=self.lanes, **kw)
            except KernelBuildError as e:
                raise KernelBuildError(f"{where}, field {fld!r}: {e}", e.log) from None
            except InputError as e:
                raise InputError(f"{where}, field {fld!r}: {e}") from None
            except TypeError as e:  # an unknown keyword in "extra"
                raise InputError(f"{where}, field {fld!r}: {e}") from None
        if not math.isfinite(self.exact):
            raise InputError(f"{where}, field 'exact': must be a finite number, got {self.exact!r}")
