"""Spectra in Mitsuba files as linear sRGB, and Mitsuba's table of named indices of refraction.

Mitsuba 3's RGB variants turn a ``<spectrum>`` into linear sRGB by rules that
depend on the property it gives (scenes/README.md, "Mitsuba XML"); mcocl's
reader follows them, measured against Mitsuba 3.9.1 ``scalar_rgb``
(tests/test_mitsuba_xml.py):

- One number ``v``: the grey (v, v, v) for a reflectance or any other
  non-emitted property; for an emitted one (``radiance``, ``irradiance``,
  ``intensity``) the colour of the spectrum that is ``v`` at every wavelength,
  the equal-energy white ``v`` · (1.20479, 0.94829, 0.90892), XYZ = (v, v, v)
  in sRGB (whose white is D65), as Mitsuba's spectral variants would see it.
- Wavelength:value pairs ``s(λ)``, linear between the given wavelengths and
  zero outside them: CIE 1931 XYZ ``X = ∫ s(λ) w(λ) x̄(λ) dλ / ∫ ȳ(λ) dλ``
  (likewise Y, Z) over 360–830 nm, with the colour-matching functions linear
  between the 5 nm samples of the CIE 1931 2° standard observer below
  (CIE 15:2004, table T.4), then linear sRGB (ITU-R BT.709 primaries, D65
  white) by the standard XYZ → RGB matrix. The weight ``w`` is 1 for an
  emitted property; for anything else (a reflectance, a conductor's eta/k) it
  is the CIE D65 illuminant (table T.1) divided by ``∫ȳ D65 / ∫ȳ``, so a flat
  spectrum is grey: a reflectance is the colour it has under daylight.
  The integral is Mitsuba's Riemann sum (1000 wavelengths evenly spaced over
  360–830 nm, both ends included, each weighted 0.47 nm, and Mitsuba's
  normalising constants), so colours agree with Mitsuba's to float precision
  (the sum is 0.1 % below the integral, and a flat reflectance of 0.6 comes out
  (0.5972, 0.5999, 0.5969)). Negative components (outside the sRGB gamut) are
  clamped to zero; a bounded property (not emitted, not a conductor's eta/k)
  is also clipped to at most 1.
"""

from __future__ import annotations

import difflib

import numpy as np

CIE_MIN_NM = 360.0
CIE_STEP_NM = 5.0

# CIE 1931 2° colour-matching functions x̄, ȳ, z̄ at 360, 365, ..., 830 nm (95 samples each).
_CIE_X = """
0.0001299 0.0002321 0.0004149 0.0007416 0.001368 0.002236 0.004243 0.00765 0.01431 0.02319 0.04351 0.07763
0.13438 0.21477 0.2839 0.3285 0.34828 0.34806 0.3362 0.3187 0.2908 0.2511 0.19536 0.1421 0.09564 0.05795001
0.03201 0.0147 0.0049 0.0024 0.0093 0.0291 0.06327 0.1096 0.1655 0.2257499 0.2904 0.3597 0.4334499 0.5120501
0.5945 0.6784 0.7621 0.8425 0.9163 0.9786 1.0263 1.0567 1.0622 1.0456 1.0026 0.9384 0.8544499 0.7514 0.6424
0.5419 0.4479 0.3608 0.2835 0.2187 0.1649 0.1212 0.0874 0.0636 0.04677 0.0329 0.0227 0.01584 0.01135916
0.008110916 0.005790346 0.004109457 0.002899327 0.00204919 0.001439971 0.0009999493 0.0006900786
0.0004760213 0.0003323011 0.0002348261 0.0001661505 0.000117413 8.307527e-05 5.870652e-05 4.150994e-05
2.935326e-05 2.067383e-05 1.455977e-05 1.025398e-05 7.221456e-06 5.085868e-06 3.581652e-06 2.522525e-06
1.776509e-06 1.251141e-06
"""
_CIE_Y = """
3.917e-06 6.965e-06 1.239e-05 2.202e-05 3.9e-05 6.4e-05 0.00012 0.000217 0.000396 0.00064 0.00121 0.00218
0.004 0.0073 0.0116 0.01684 0.023 0.0298 0.038 0.048 0.06 0.0739 0.09098 0.1126 0.13902 0.1693 0.20802 0.2586
0.323 0.4073 0.503 0.6082 0.71 0.7932 0.862 0.9148501 0.954 0.9803 0.9949501 1.0 0.995 0.9786 0.952 0.9154
0.87 0.8163 0.757 0.6949 0.631 0.5668 0.503 0.4412 0.381 0.321 0.265 0.217 0.175 0.1382 0.107 0.0816 0.061
0.04458 0.032 0.0232 0.017 0.01192 0.00821 0.005723 0.004102 0.002929 0.002091 0.001484 0.001047 0.00074
0.00052 0.0003611 0.0002492 0.0001719 0.00012 8.48e-05 6e-05 4.24e-05 3e-05 2.12e-05 1.499e-05 1.06e-05
7.4657e-06 5.2578e-06 3.7029e-06 2.6078e-06 1.8366e-06 1.2934e-06 9.1093e-07 6.4153e-07 4.5181e-07
"""
_CIE_Z = """
0.0006061 0.001086 0.001946 0.003486 0.006450001 0.01054999 0.02005001 0.03621 0.06785001 0.1102 0.2074
0.3713 0.6456 1.0390501 1.3856 1.62296 1.74706 1.7826 1.77211 1.7441 1.6692 1.5281 1.28764 1.0419 0.8129501
0.6162 0.46518 0.3533 0.272 0.2123 0.1582 0.1117 0.07824999 0.05725001 0.04216 0.02984 0.0203 0.0134
0.008749999 0.005749999 0.0039 0.002749999 0.0021 0.0018 0.001650001 0.0014 0.0011 0.001 0.0008 0.0006
0.00034 0.00024 0.00019 0.0001 4.999999e-05 3e-05 2e-05 1e-05 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
0 0 0 0 0 0 0 0 0 0 0 0 0 0
"""
CIE_XYZ = np.array([np.array(t.split(), dtype=np.float64) for t in (_CIE_X, _CIE_Y, _CIE_Z)])
CIE_WAVELENGTHS = CIE_MIN_NM + CIE_STEP_NM * np.arange(CIE_XYZ.shape[1])

# CIE standard illuminant D65, relative spectral power at 360, 365, ..., 830 nm (CIE 15:2004, table T.1).
CIE_D65 = np.array("""
46.6383 49.3637 52.0891 51.0323 49.9755 52.3118 54.6482 68.7015 82.7549 87.1204
91.4860 92.4589 93.4318 90.0570 86.6823 95.7736 104.8650 110.9360 117.0080 117.4100
117.8120 116.3360 114.8610 115.3920 115.9230 112.3670 108.8110 109.0820 109.3540 108.5780
107.8020 106.2960 104.7900 106.2390 107.6890 106.0470 104.4050 104.2250 104.0460 102.0230
100.0000 98.1671 96.3342 96.0611 95.7880 92.2368 88.6856 89.3459 90.0062 89.8026
89.5991 88.6489 87.6987 85.4936 83.2886 83.4939 83.6992 81.8630 80.0268 80.1207
80.2146 81.2462 82.2778 80.2810 78.2842 74.0027 69.7213 70.6652 71.6091 72.9790
74.3490 67.9765 61.6040 65.7448 69.8856 72.4863 75.0870 69.3398 63.5927 55.0054
46.4182 56.6118 66.8054 65.0941 63.3828 63.8434 64.3040 61.8779 59.4519 55.7054
51.9590 54.6998 57.4406 58.8765 60.3125
""".split(), dtype=np.float64)

CIE_MAX_NM = float(CIE_WAVELENGTHS[-1])
# Mitsuba 3's sum for a sampled spectrum (module docstring): its number of wavelengths, its ∫ȳ dλ (nm) and
# its ∫ȳ D65 dλ / ∫ȳ dλ (its constants MI_CIE_Y_NORMALIZATION and MI_CIE_D65_NORMALIZATION, inverted).
MITSUBA_SUM_POINTS = 1000
MITSUBA_Y_INTEGRAL = 106.7502593994140625
MITSUBA_D65_Y = 98.99741751876255

# XYZ → linear sRGB (ITU-R BT.709 primaries, D65 white point), IEC 61966-2-1.
XYZ_TO_LINEAR_SRGB = np.array([
    [3.240479, -1.537150, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
])
# Linear sRGB of XYZ = (1, 1, 1), the equal-energy white E: a constant emitted spectrum of 1 (module docstring).
EQUAL_ENERGY_WHITE = XYZ_TO_LINEAR_SRGB.sum(axis=1)

# Mitsuba's documented named indices of refraction (Hecht, Optics, 4th ed.; ~589 nm, 0–20 °C).
NAMED_IORS = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277, "carbon dioxide": 1.00045,
    "water": 1.3330, "acetone": 1.36, "ethanol": 1.361, "carbon tetrachloride": 1.461, "glycerol": 1.4729,
    "benzene": 1.501, "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458,
    "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544,
    "amber": 1.55, "pet": 1.5750, "diamond": 2.419,
}


def named_ior(name: str) -> float | None:
    """The index of refraction Mitsuba gives ``name`` (case, ``-`` and ``_`` ignored), ``None`` if unknown."""
    key = " ".join(name.lower().replace("-", " ").replace("_", " ").split())
    return NAMED_IORS.get(key)


def nearest_ior_names(name: str) -> list[str]:
    """Names of the table closest to ``name`` (for error messages)."""
    return difflib.get_close_matches(name.lower(), list(NAMED_IORS), n=3, cutoff=0.3)


def spectrum_to_linear_srgb(wavelengths: np.ndarray, values: np.ndarray, *, emitted: bool,
                            bounded: bool) -> tuple[np.ndarray, bool]:
    """Linear sRGB of a piecewise-linear spectrum as Mitsuba 3's RGB variants read it; also whether it was clipped.

    ``wavelengths`` (nm, strictly increasing) and ``values`` have one entry per
    sample. ``emitted``: the spectrum is a radiance, irradiance or intensity
    (no D65 weight); ``bounded``: components above 1 are clipped to 1 (a
    reflectance). See the module docstring for the integral.
    """
    grid = np.linspace(CIE_MIN_NM, CIE_MAX_NM, MITSUBA_SUM_POINTS)
    inside = (grid >= wavelengths[0]) & (grid <= wavelengths[-1])
    s = np.where(inside, np.interp(grid, wavelengths, values), 0.0)
    if not emitted:
        s = s * np.interp(grid, CIE_WAVELENGTHS, CIE_D65) / MITSUBA_D65_Y
    cmf = np.array([np.interp(grid, CIE_WAVELENGTHS, c) for c in CIE_XYZ])
    xyz = cmf @ s * ((CIE_MAX_NM - CIE_MIN_NM) / MITSUBA_SUM_POINTS) / MITSUBA_Y_INTEGRAL
    rgb = XYZ_TO_LINEAR_SRGB @ xyz
    high = 1.0 if bounded else np.inf
    clipped = bool(np.any(rgb < 0.0) or np.any(rgb > high))
    return np.clip(rgb, 0.0, high), clipped


__all__ = ["EQUAL_ENERGY_WHITE", "NAMED_IORS", "XYZ_TO_LINEAR_SRGB", "named_ior", "nearest_ior_names", "spectrum_to_linear_srgb"]
