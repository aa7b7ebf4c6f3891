"""Shared test setup: every test runs on the default OpenCL device (PoCL CPU in CI)."""

from __future__ import annotations

import warnings

import pyopencl as cl

# PoCL reports vector-ABI notes as compiler warnings; they are not test failures.
warnings.filterwarnings("ignore", category=cl.CompilerWarning)
