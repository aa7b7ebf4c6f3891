"""The tables of the roughplastic BSDF (kernels/render/bsdf_roughplastic.cl), computed on the host.

Mitsuba 3's ``roughplastic`` (after Weidlich & Wilkie 2007, "Arbitrarily
layered micro-facet surfaces") needs two integrals of its rough dielectric
coating that depend only on (alpha, eta, distribution):

- the external transmittance t(mu): the fraction of light arriving at
  incidence cosine mu that the rough interface transmits into the coating,
  tabulated at :data:`RES` cosines evenly spaced on [0, 1] (the kernel
  interpolates linearly, as Mitsuba does);
- the internal reflectance R_int: the hemispherical (cosine-weighted) average
  of the interface's rough reflectance seen from inside (relative index
  1 / eta), 2 int_0^1 R(mu) mu dmu.

Both are integrals over microfacet normals m (the change of variables of
Walter et al. 2007, eq. 38: f cos o d omega_o = (F or 1 - F) G D(m) |i.m| /
|cos i| d omega_m) of the same D and G1 the kernels use (render/bsdf_roughconductor.cl:
GGX, Walter's rational Beckmann G1), by Gauss-Legendre quadrature in
(tan theta_m / alpha mapped to [0, 1), phi).  Using the kernels' own G keeps
the BSDF from creating energy (tests/test_render_bsdf_roughplastic.py);
Mitsuba integrates the same quantities by sampling.

All roughplastic materials' tables go after the material records in the one
materials table (:func:`append_tables`); a record's ``table`` field holds the
index of its first float.  A textured alpha gets one table per alpha of a grid
over the texture's range (:func:`alpha_grid`), which the kernel interpolates
linearly in log alpha at the alpha of the hit.
"""

from __future__ import annotations

import numpy as np

from ..bsdf_registry import FLAG_BITS

RES = 64  # transmittance entries, mu = 0, 1/63, ..., 1 (Mitsuba's MTS_ROUGH_TRANSMITTANCE_RES)
TABLE_FLOATS = 80  # RES entries, then R_int, padded to whole rows of the materials table (20 floats)
# A textured alpha's tables (alpha_grid): neighbours at most this ratio apart, at most this many tables
# (t(mu) moves by < 5e-4 between the linear interpolation over one step and the table there).
GRID_RATIO, GRID_MAX = 1.1, 48
_NQ_T, _NQ_P = 96, 48  # quadrature nodes in tan theta_m and in phi (phi over [0, pi]); 160 x 96 moves t by < 4e-5


def _fresnel(c: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance at cosine c >= 0 entering relative index eta (1 beyond the critical angle)."""
    s2t = (1 - c * c) / eta**2
    ct = np.sqrt(np.maximum(1 - s2t, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
    return np.where(s2t >= 1, 1.0, 0.5 * (rs * rs + rp * rp))


def _d_g1(alpha: float, beckmann: bool):
    """D(m) and G1(v, m) of the kernels (Walter et al. 2007 eqs. 25, 27, 33, 34)."""
    def d(m: np.ndarray) -> np.ndarray:
        c2 = m[..., 2] ** 2
        t2 = (1 - c2) / c2
        if beckmann:
            return np.exp(-t2 / alpha**2) / (np.pi * alpha**2 * c2 * c2)
        return 1 / (np.pi * alpha**2 * c2 * c2 * (1 + t2 / alpha**2) ** 2)

    def g1(v: np.ndarray, m: np.ndarray) -> np.ndarray:
        vz = v[..., 2]
        tan2 = np.maximum(1 - vz * vz, 0.0) / (vz * vz)
        if beckmann:
            with np.errstate(divide="ignore", invalid="ignore"):  # b = inf at normal incidence: G1 = 1
                b = 1 / (alpha * np.sqrt(tan2))
                g = np.where(b < 1.6, (3.535 * b + 2.181 * b * b) / (1 + 2.276 * b + 2.577 * b * b), 1.0)
        else:
            g = 2 / (1 + np.sqrt(1 + alpha**2 * tan2))
        return np.where(np.sum(v * m, axis=-1) * vz > 0, g, 0.0)

    return d, g1


def _normals(alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature normals m (n, 3) over the upper hemisphere and their weights (solid angle)."""
    x, w = np.polynomial.legendre.leggauss(_NQ_T)
    v, wv = 0.5 * (x + 1), 0.5 * w
    q = v / (1 - v)  # tan theta_m / alpha
    theta = np.arctan(alpha * q)
    dtheta = alpha / (1 + (alpha * q) ** 2) / (1 - v) ** 2 * wv
    xp, wp = np.polynomial.legendre.leggauss(_NQ_P)
    phi, wphi = 0.5 * np.pi * (xp + 1), 0.5 * np.pi * wp * 2  # [0, pi], doubled: symmetric in phi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    m = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    wts = (np.sin(theta) * dtheta)[:, None] * wphi[None, :]
    return m, wts.reshape(-1)


def _albedos(mu: np.ndarray, alpha: float, eta: float, beckmann: bool) -> tuple[np.ndarray, np.ndarray]:
    """(reflected, transmitted) fraction of light at incidence cosines mu on the rough interface of relative index eta."""
    d, g1 = _d_g1(alpha, beckmann)
    m, wts = _normals(alpha)
    refl, trans = np.empty(len(mu)), np.empty(len(mu))
    dm = d(m)
    for j, c in enumerate(np.maximum(mu, 1e-4)):
        wi = np.array([np.sqrt(1 - c * c), 0.0, c])
        cim = m @ wi
        f = _fresnel(np.maximum(cim, 0.0), eta)
        base = np.where(cim > 0, g1(wi, m) * dm * cim / c, 0.0) * wts
        wr = 2 * cim[:, None] * m - wi
        refl[j] = np.sum(base * f * g1(wr, m))
        # Snell at m (relative index eta): t = -wi / eta + (cim / eta - cos_t) m
        ct = np.sqrt(np.maximum(1 - (1 - cim * cim) / eta**2, 0.0))
        wt = -wi / eta + (cim / eta - ct)[:, None] * m
        trans[j] = np.sum(base * (1 - f) * g1(wt, m))
    return refl, trans


def _mu_nodes(eta: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Gauss-Legendre nodes and weights over mu in [0, 1], split at the cosine where total internal
    reflection begins inside (sqrt(1 - 1 / eta^2)): the internal reflectance has a kink there."""
    cuts = [0.0, float(np.sqrt(1 - 1 / eta**2)), 1.0] if eta > 1 else [0.0, 1.0]
    x, w = np.polynomial.legendre.leggauss(24)
    return [(a + (b - a) * 0.5 * (x + 1), (b - a) * 0.5 * w) for a, b in zip(cuts[:-1], cuts[1:])]


def roughplastic_table(alpha: float, eta: float, beckmann: bool) -> np.ndarray:
    """:data:`TABLE_FLOATS` float32: t(mu) at RES cosines, then R_int, then zeros."""
    mu = np.linspace(0.0, 1.0, RES)
    _, trans = _albedos(mu, alpha, eta, beckmann)
    r_int = sum(float(np.sum(w * 2 * m * _albedos(m, alpha, 1.0 / eta, beckmann)[0])) for m, w in _mu_nodes(eta))
    out = np.zeros(TABLE_FLOATS, np.float32)
    out[:RES] = trans
    out[RES] = r_int
    return out


def alpha_grid(texels: np.ndarray) -> np.ndarray:
    """The alphas of the tables of a textured alpha: from the least to the greatest luminance of the
    texture's ``texels`` (N, 3) (Rec. 709 weights, clamped to [1e-4, 1] as the kernel clamps them),
    evenly spaced in log alpha at most :data:`GRID_RATIO` apart and at most :data:`GRID_MAX` of them;
    one alpha when the texture's luminance is constant."""
    lum = np.clip(texels.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]), 1e-4, 1.0)
    lo, hi = float(lum.min()), float(lum.max())
    if hi <= lo * (1 + 1e-6):
        return np.array([lo])
    n = min(int(np.ceil(np.log(hi / lo) / np.log(GRID_RATIO))) + 1, GRID_MAX)
    return np.exp(np.linspace(np.log(lo), np.log(hi), n))


def alpha_grid_tables(alphas: np.ndarray, eta: float, beckmann: bool) -> np.ndarray:
    """The tables at ``alphas`` (:func:`alpha_grid`), one after the other; the first one's floats
    RES + 1 .. RES + 3 hold the grid: log of the first alpha, the inverse step in log alpha (0 for one
    alpha) and the number of alphas less one (kernels/render/bsdf_roughplastic.cl, roughplastic_grid)."""
    out = np.concatenate([roughplastic_table(float(a), eta, beckmann) for a in alphas])
    out[RES + 1] = np.log(alphas[0])
    out[RES + 2] = (len(alphas) - 1) / np.log(alphas[-1] / alphas[0]) if len(alphas) > 1 else 0.0
    out[RES + 3] = len(alphas) - 1
    return out


def append_tables(materials, records: np.ndarray, table_field: int) -> np.ndarray:
    """The materials table: ``records`` (M, 20) with every roughplastic material's table appended as rows.

    ``materials``: the scene's Material list (kind, alpha, int_ior, ext_ior, flags, textures);
    ``table_field``: the column of the record's ``table`` field, set to the table's first float.
    A material with a textured alpha (flag ``alpha_grid``) gets the tables of :func:`alpha_grid_tables`.
    """
    rows = [records]
    at = records.size
    for i, m in enumerate(materials):
        if m.kind != "roughplastic":
            continue
        eta, beckmann = m.int_ior / m.ext_ior, bool(m.flags & FLAG_BITS["beckmann"])
        if m.flags & FLAG_BITS["alpha_grid"]:
            t = alpha_grid_tables(alpha_grid(m.textures["alpha"].texels()), eta, beckmann)
        else:
            t = roughplastic_table(max(m.alpha, 1e-4), eta, beckmann)
        records[i, table_field] = at
        rows.append(t.reshape(-1, records.shape[1]))
        at += t.size
    return np.concatenate(rows) if len(rows) > 1 else records


__all__ = ["GRID_MAX", "GRID_RATIO", "RES", "TABLE_FLOATS", "alpha_grid", "alpha_grid_tables", "append_tables",
           "roughplastic_table"]
