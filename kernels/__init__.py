"""The engine's OpenCL C sources, installed as the package data ``mcocl/kernels``.

In the source tree they live in the top-level ``kernels/`` folder; this file
makes the folder a package so that an editable install resolves
``mcocl.kernels`` to it (see ``pyproject.toml``).
"""
