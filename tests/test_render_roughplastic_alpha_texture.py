"""A textured alpha on roughplastic: its coat's tables as a grid over alpha (mcocl/render/roughplastic_tables.py
alpha_grid, alpha_grid_tables; kernels/render/bsdf_roughplastic.cl roughplastic_coat).

- Between two grid alphas, the linear interpolation in log alpha of their
  tables is within 5e-4 of the table computed at that alpha.
- The kernel on the grid (alpha between grid points): chi-square of its
  sampling against its pdf, weight = f cos / pdf, and a white furnace that
  stays at most 1 and within 2e-3 of the exact table's albedo at that alpha.
- A constant alpha texture renders as the scalar alpha within float rounding
  (not bit for bit: the kernel's luminance of the texel can differ from the
  scalar in the last bit: measured 2.4e-7 relative at alpha 0.3, equal at 0.25 and 0.1).
- Mitsuba's roughplastic with an alpha texture imports as one.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from chi2 import Chi2Family
from direction_bins import converged_counts, directions_to_bins
from test_render_bsdf import N, evaluate, sample
from test_render_bsdf_roughplastic import _table, _unit

import mcocl
from mcocl.bsdf_registry import FLAG_BITS
from mcocl.render.roughplastic_tables import GRID_RATIO, RES, TABLE_FLOATS, alpha_grid, roughplastic_table
from mcocl.render.scene_file import load_scene

CHECKER = {"type": "checkerboard", "color0": 0.05, "color1": 0.6}  # alphas 0.05 and 0.6: the record holds 0.325


def test_grid_interpolates_the_tables() -> None:
    alphas = alpha_grid(np.array([[0.05] * 3, [0.6] * 3]))
    assert abs(alphas[0] - 0.05) < 1e-7 and abs(alphas[-1] - 0.6) < 1e-7  # float32 texels
    assert np.all(alphas[1:] / alphas[:-1] <= GRID_RATIO * (1 + 1e-12))
    assert len(alpha_grid(np.full((4, 3), 0.3))) == 1
    for k in (0, len(alphas) // 2, len(alphas) - 2):
        a, b = roughplastic_table(alphas[k], 1.49, False), roughplastic_table(alphas[k + 1], 1.49, False)
        mid = np.sqrt(alphas[k] * alphas[k + 1])
        exact = roughplastic_table(mid, 1.49, False)
        np.testing.assert_allclose(0.5 * (a + b)[:RES + 1], exact[:RES + 1], atol=5e-4)


FAMILY = Chi2Family("roughplastic alpha grid sampling", 2)


def test_kernel_on_the_grid_samples_its_pdf_and_keeps_energy() -> None:
    mats = _table(alpha=CHECKER, diffuse_reflectance=1.0)
    assert int(mats[0, 7]) & FLAG_BITS["alpha_grid"] and abs(mats[0, 4] - 0.325) < 1e-6
    start = int(mats[0, 15])
    assert mats.size - start == len(alpha_grid(np.array([[0.05] * 3, [0.6] * 3]))) * TABLE_FLOATS
    exact = _table(alpha=float(mats[0, 4]), diffuse_reflectance=1.0)
    for theta in (30.0, 75.0):
        wi = _unit(theta)
        s = sample(mats, wi)
        valid = s["pdf"] > 0
        idx = directions_to_bins(s["wo"][valid], 20, 40, (0.0, 1.0))
        observed, expected = converged_counts(lambda dirs, wi=wi: evaluate(mats, wi, dirs)[1], idx, N, 20, 40,
                                              (0.0, 1.0))
        FAMILY.check(f"grid {theta:g} deg", observed, expected)
        f, pdf = evaluate(mats, wi, s["wo"][valid][:4096])
        np.testing.assert_allclose(f / pdf[:, None], s["weight"][valid][:4096], rtol=2e-3)
        w = s["weight"][:, 0].astype(np.float64)
        mean, se = w.mean(), w.std() / np.sqrt(len(w))
        assert mean <= 1 + 5 * se + 1e-6
        ref = sample(exact, wi)["weight"][:, 0].astype(np.float64).mean()  # same seed: the same draws
        assert abs(mean - ref) < 2e-3, (theta, mean, ref)


def _sky_scene(tmp_path: Path, name: str, alpha) -> Path:
    data = {"camera": {"origin": [0, 0, 1], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 90, "width": 16,
                       "height": 16},
            "integrator": {"type": "mis", "max_depth": 2},
            "materials": {"m": {"type": "roughplastic", "alpha": alpha, "diffuse_reflectance": [0.6, 0.3, 0.2]}},
            "environment": {"type": "constant", "radiance": 1.0},
            "shapes": [{"type": "rectangle", "material": "m", "transform": [{"scale": [1.25, 1.25, 1]}]}]}
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


def test_constant_alpha_texture_renders_as_the_scalar(tmp_path: Path) -> None:
    plain = mcocl.render(_sky_scene(tmp_path, "p.json", 0.3), spp=4, seed=3)
    tex = mcocl.render(_sky_scene(tmp_path, "t.json", {"type": "checkerboard", "color0": 0.3, "color1": 0.3}),
                       spp=4, seed=3)
    np.testing.assert_allclose(tex.mean, plain.mean, rtol=1e-5, atol=1e-7)


def test_mitsuba_roughplastic_takes_an_alpha_texture(tmp_path: Path) -> None:
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"/><shape type="sphere"><bsdf type="roughplastic">'
        '<texture type="checkerboard" name="alpha"><float name="color0" value="0.05"/>'
        '<float name="color1" value="0.6"/></texture></bsdf></shape></scene>')
    m = load_scene(tmp_path / "s.xml").materials[0]
    assert m.kind == "roughplastic" and "alpha" in m.textures and m.flags & FLAG_BITS["alpha_grid"]
