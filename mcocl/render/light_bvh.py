"""The light BVH: a tree over every emitting primitive for choosing a light from the shading point.

Conty Estevez & Kulla, "Importance Sampling of Many Lights with Adaptive
Tree Splitting" (2018), as pbrt-v4's ``BVHLightSampler`` uses it: every node
bounds the lights below it by a box, their total power and an orientation
cone (the emitters' normals lie within theta_o of an axis, and each emits
within theta_e of its normal).  From a shading point the kernel
(kernels/render/light_bvh.cl) estimates an *importance* of both children of
a node — power / distance², times a bound of the cosine at the emitter and
at the receiver — and descends into one of them with probability in
proportion; a leaf is one light.  Point and spot lights
(mcocl/render/delta_lights.py) are leaves too, after the primitives: a
point box, every direction for a point light, the cutoff cone about its
axis for a spot (directional lights are refused: they lie at infinity).

A node record (:data:`~mcocl.layouts.LIGHT_BVH_NODE`, three float4) holds
the bounding sphere of its box rather than the box: the importance needs
only the sphere, and 12 values fit three float4 where a box needs four.

Per light (one per entry of ``CompiledScene.light_prims``, in that order):

- triangle: its box, the front normal as the axis, theta_o = 0 and
  theta_e = π/2 (one-sided emission);
- sphere (normals out or in): its box (rounded outwards to float32),
  theta_o = π (normals in every direction), theta_e = π/2.

The tree is built top-down, one NumPy pass per level: a node's lights are
sorted by centroid along the widest axis of their centroids and split where
the power-weighted surface area of the two sides is least (median splits
from level 31 - ceil(log2 L) on, so that the depth stays below the 32 bits of
a trail); parents merge
their children's boxes, powers and cones (pbrt-v4's ``Union`` of direction
cones, §3.8.4 of the 4th edition).  Merged cones are widened by
:data:`CONE_MARGIN` so that float32 rounding of the stored axis and cosine
cannot make a node look darker than a light below it sees a point: an
importance of zero means the light cannot reach the point, and a light that
could but gets zero would bias the image.  The split cost ignores
orientation (pbrt-v4's surface-area-orientation heuristic weighs the cones
too).

``count`` of a node: the lights below it.  The walk gives every child that
can light the point at least ``count`` of the 2^23 cells of the uniforms'
grid, so every light that can reach the point has a non-zero probability
however small its importance (at most 2^23 lights).

A flat tree for a few lights: with 2 to :data:`FLAT_LIGHTS` area lights (and
no point or spot light) the records are the root (its count carrying
:data:`FLAT_FLAG`) and then every light's leaf, in light order, and a light's
trail is its index.  The kernel then weighs every leaf at once — the same
records for all lanes, read once, instead of two gathered nodes per level
and lanes that wait for the deepest walk — and deals the 2^23 cells out in
proportion to the leaves' importances (``light_bvh_flat``).  On
scenes/veach_mis.json (5 lights) that makes the choice as cheap per sample
as the power CDF and lowers the median pixel variance against the binary
tree (bench/light_walk.py, bench/light_choice.py).  Scenes with point or
spot lights keep the binary tree: on the point-and-spot plane of
tests/test_render_delta_lights.py the flat choice had 1.5x its variance.

``light_trail`` (uint32 per primitive id): the path from the root to the
leaf of the primitive's light, bit d = 1 when the path takes the second
child at depth d — so that the pmf of a light hit by a BSDF-sampled ray can
be recomputed by walking the same nodes (``light_bvh_pmf`` in the kernel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..layouts import LIGHT_BVH_NODE
from ..rng import GRID_CELLS
from .compiled import CompiledScene
from .emitter_choice import FLAT_LIGHTS  # LIGHT_BVH_FLAT_MAX of kernels/render/light_bvh.cl

CONE_MARGIN = 1e-4  # radians added to a merged cone's theta_o (float32 rounding of axis and cosine)
MAX_DEPTH = 32  # the trail is a uint32
FLAT_FLAG = 1 << 31  # in the root's count: the tree is flat (LIGHT_BVH_FLAT_FLAG of the kernel)


@dataclass
class LightBVH:
    """The light BVH as the kernel reads it.

    Attributes:
        nodes: float32 (4 N, 4): N :data:`~mcocl.layouts.LIGHT_BVH_NODE` records, node 0 the root.
        trail: uint32 (num primitives,): root-to-leaf path of each light primitive (0 for others).
        depth: levels below the root.
    """

    nodes: np.ndarray
    trail: np.ndarray
    depth: int


def _light_geometry(cs: CompiledScene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per light: box lo, hi (float64 of float32 values), unit axis, cos theta_o, cos theta_e."""
    prims = np.asarray(cs.light_prims, np.int64)
    nl, nt = len(prims), cs.num_triangles
    lo, hi = np.zeros((nl, 3)), np.zeros((nl, 3))
    axis = np.tile([0.0, 0.0, 1.0], (nl, 1))
    cos_o = np.full(nl, -1.0)
    tri = prims < nt
    v = cs.tri_vertices[prims[tri], :, :3].astype(np.float64)
    lo[tri], hi[tri] = v.min(axis=1), v.max(axis=1)
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    axis[tri] = n / np.linalg.norm(n, axis=1)[:, None]
    cos_o[tri] = 1.0
    s = cs.spheres[prims[~tri] - nt].astype(np.float64)
    lo[~tri] = np.nextafter((s[:, :3] - s[:, 3:]).astype(np.float32), np.float32(-np.inf))
    hi[~tri] = np.nextafter((s[:, :3] + s[:, 3:]).astype(np.float32), np.float32(np.inf))
    cos_e = np.zeros(nl)
    if cs.num_delta:
        # point and spot lights (mcocl/render/delta_lights.py; with_settings refuses directional ones):
        # a point box; a point light shines every way (like a sphere), a spot within its cutoff of its axis
        d = cs.delta_lights
        pos = np.array([li.position for li in d], np.float32)
        spot = np.array([li.kind == "spot" for li in d])
        lo = np.concatenate([lo, np.nextafter(pos, np.float32(-np.inf)).astype(np.float64)])
        hi = np.concatenate([hi, np.nextafter(pos, np.float32(np.inf)).astype(np.float64)])
        axis = np.concatenate([axis, np.array([li.direction for li in d], np.float64)])
        cos_o = np.concatenate([cos_o, np.where(spot, 1.0, -1.0)])
        cos_e = np.concatenate([cos_e, np.where(spot, [math.cos(math.radians(li.cutoff_angle)) for li in d], 0.0)])
    return lo, hi, axis, cos_o, cos_e


def _segment_scan(x: np.ndarray, seg: np.ndarray, op: np.ufunc) -> np.ndarray:
    """Running ``op`` (np.minimum or np.maximum) of rows x restarting at every new segment id (ids ascending)."""
    big = 4.0 * (float(np.max(np.abs(x))) + 1.0)
    shift = (seg * big)[:, None] * (1.0 if op is np.maximum else -1.0)
    return op.accumulate(x + shift, axis=0) - shift


def _box_area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    d = np.maximum(hi - lo, 0.0)
    return 2.0 * (d[:, 0] * d[:, 1] + d[:, 1] * d[:, 2] + d[:, 2] * d[:, 0])


def _split_levels(lo: np.ndarray, hi: np.ndarray, power: np.ndarray,
                  ) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Top-down splits, level by level: the light order and each level's node ranges (start, end) in it.

    Each node sorts its lights by centroid along the widest axis of their
    centroids and splits where power x box surface area of the two sides is
    least (a power-weighted SAH; pbrt-v4's SAOH also weighs the cones), every
    position considered; from level 31 - ceil(log2 L) on it splits at the
    median, which keeps the depth at most 31 (whatever the cost splits left,
    at most L lights remain below a node).
    """
    nl = len(lo)
    median_from = MAX_DEPTH - 1 - int(math.ceil(math.log2(max(nl, 2))))
    cent = 0.5 * (lo + hi)
    perm = np.arange(nl)
    starts, ends = [np.array([0])], [np.array([nl])]
    while True:
        s, e = starts[-1], ends[-1]
        inner = (e - s) > 1
        if not np.any(inner):
            break
        s, e = s[inner], e[inner]
        count = e - s
        first = np.cumsum(count) - count
        seg = np.repeat(np.arange(len(s)), count)
        pos = np.arange(len(seg)) + np.repeat(s - first, count)  # positions in perm
        c = cent[perm[pos]]
        bounds_lo = np.minimum.reduceat(c, first, axis=0)
        bounds_hi = np.maximum.reduceat(c, first, axis=0)
        ax = np.argmax(bounds_hi - bounds_lo, axis=1)
        key = c[np.arange(len(pos)), ax[seg]]
        order = np.lexsort((perm[pos], key, seg))  # ties broken by light index: deterministic
        perm[pos] = perm[pos[order]]
        mid = s + count // 2
        if len(starts) - 1 < median_from:
            lights = perm[pos]
            w = power[lights]
            left_lo, left_hi = _segment_scan(lo[lights], seg, np.minimum), _segment_scan(hi[lights], seg, np.maximum)
            rseg = seg[-1] - seg[::-1]
            right_lo = _segment_scan(lo[lights][::-1], rseg, np.minimum)[::-1]
            right_hi = _segment_scan(hi[lights][::-1], rseg, np.maximum)[::-1]
            left_w = np.cumsum(w) - np.repeat(np.cumsum(w)[first] - w[first], count)
            seg_w = np.add.reduceat(w, first)
            # the split after position j: j and those before it left, the rest right
            cost = np.full(len(pos), np.inf)
            cost[:-1] = (left_w[:-1] * _box_area(left_lo[:-1], left_hi[:-1])
                         + (seg_w[seg[:-1]] - left_w[:-1]) * _box_area(right_lo[1:], right_hi[1:]))
            cost[first + count - 1] = np.inf  # no split after a segment's last light
            best = np.lexsort((np.arange(len(pos)), cost, seg))[first]  # first least cost of each segment
            mid = np.where(np.isfinite(cost[best]), s + (best - first) + 1, mid)
        starts.append(np.stack([s, mid], axis=1).ravel())
        ends.append(np.stack([mid, e], axis=1).ravel())
    return perm, starts, ends


def _cone_union(ax_a, th_a, ax_b, th_b):
    """Smallest cone (axis, theta) holding cones a and b, vectorised (pbrt-v4's DirectionCone Union)."""
    cos_d = np.clip(np.sum(ax_a * ax_b, axis=1), -1.0, 1.0)
    th_d = np.arccos(cos_d)
    a_holds = np.minimum(th_d + th_b, math.pi) <= th_a
    b_holds = np.minimum(th_d + th_a, math.pi) <= th_b
    th_o = 0.5 * (th_a + th_d + th_b)
    wr = np.cross(ax_a, ax_b)
    wr_len = np.linalg.norm(wr, axis=1)
    full = (th_o >= math.pi) | (wr_len < 1e-12)
    k = wr / np.where(wr_len > 0, wr_len, 1.0)[:, None]
    rot = (th_o - th_a)[:, None]
    # Rodrigues' rotation of ax_a about k (k is perpendicular to ax_a)
    ax = ax_a * np.cos(rot) + np.cross(k, ax_a) * np.sin(rot)
    ax = ax / np.linalg.norm(ax, axis=1)[:, None]
    th = np.minimum(th_o + CONE_MARGIN, math.pi)
    ax = np.where(full[:, None], [[0.0, 0.0, 1.0]], ax)
    th = np.where(full, math.pi, th)
    ax = np.where(b_holds[:, None], ax_b, ax)
    th = np.where(b_holds, th_b, th)
    ax = np.where(a_holds[:, None], ax_a, ax)
    th = np.where(a_holds, th_a, th)
    return ax, th


def build_light_bvh(cs: CompiledScene) -> LightBVH:
    """The light BVH over ``cs.light_prims`` with their powers ``cs.light_power`` (see the module docstring).

    A scene without lights gets a single zero-power leaf (never used: the
    kernel chooses no area light when there are none).
    """
    nl = cs.num_choices  # the light primitives, then the point and spot lights
    rec_dtype = LIGHT_BVH_NODE.dtype()
    trail_out = np.zeros(max(cs.num_triangles + cs.num_spheres, 1), np.uint32)
    if nl == 0:
        rec = np.zeros(1, rec_dtype)
        rec["count"] = 1
        return LightBVH(rec.view(np.float32).reshape(-1, 4), trail_out, 0)
    lo, hi, axis, cos_o, cos_e = _light_geometry(cs)
    power = np.concatenate([np.asarray(cs.light_power, np.float64), np.asarray(cs.delta_power, np.float64)])
    perm, starts, ends = _split_levels(lo, hi, power)
    if len(starts) - 1 > MAX_DEPTH or nl > GRID_CELLS:
        raise InputError(f"{cs.source}: {nl} emitting primitives: the light BVH takes at most {GRID_CELLS}")

    # Number the nodes level by level; the two children of a node are adjacent.
    level_ids, first = [], 0
    for s in starts:
        level_ids.append(first + np.arange(len(s)))
        first += len(s)
    total = first
    n_lo, n_hi = np.zeros((total, 3)), np.zeros((total, 3))
    n_axis, n_th = np.zeros((total, 3)), np.zeros(total)
    n_pow, n_cos_e, n_count = np.zeros(total), np.zeros(total), np.ones(total, np.int64)
    ref, leaf = np.zeros(total, np.int64), np.zeros(total, bool)
    trail, depth = np.zeros(total, np.int64), np.zeros(total, np.int64)
    for lev in range(len(starts)):
        ids, s, e = level_ids[lev], starts[lev], ends[lev]
        is_leaf = (e - s) == 1
        leaf[ids] = is_leaf
        ref[ids[is_leaf]] = perm[s[is_leaf]]
        if lev + 1 < len(starts):
            children = level_ids[lev + 1]
            parents = ids[~is_leaf]
            ref[parents] = children[0::2]
            trail[children[0::2]], trail[children[1::2]] = trail[parents], trail[parents] | (1 << lev)
            depth[children] = lev + 1
    # Leaves carry their light; parents merge their children, deepest level first.
    lt = ref[leaf]
    n_lo[leaf], n_hi[leaf], n_pow[leaf] = lo[lt], hi[lt], power[lt]
    n_axis[leaf], n_th[leaf], n_cos_e[leaf] = axis[lt], np.arccos(np.clip(cos_o[lt], -1, 1)), cos_e[lt]
    for lev in range(len(starts) - 2, -1, -1):
        ids = level_ids[lev]
        p = ids[~leaf[ids]]
        a, b = ref[p], ref[p] + 1
        n_lo[p], n_hi[p] = np.minimum(n_lo[a], n_lo[b]), np.maximum(n_hi[a], n_hi[b])
        n_pow[p] = n_pow[a] + n_pow[b]
        n_count[p] = n_count[a] + n_count[b]
        n_cos_e[p] = np.minimum(n_cos_e[a], n_cos_e[b])
        n_axis[p], n_th[p] = _cone_union(n_axis[a], n_th[a], n_axis[b], n_th[b])
    rec = np.zeros(total, rec_dtype)
    # The bounding sphere of each box, rounded outwards: the radius covers the float32 centre's error.
    centre = 0.5 * (n_lo + n_hi)
    c32 = centre.astype(np.float32)
    radius = 0.5 * np.linalg.norm(n_hi - n_lo, axis=1) + np.linalg.norm(c32 - centre, axis=1)
    rec["center"], rec["radius2"] = c32, np.nextafter((radius * radius).astype(np.float32), np.float32(np.inf))
    rec["power"], rec["ref"], rec["count"] = n_pow, ref.astype(np.uint32), n_count
    rec["axis"] = n_axis
    # cos theta_o rounded down (a wider cone) where it is not exactly 1 or -1
    cos_stored = np.cos(n_th).astype(np.float32)
    inexact = (n_th > 0) & (n_th < math.pi)
    rec["cos_o"] = np.where(inexact, np.nextafter(cos_stored, np.float32(-1)), np.where(n_th == 0, 1.0, -1.0))
    rec["cos_e"] = n_cos_e
    if 1 < nl <= FLAT_LIGHTS and cs.num_delta == 0:
        return _flat(cs, rec, ref, leaf, trail_out)
    prim_leaf = ref[leaf] < cs.num_lights  # delta lights have no primitive: no BSDF sample finds them
    trail_out[np.asarray(cs.light_prims, np.int64)[ref[leaf][prim_leaf]]] = trail[leaf][prim_leaf].astype(np.uint32)
    return LightBVH(np.ascontiguousarray(rec).view(np.float32).reshape(-1, 4), trail_out, int(depth.max()))


def _flat(cs: CompiledScene, rec: np.ndarray, ref: np.ndarray, leaf: np.ndarray, trail_out: np.ndarray) -> LightBVH:
    """The flat tree of a few lights: the root, then every light's leaf record in light order.

    The kernel weighs all leaves at once (one importance per light, read once
    for every lane, instead of two gathered nodes per level), and a light's
    trail is its index.
    """
    leaves = np.flatnonzero(leaf)
    leaves = leaves[np.argsort(ref[leaves])]
    flat = np.concatenate([rec[:1], rec[leaves]])
    flat["ref"][0] = 1
    flat["count"][0] = len(leaves) | FLAT_FLAG
    trail_out[np.asarray(cs.light_prims, np.int64)] = np.arange(cs.num_lights, dtype=np.uint32)
    return LightBVH(np.ascontiguousarray(flat).view(np.float32).reshape(-1, 4), trail_out, 1)


__all__ = ["CONE_MARGIN", "FLAT_FLAG", "FLAT_LIGHTS", "MAX_DEPTH", "LightBVH", "build_light_bvh"]
