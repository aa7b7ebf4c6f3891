"""Mitsuba XML scenes for mcocl: :func:`read_mitsuba` turns a Mitsuba 3 (or 0.6) ``.xml`` file into
mcocl's JSON scene dictionary, which :func:`mcocl.render.scene_file.load_scene` then validates and compiles.

Modules: :mod:`.xml_source` (safe parsing with lines, ``<default>``,
``$name``, ``<include>``, 0.6 upgrade), :mod:`.properties` (typed values and
transforms), :mod:`.spectra` (spectra → RGB, named IORs), :mod:`.sensor`,
:mod:`.bsdf`, :mod:`.shape` (plugins), :mod:`.report` (strict or lenient),
:mod:`.reader` (the scene).  The mapping is documented in scenes/README.md,
"Mitsuba XML".
"""

from .reader import load_mitsuba, read_mitsuba

__all__ = ["load_mitsuba", "read_mitsuba"]
