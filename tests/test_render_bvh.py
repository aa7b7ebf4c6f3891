"""BVH build and traversal against brute-force intersection (a NumPy twin of intersect.cl)."""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family

from mcocl.render.bvh import MAX_DEPTH, build_bvh
from mcocl.render.compiled import compile_scene
from mcocl.render.raycast import MISS, cast_rays, query_prims
from mcocl.render.scene import parse_scene

EPS = 2.0**-20  # TRI_EDGE_EPS of intersect.cl


def brute_force(tris: np.ndarray, spheres: np.ndarray, o: np.ndarray, d: np.ndarray, tmax: np.ndarray):
    """Closest t and primitive per ray over every primitive (float64 twin of intersect.cl)."""
    n = len(o)
    best_t = np.full(n, np.inf)
    best_p = np.full(n, MISS, np.uint32)
    o64, d64 = o.astype(np.float64), d.astype(np.float64)
    for p, (v0, v1, v2) in enumerate(tris.astype(np.float64)):
        e1, e2 = v1 - v0, v2 - v0
        pv = np.cross(d64, e2)
        det = pv @ e1
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = o64 - v0
            u = np.einsum("ij,ij->i", tv, pv) * inv
            qv = np.cross(tv, e1)
            v = np.einsum("ij,ij->i", d64, qv) * inv
            t = (qv @ e2) * inv
            ok = (det != 0) & (u >= -EPS) & (v >= -EPS) & (u + v <= 1 + EPS) & (t > 0) & (t < np.minimum(tmax, best_t))
        best_t[ok], best_p[ok] = t[ok], p
    for k, s in enumerate(spheres.astype(np.float64)):
        f = o64 - s[:3]
        a = np.einsum("ij,ij->i", d64, d64)
        b = np.einsum("ij,ij->i", f, d64)
        c = np.einsum("ij,ij->i", f, f) - s[3] ** 2
        disc = b * b - a * c
        with np.errstate(invalid="ignore"):
            sq = np.sqrt(disc)
            t0, t1 = (-b - sq) / a, (-b + sq) / a
        t = np.where(t0 > 0, t0, t1)
        ok = (disc >= 0) & (t > 0) & (t < np.minimum(tmax, best_t))
        best_t[ok], best_p[ok] = t[ok], len(tris) + k
    return best_t, best_p


def soup_scene(rng: np.random.Generator, ntri: int, nsph: int, size: float = 0.2) -> dict:
    """A scene dict with one mesh of random triangles and random spheres in [-1, 1]^3."""
    c = rng.uniform(-1, 1, (ntri, 1, 3))
    v = (c + rng.normal(0, size, (ntri, 3, 3))).reshape(-1, 3)
    shapes = []
    if ntri:
        shapes.append({"type": "mesh", "material": "m", "vertices": v.tolist(),
                       "faces": np.arange(3 * ntri).reshape(-1, 3).tolist()})
    for _ in range(nsph):
        shapes.append({"type": "sphere", "material": "m", "center": rng.uniform(-1, 1, 3).tolist(),
                       "radius": float(rng.uniform(0.02, 0.3))})
    return {"camera": {"origin": [0, 0, 5], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
            "materials": {"m": {"type": "diffuse", "reflectance": 0.5}}, "shapes": shapes}


def random_rays(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    o = rng.uniform(-1.5, 1.5, (n, 3)).astype(np.float32)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o, d.astype(np.float32)


def check_against_brute_force(cs, o, d, tmax):
    hits = cast_rays(cs, o, d, tmax)
    tris = cs.tri_vertices[:, :, :3]
    bt, bp = brute_force(tris, cs.spheres, o, d, tmax)
    hit_b = bp != MISS
    # Same hit/miss decision except for rays grazing an edge within float rounding (none expected here).
    mismatch = (hits.prim != MISS) != hit_b
    assert mismatch.sum() <= max(1, len(o) // 2000), f"{mismatch.sum()} hit/miss disagreements"
    both = hit_b & (hits.prim != MISS)
    np.testing.assert_allclose(hits.t[both], bt[both], rtol=2e-4, atol=1e-5)
    # Where the two pick different primitives, they must be at (nearly) the same distance.
    diff = both & (hits.prim != bp)
    assert diff.sum() <= max(1, len(o) // 1000)
    # any-hit agrees with the closest hit.
    np.testing.assert_array_equal(hits.any, hits.prim != MISS)
    return hits


@pytest.mark.parametrize("ntri,nsph,seed", [(300, 0, 1), (200, 25, 2), (0, 40, 3), (1, 0, 4), (2, 1, 5)])
def test_traversal_matches_brute_force(ntri, nsph, seed):
    rng = np.random.default_rng(seed)
    cs = compile_scene(parse_scene(soup_scene(rng, ntri, nsph), "soup.json"))
    o, d = random_rays(rng, 4000)
    tmax = np.where(rng.uniform(size=len(o)) < 0.3, rng.uniform(0.1, 2.0, len(o)), np.inf).astype(np.float32)
    hits = check_against_brute_force(cs, o, d, tmax)
    assert (hits.prim != MISS).sum() >= 10  # the test exercises hits, not only misses


@pytest.mark.parametrize("all_axes,traversal_cost", [(True, 1.0), (False, 0.25), (False, 4.0)])
def test_build_variants_match_brute_force(all_axes, traversal_cost):
    rng = np.random.default_rng(8)
    cs = compile_scene(parse_scene(soup_scene(rng, 400, 20, size=0.1), "soup.json"), all_axes=all_axes,
                       traversal_cost=traversal_cost)
    o, d = random_rays(rng, 3000)
    check_against_brute_force(cs, o, d, np.full(len(o), np.inf, np.float32))


def test_small_leaves_deep_tree_matches_brute_force():
    rng = np.random.default_rng(7)
    cs = compile_scene(parse_scene(soup_scene(rng, 600, 30, size=0.05), "soup.json"), max_leaf=1, bins=4)
    o, d = random_rays(rng, 3000)
    check_against_brute_force(cs, o, d, np.full(len(o), np.inf, np.float32))


def test_empty_scene_every_ray_misses():
    rng = np.random.default_rng(0)
    cs = compile_scene(parse_scene(soup_scene(rng, 0, 0), "empty.json"))
    assert cs.num_triangles == 0 and cs.num_spheres == 0 and cs.num_lights == 0
    o, d = random_rays(rng, 100)
    hits = cast_rays(cs, o, d)
    assert np.all(hits.prim == MISS) and not hits.any.any() and np.all(np.isinf(hits.t))


def test_degenerate_triangles_never_hit():
    rng = np.random.default_rng(3)
    v = [[0, 0, 0], [1, 0, 0], [2, 0, 0],  # collinear
         [0.5, 0.5, 0.5], [0.5, 0.5, 0.5], [0.5, 0.5, 0.5],  # one point
         [-1, -1, 0], [1, -1, 0], [-1, 1, 0]]  # a real triangle, so the BVH is not empty
    scene = soup_scene(rng, 0, 0)
    scene["shapes"] = [{"type": "mesh", "material": "m", "vertices": v, "faces": [[0, 1, 2], [3, 4, 5], [6, 7, 8]]}]
    cs = compile_scene(parse_scene(scene, "degenerate.json"))
    assert cs.bvh_stats["degenerate_triangles"] == 2
    # Rays straight at the degenerate ones (along the line, through the point) and random rays.
    o = np.concatenate([[[-1, 0, 0], [0.5, 0.5, 2], [0.5, 0.5, -2], [1, 5, 0]], random_rays(rng, 2000)[0]])
    d = np.concatenate([[[1, 0, 0], [0, 0, -1], [0, 0, 1], [0, -1, 0]], random_rays(rng, 2000)[1]])
    hits = cast_rays(cs, o.astype(np.float32), d.astype(np.float32))
    assert not np.isin(hits.prim, [0, 1]).any()
    assert np.all(np.isfinite(hits.t[hits.prim != MISS]))
    assert np.all(np.isfinite(hits.b1)) and np.all(np.isfinite(hits.b2))


def test_primitive_queries_read_every_triangle_from_the_device_table():
    """prim_normal, prim_area and prim_sample_area read a triangle's leaf record through tri_rows, those the
    BVH leaves out (degenerate) included: the float32 edges give what the vertices give."""
    rng = np.random.default_rng(6)
    v = [[0, 0, 0], [1, 0, 0], [2, 0, 0],  # collinear: left out of the BVH
         [-1, -1, 0], [1, -1, 0], [-1, 1, 0]]  # area 2, normal +z
    scene = soup_scene(rng, 0, 1)
    scene["shapes"].append({"type": "mesh", "material": "m", "vertices": v, "faces": [[0, 1, 2], [3, 4, 5]]})
    cs = compile_scene(parse_scene(scene, "rows.json"))
    assert cs.bvh_stats["degenerate_triangles"] == 1 and cs.num_triangles == 2
    u = np.full((2, 2), 0.25, np.float32)
    normals, areas, points, point_normals = query_prims(cs, np.arange(2), np.zeros((2, 3), np.float32), u)
    assert areas[0] == 0.0 and areas[1] == 2.0
    np.testing.assert_array_equal(normals[1], [0, 0, 1])
    np.testing.assert_array_equal(point_normals[1], [0, 0, 1])
    # b1 = 1 - sqrt(0.25) = 0.5, b2 = 0.25 * 0.5: v0 + 0.5 e1 + 0.125 e2, exact in float32
    np.testing.assert_array_equal(points, [[0.75, 0, 0], [0, -0.75, 0]])


def test_degenerate_triangle_kernel_test_rejects_directly():
    """The kernel's own test rejects a degenerate triangle even inside the BVH (no reliance on the build)."""
    rng = np.random.default_rng(4)
    scene = soup_scene(rng, 0, 0)
    scene["shapes"] = [{"type": "mesh", "material": "m", "vertices": [[-1, -1, 0], [1, -1, 0], [-1, 1, 0]],
                        "faces": [[0, 1, 2]]}]
    cs = compile_scene(parse_scene(scene, "one.json"))
    cs.tri_vertices[0, 2, :3] = [0.0, -1.0, 0.0]  # collapse it after the build: on the line v0-v1
    o = np.array([[0, -1, 1], [-0.5, -1, -1], [0.2, -1, 0]], np.float32)
    d = np.array([[0, 0, -1], [0, 0, 1], [1, 0, 0]], np.float32)
    hits = cast_rays(cs, o, d)
    assert np.all(hits.prim == MISS) and not hits.any.any()


def test_shadow_ray_tmax_is_exclusive_and_unnormalised_directions_work():
    scene = soup_scene(np.random.default_rng(0), 0, 0)
    scene["shapes"] = [{"type": "rectangle", "material": "m"}, {"type": "sphere", "material": "m",
                                                                 "center": [0, 0, -3], "radius": 1}]
    cs = compile_scene(parse_scene(scene, "shadow.json"))
    o = np.array([[0.2, 0.1, 2.0]] * 4 + [[0, 0, -0.5]] * 2, np.float32)
    d = np.array([[0, 0, -4.0]] * 4 + [[0, 0, -1.0]] * 2, np.float32)  # length 4: the plane at t = 0.5
    tmax = np.array([0.49, 0.51, np.inf, 0.25, 1.5, 2.0], np.float32)
    hits = cast_rays(cs, o, d, tmax)
    np.testing.assert_array_equal(hits.any, [False, True, True, False, False, True])
    np.testing.assert_allclose(hits.t[[1, 2]], 0.5, rtol=1e-6)
    np.testing.assert_allclose(hits.t[5], 1.5, rtol=1e-6)  # sphere front at z = -2
    # From inside a sphere the far side is hit.
    h = cast_rays(cs, np.array([[0, 0, -3]], np.float32), np.array([[1, 0, 0]], np.float32))
    assert h.prim[0] == cs.num_triangles and abs(h.t[0] - 1.0) < 1e-6


def test_closed_mesh_is_watertight_along_shared_edges():
    """Rays aimed exactly at the diagonals and edges of a cube's faces never escape it."""
    scene = soup_scene(np.random.default_rng(0), 0, 0)
    scene["shapes"] = [{"type": "cube", "material": "m", "flip_normals": True,
                        "transform": [{"rotate": {"axis": [1, 2, 3], "angle": 33}}, {"scale": 1.7}]}]
    cs = compile_scene(parse_scene(scene, "cube.json"))
    rng = np.random.default_rng(11)
    # Points on the diagonals and edges of the cube's faces (local), transformed like the cube.
    s = rng.uniform(-1, 1, 20000)
    face_pts = np.stack([s, s, np.ones_like(s)], axis=1)
    edge_pts = np.stack([s, np.ones_like(s), np.ones_like(s)], axis=1)
    pts = np.concatenate([face_pts, edge_pts, -face_pts, -edge_pts])
    from mcocl.render import transform as tf
    m = tf.compose([tf.rotate([1, 2, 3], 33), tf.scale(1.7)])
    target = tf.apply_points(m, pts)
    o = rng.uniform(-0.5, 0.5, (len(target), 3))
    d = (target - o).astype(np.float32)
    hits = cast_rays(cs, o.astype(np.float32), d)
    assert np.all(hits.prim != MISS)
    assert np.all(cast_rays(cs, o.astype(np.float32), d, np.float32(2.0), closest=False).any)


# the square's quadrants, the sphere's octants, the triangle's barycentric histogram
AREA_SAMPLING = Chi2Family("primitive area sampling", 3)


def test_prim_normal_area_and_sampling():
    scene = soup_scene(np.random.default_rng(0), 0, 0)
    scene["shapes"] = [{"type": "rectangle", "material": "m", "flip_normals": True},
                       {"type": "sphere", "material": "m", "center": [1, 2, 3], "radius": 0.5, "flip_normals": True}]
    cs = compile_scene(parse_scene(scene, "q.json"))
    rng = np.random.default_rng(1)
    n = 20000
    prims = np.repeat(np.array([0, 1, 2], np.uint32), n)
    u = rng.uniform(size=(3 * n, 2)).astype(np.float32)
    pts = np.zeros((3 * n, 3), np.float32)
    pts[2 * n:] = [1.5, 2, 3]
    normals, area, samples, snormals = query_prims(cs, prims, pts, u)
    np.testing.assert_allclose(normals[:2 * n], np.tile([0, 0, -1], (2 * n, 1)), atol=1e-6)
    np.testing.assert_allclose(normals[2 * n:], np.tile([-1, 0, 0], (n, 1)), atol=1e-6)
    np.testing.assert_allclose(area, np.repeat([2.0, 2.0, np.pi], n), rtol=1e-6)
    np.testing.assert_allclose(snormals[:2 * n], np.tile([0, 0, -1], (2 * n, 1)), atol=1e-6)
    sph = samples[2 * n:] - [1, 2, 3]
    np.testing.assert_allclose(np.linalg.norm(sph, axis=1), 0.5, rtol=1e-5)
    np.testing.assert_allclose(snormals[2 * n:], -sph / 0.5, atol=1e-5)
    # Uniform over the area: quadrant counts of the square and octant counts of the sphere.
    sq = samples[:2 * n, :2]
    q = (sq[:, 0] > 0).astype(int) * 2 + (sq[:, 1] > 0)
    assert abs(sq).max() <= 1.0 + 1e-6
    AREA_SAMPLING.check("square quadrants", np.bincount(q, minlength=4), np.full(4, 2 * n / 4))
    oc = (sph[:, 0] > 0) * 4 + (sph[:, 1] > 0) * 2 + (sph[:, 2] > 0)
    AREA_SAMPLING.check("sphere octants", np.bincount(oc, minlength=8), np.full(8, n / 8))
    # A finer check on one triangle: histogram over a 4x4 grid of the unit square restricted to it.
    tri = samples[:n, :2]
    v0, v1, v2 = cs.tri_vertices[0, :, :2]
    # barycentric coordinates -> (b1, b2) uniform on the triangle means P(b1 < x) = 1 - (1 - x)^2
    mat = np.stack([v1 - v0, v2 - v0], axis=1)
    b = np.linalg.solve(mat, (tri - v0).T).T
    edges = np.linspace(0, 1, 11)
    counts = np.histogram(b[:, 0], edges)[0]
    expected = np.diff(1 - (1 - edges) ** 2) * n
    AREA_SAMPLING.check("triangle barycentric b1", counts, expected)


@pytest.mark.parametrize("all_axes", [False, True])
def test_build_limits_and_partition(all_axes):
    rng = np.random.default_rng(5)
    n = 5000
    c = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
    c[:1000] = 0.25  # many identical boxes: the no-SAH-split fallback
    e = rng.uniform(0, 0.01, (n, 3)).astype(np.float32)
    e[:1000] = 0.01
    b = build_bvh(c - e, c + e, all_axes=all_axes)
    assert b.depth <= MAX_DEPTH
    assert np.array_equal(np.sort(b.prims), np.arange(n))
    u = b.nodes.view(np.uint32)
    assert u[0, 0] == n and u[0, 1] == b.num_nodes
    # Every leaf's primitives lie in its box; every internal reference is a valid node.
    cnt = u[1:, 3].reshape(-1, 2, 2)[:, :, 1]
    ref = u[1:, 3].reshape(-1, 2, 2)[:, :, 0]
    lo = b.nodes[1:, :3].reshape(-1, 2, 2, 3)[:, :, 0]
    hi = b.nodes[1:, :3].reshape(-1, 2, 2, 3)[:, :, 1]
    assert np.all(ref[cnt == 0] < b.num_nodes)
    for k, j in zip(*np.nonzero(cnt)):
        pr = b.prims[ref[k, j]: ref[k, j] + cnt[k, j]]
        assert np.all((c - e)[pr] >= lo[k, j]) and np.all((c + e)[pr] <= hi[k, j])
    assert cnt.sum() == n
    # Depth-first node order: a node's children come after it.
    parent = np.repeat(np.arange(b.num_nodes), 2).reshape(-1, 2)
    assert np.all(ref[cnt == 0] > parent[cnt == 0])


def check_tree(b, lo: np.ndarray, hi: np.ndarray) -> None:
    """Structural checks of a flattened hierarchy over boxes [lo, hi]: a partition, conservative boxes, order."""
    n = len(lo)
    assert b.depth <= MAX_DEPTH
    assert np.array_equal(np.sort(b.prims), np.arange(n))
    u = b.nodes.view(np.uint32)
    assert u[0, 0] == n and u[0, 1] == b.num_nodes and u[0, 2] == b.depth
    cnt = u[1:, 3].reshape(-1, 2, 2)[:, :, 1]
    ref = u[1:, 3].reshape(-1, 2, 2)[:, :, 0]
    nlo = b.nodes[1:, :3].reshape(-1, 2, 2, 3)[:, :, 0]
    nhi = b.nodes[1:, :3].reshape(-1, 2, 2, 3)[:, :, 1]
    assert np.all(ref[cnt == 0] < b.num_nodes)
    if n > 1:
        assert cnt.sum() == n and (cnt > 0).sum() == b.num_leaves
    k, j = np.nonzero(cnt)
    leaf_of = np.repeat(np.arange(len(k)), cnt[k, j])
    pos = np.concatenate([np.arange(r, r + c) for r, c in zip(ref[k, j], cnt[k, j])])
    pr = b.prims[pos]
    assert np.all(lo[pr] >= nlo[k, j][leaf_of]) and np.all(hi[pr] <= nhi[k, j][leaf_of])
    # An internal child's box holds both boxes of its own children.
    par, side = np.nonzero(cnt == 0)
    child = ref[par, side]
    assert np.all(nlo[par, side][:, None] <= nlo[child]) and np.all(nhi[par, side][:, None] >= nhi[child])
    parent = np.repeat(np.arange(b.num_nodes), 2).reshape(-1, 2)
    assert np.all(ref[cnt == 0] > parent[cnt == 0])  # depth-first order


@pytest.mark.parametrize("method", ["ploc", "binned"])
@pytest.mark.parametrize("case", ["identical", "scale_huge", "scale_tiny", "far_offset", "flat", "two", "nested"])
def test_build_structure_on_adversarial_boxes(method, case):
    rng = np.random.default_rng(12)
    n = 3000
    c = rng.uniform(-1, 1, (n, 3))
    e = rng.uniform(0, 0.01, (n, 3))
    if case == "identical":  # every box the same: only ties
        c[:], e[:] = 0.3, 0.1
    elif case == "scale_huge":  # areas beyond float32 range unless rescaled
        c, e = c * 1e30, e * 1e30
    elif case == "scale_tiny":  # areas below float32's smallest numbers
        c, e = c * 1e-30, e * 1e-30
    elif case == "far_offset":  # a small scene far from the origin
        c = c * 1e-3 + 1e6
        e = e * 1e-3
    elif case == "flat":  # coplanar: zero extent along z
        c[:, 2], e[:, 2] = 0.5, 0.0
    elif case == "two":
        c, e = c[:2], e[:2]
    elif case == "nested":  # boxes nested like onion shells: greedy clustering makes a chain
        s = 1.5 ** np.arange(60)
        c, e = np.zeros((60, 3)), np.stack([s, s, s], 1)
    lo, hi = (c - e).astype(np.float32), (c + e).astype(np.float32)
    b = build_bvh(lo, hi, method=method)
    check_tree(b, lo, hi)
    if case == "nested" and method == "ploc":  # the clustered chain is too deep: the binned build takes over
        from mcocl.render.bvh_ploc import cluster, flatten_tree
        assert flatten_tree(cluster(lo, hi)[0], np.arange(len(lo), dtype=np.uint32), 8, 1.0)[4] > MAX_DEPTH
        # its input boxes come back from the clustering's leaves: the very tree of a binned build of them
        binned = build_bvh(lo, hi, method="binned")
        assert b.nodes.tobytes() == binned.nodes.tobytes() and b.prims.tobytes() == binned.prims.tobytes()
    again = build_bvh(lo.copy(), hi.copy(), method=method)  # deterministic: the same bytes
    assert again.nodes.tobytes() == b.nodes.tobytes() and again.prims.tobytes() == b.prims.tobytes()


def test_build_rejects_bad_input():
    lo = np.zeros((3, 3), np.float32)
    hi = np.ones((3, 3), np.float32)
    with pytest.raises(ValueError, match="unknown method"):
        build_bvh(lo, hi, method="sweep")
    hi[1, 2] = np.nan
    with pytest.raises(ValueError, match="finite"):
        build_bvh(lo, hi)


def test_clustered_tree_is_close_to_binned_sah():
    """The default (clustering) build's SAH cost stays near the binned builder's on a random soup."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
    from bvh_build import sah_cost, soup, terrain

    for make in (soup, terrain):
        t = make(20000, seed=3).astype(np.float32)
        lo, hi = t.min(axis=1), t.max(axis=1)
        ratio = sah_cost(build_bvh(lo, hi)) / sah_cost(build_bvh(lo, hi, method="binned"))
        assert ratio < 1.12, f"{make.__name__}: SAH ratio {ratio:.3f}"


def mesh_scene(v: np.ndarray, f: np.ndarray) -> dict:
    """A scene dict holding one mesh."""
    scene = soup_scene(np.random.default_rng(0), 0, 0)
    scene["shapes"] = [{"type": "mesh", "material": "m", "vertices": np.asarray(v).tolist(),
                        "faces": np.asarray(f).tolist()}]
    return scene


def test_coplanar_overlapping_triangles_match_brute_force():
    """Many overlapping triangles in one plane, rays from both sides and grazing rays in the plane."""
    rng = np.random.default_rng(21)
    n = 400
    c = rng.uniform(-1, 1, (n, 1, 2))
    v2 = c + rng.normal(0, 0.3, (n, 3, 2))
    v = np.concatenate([v2, np.zeros((n, 3, 1))], axis=2).reshape(-1, 3)
    cs = compile_scene(parse_scene(mesh_scene(v, np.arange(3 * n).reshape(-1, 3)), "coplanar.json"))
    o = np.concatenate([rng.uniform(-1.5, 1.5, (3000, 3)) * [1, 1, 0] + [0, 0, 1],
                        rng.uniform(-1.5, 1.5, (3000, 3)) * [1, 1, 0] - [0, 0, 1]]).astype(np.float32)
    d = np.concatenate([np.tile([0, 0, -1.0], (3000, 1)), rng.normal(size=(3000, 3)) * [0.2, 0.2, 0] + [0, 0, 1]])
    d = d.astype(np.float32)
    hits = cast_rays(cs, o, d)
    bt, bp = brute_force(cs.tri_vertices[:, :, :3], cs.spheres, o, d, np.full(len(o), np.inf))
    # Every hit is at the plane, so which of the overlapping triangles is reported is a tie: check
    # hit/miss and distance against brute force, and that the reported triangle really holds the point.
    hit = hits.prim != MISS
    assert (hit != (bp != MISS)).sum() <= 3 and hit.mean() > 0.3
    np.testing.assert_allclose(hits.t[hit & (bp != MISS)], bt[hit & (bp != MISS)], rtol=1e-5, atol=1e-6)
    tri = cs.tri_vertices[hits.prim[hit], :, :3].astype(np.float64)
    p = (o[hit] + hits.t[hit, None] * d[hit]).astype(np.float64)
    b1, b2 = hits.b1[hit], hits.b2[hit]
    np.testing.assert_allclose(tri[:, 0] + b1[:, None] * (tri[:, 1] - tri[:, 0]) + b2[:, None] * (tri[:, 2] - tri[:, 0]),
                               p, atol=1e-5)
    assert np.all((b1 >= -1e-5) & (b2 >= -1e-5) & (b1 + b2 <= 1 + 1e-5))
    # Rays inside the plane: parallel to every triangle, nothing can be hit (det = 0).
    og = rng.uniform(-1.5, 1.5, (500, 3)).astype(np.float32) * [1, 1, 0]
    dg = np.concatenate([rng.normal(size=(500, 2)), np.zeros((500, 1))], axis=1).astype(np.float32)
    assert np.all(cast_rays(cs, og.astype(np.float32), dg).prim == MISS)


def test_huge_tiny_and_degenerate_triangles_match_brute_force():
    """One huge triangle among tiny ones and degenerate ones (lines, points): BVH = brute force."""
    rng = np.random.default_rng(22)
    tiny = rng.uniform(-1, 1, (300, 1, 3)) + rng.normal(0, 1e-3, (300, 3, 3))
    small = rng.uniform(-1, 1, (300, 1, 3)) + rng.normal(0, 0.1, (300, 3, 3))
    huge = np.array([[[-1e4, -1e4, -0.5], [1e4, -1e4, -0.5], [0, 1e4, -0.7]]])
    line = rng.uniform(-1, 1, (50, 1, 3)) + np.linspace(0, 1, 3)[None, :, None] * rng.normal(0, 0.2, (50, 1, 3))
    point = np.repeat(rng.uniform(-1, 1, (50, 1, 3)), 3, axis=1)
    tris = np.concatenate([tiny, small, huge, line, point])
    perm = rng.permutation(len(tris))
    tris = tris[perm]
    cs = compile_scene(parse_scene(mesh_scene(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3)),
                                   "mixed.json"))
    assert cs.bvh_stats["degenerate_triangles"] >= 100
    o, d = random_rays(rng, 4000)
    # Rays aimed at the tiny triangles' centroids too, so that they are hit.
    targets = tris[np.isin(perm, np.arange(300))].mean(axis=1)
    o2 = rng.uniform(-1.5, 1.5, (len(targets), 3))
    o = np.concatenate([o, o2]).astype(np.float32)
    d = np.concatenate([d, targets - o2]).astype(np.float32)
    hits = check_against_brute_force(cs, o, d, np.full(len(o), np.inf, np.float32))
    tiny_ids = np.flatnonzero(np.isin(perm, np.arange(300)))
    assert np.isin(hits.prim, tiny_ids).sum() >= 100
    assert np.isin(hits.prim, np.flatnonzero(perm == 600)).sum() >= 100  # the huge one


def test_closed_mesh_has_no_leaks_through_shared_vertices():
    """Rays from inside a closed triangulated sphere, aimed at its vertices and edge midpoints, all hit it."""
    k = 24
    th, ph = np.meshgrid(np.linspace(0, np.pi, k), np.linspace(0, 2 * np.pi, 2 * k, endpoint=False), indexing="ij")
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3)
    idx = np.arange(k * 2 * k).reshape(k, 2 * k)
    a, b_, c, d = idx[:-1], np.roll(idx, -1, 1)[:-1], idx[1:], np.roll(idx, -1, 1)[1:]
    f = np.concatenate([np.stack([a, c, b_], -1).reshape(-1, 3), np.stack([b_, c, d], -1).reshape(-1, 3)])
    cs = compile_scene(parse_scene(mesh_scene(v, f), "sphere.json"))
    rng = np.random.default_rng(23)
    targets = np.concatenate([v, 0.5 * (v[f[:, 0]] + v[f[:, 1]]), 0.5 * (v[f[:, 1]] + v[f[:, 2]])])
    o = np.repeat(rng.uniform(-0.3, 0.3, (4, 3)), len(targets), axis=0)
    d = np.tile(targets, (4, 1)) - o
    hits = cast_rays(cs, o.astype(np.float32), d.astype(np.float32))
    assert np.all(hits.prim != MISS)
    # any-hit walks the wide tree in slot order, not nearest first: no leak there either
    # (tmax 2: the aimed point lies at t = 1 and the far side of the sphere beyond it)
    occluded = cast_rays(cs, o.astype(np.float32), d.astype(np.float32), np.float32(2.0), closest=False)
    assert np.all(occluded.any)
