"""A mark for tests of the vector build: skipped where the default device builds one lane.

GPUs build one lane (they vectorise across work-items), and ``MCOCL_LANES=1``
forces the scalar build everywhere; a test of the fallback from the vector
build to the scalar one has nothing to test there.
"""

from __future__ import annotations

import pytest

from mcocl import runtime


def _default_lanes() -> int:
    try:
        return runtime.device_context(None).lanes
    except Exception:  # no device: the tests that need one report that themselves
        return 1


needs_vector_lanes = pytest.mark.skipif(_default_lanes() == 1,
                                        reason="the default device builds one lane: no vector build to test")
