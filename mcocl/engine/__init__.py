"""The engine: how a job's blocks are computed, wherever they run.

A *job* (:class:`~mcocl.engine.contract.BlockJob`) is a range of blocks whose
statistics are folded in block order into an
:class:`~mcocl.accumulate.Accumulator`.  The package is layered; each module
imports only the layers below it, never a sibling back end:

- :mod:`~mcocl.engine.contract`: what a job, a runner, the halting rules, a
  progress report, a placement and a run's report are; Ctrl-C handling;
- :mod:`~mcocl.engine.chunking`: the one chunk-sizing policy and the queue
  that hands chunks out;
- :mod:`~mcocl.engine.fold`: the one loop that folds finished chunks, reports
  progress, saves checkpoints and applies the halting rules;
- back ends: :mod:`~mcocl.engine.one_device`,
  :mod:`~mcocl.engine.multi_device`, :mod:`~mcocl.engine.dask_cluster`;
- :mod:`~mcocl.engine.dispatch`: :func:`~mcocl.engine.dispatch.execute`,
  which picks the back end a placement asks for.

This file imports nothing: each user imports the layer it needs, and
importing the contract does not load every back end.
"""
