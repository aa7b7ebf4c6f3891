"""mcocl against Mitsuba 3 on a scene of the newer materials (tests/data/new_materials.xml).

The reference is Mitsuba 3.9.1's scalar_rgb render of the same file with its
per-pixel standard error (tests/data/README.md says how it was made).  mcocl
reads the XML itself (the Mitsuba reader: roughdielectric, thindielectric,
named-metal conductors, anisotropic roughconductor, twosided), renders it with
`mis`, and every 8x8 block of each channel must agree in a z-test at a 1e-3
family-wise level (Sidak correction over the blocks).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import stats

from mcocl.render.api import render

DATA = Path(__file__).resolve().parent / "data"


def _blocks(x: np.ndarray, b: int = 8) -> np.ndarray:
    h, w, c = x.shape
    return x.reshape(h // b, b, w // b, b, c).sum(axis=(1, 3))


def test_new_materials_match_mitsuba() -> None:
    ref = np.load(DATA / "new_materials_mitsuba.npz")
    r = render(str(DATA / "new_materials.xml"), spp=4096, seed=13)
    assert r.nonfinite == 0
    m1, m2 = _blocks(r.mean.astype(np.float64)), _blocks(ref["mean"].astype(np.float64))
    v = _blocks(r.variance.astype(np.float64)) + _blocks(ref["stderr"].astype(np.float64) ** 2)
    z = np.abs(m1 - m2) / np.sqrt(v)
    level = 1 - (1 - 1e-3) ** (1 / z.size)
    worst = np.unravel_index(np.argmax(z), z.shape)
    assert 2 * stats.norm.sf(z.max()) > level, \
        f"max z {z.max():.2f} at block {worst}: mcocl {m1[worst]:.4f}, Mitsuba {m2[worst]:.4f}"
    assert np.all(m2 > 0)


def test_convert_keeps_the_new_materials(tmp_path) -> None:
    """`mcocl convert` writes JSON that compiles to the XML's materials table (records and roughplastic tables)."""
    from mcocl.cli import main
    from mcocl.render.compiled import compile_scene

    xml = tmp_path / "s.xml"
    text = (DATA / "new_materials.xml").read_text()
    xml.write_text(text.replace('<bsdf type="thindielectric" id="pane"/>',
                                '<bsdf type="thindielectric" id="pane"/><bsdf type="roughplastic" id="coat">'
                                '<float name="alpha" value="0.2"/></bsdf>'))
    out = tmp_path / "s.json"
    assert main(["convert", str(xml), "-o", str(out)]) == 0
    a, b = compile_scene(out).materials, compile_scene(xml).materials
    assert a.shape == (7 + 5, 16) and np.array_equal(a, b)
