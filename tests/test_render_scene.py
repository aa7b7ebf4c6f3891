"""Scene files: validation errors name the file and key path; the shipped scenes compile as specified."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render import transform as tf
from mcocl.render.compiled import LUMINANCE, compile_scene
from mcocl.render.raycast import MISS, cast_rays
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"

BASE = {
    "camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 8, "height": 6},
    "integrator": {"type": "nee", "max_depth": 3, "rr_depth": 2, "spp": 4},
    "materials": {"w": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
                  "m": {"type": "roughconductor", "alpha": 0.2}},
    "shapes": [
        {"type": "rectangle", "material": "w"},
        {"type": "cube", "material": "m", "transform": [{"scale": 0.5}]},
        {"type": "sphere", "material": "w", "center": [0, 2, 0], "radius": 0.5,
         "emitter": {"type": "area", "radiance": 3}},
        {"type": "mesh", "material": "w", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [[0, 1, 2]]},
    ],
}


def write(tmp_path: Path, scene: dict, name: str = "s.json") -> Path:
    p = tmp_path / name
    p.write_text(json.dumps(scene))
    return p


def edit(**changes):
    """A copy of BASE with dotted-path edits; a value of ... deletes the key."""
    s = copy.deepcopy(BASE)
    for path, val in changes.items():
        keys = [int(k) if k.isdigit() else k for k in path.split("__")]
        obj = s
        for k in keys[:-1]:
            obj = obj[k]
        if val is ...:
            del obj[keys[-1]]
        else:
            obj[keys[-1]] = val
    return s


def test_base_scene_is_valid(tmp_path):
    cs = compile_scene(write(tmp_path, BASE))
    assert cs.num_triangles == 2 + 12 + 1 and cs.num_spheres == 1
    assert (cs.integrator, cs.max_depth, cs.rr_depth, cs.spp) == ("nee", 3, 2, 4)
    assert cs.materials.shape == (2, 20) and cs.materials[1, 0] == 2 and cs.materials[1, 4] == np.float32(0.2)
    np.testing.assert_array_equal(cs.materials[1, 1:4], 1.0)  # specular reflectance defaults to 1
    assert list(cs.shape_emitter) == [-1, -1, 0, -1]
    assert list(cs.light_prims) == [cs.num_triangles] and list(cs.light_cdf) == [0.0, 1.0]
    assert cs.prim_light[cs.num_triangles] == 0 and (cs.prim_light[: cs.num_triangles] == -1).all()
    np.testing.assert_allclose(cs.light_area, [math.pi], rtol=1e-6)
    for name in ("camera", "tri_vertices", "spheres", "bvh_nodes", "light_cdf", "materials"):
        assert getattr(cs, name).flags.c_contiguous


@pytest.mark.parametrize(
    "changes,key,message",
    [
        ({"shapes__3__material": "nope"}, "shapes[3].material", "unknown material 'nope'"),
        ({"shapes__1__colour": 1}, "shapes[1].colour", "unknown key"),
        ({"camera__fov": ...}, "camera.fov", "missing required key"),
        ({"camera__fov": "wide"}, "camera.fov", "expected a number"),
        ({"camera__fov": 180}, "camera.fov", "must be <"),
        ({"camera__width": 8.0}, "camera.width", "expected an integer"),
        ({"camera__width": True}, "camera.width", "expected an integer"),
        ({"camera__up": [0, 0, 1]}, "camera.up", "parallel"),
        ({"camera__origin": [0, 0]}, "camera.origin", "list of 3 numbers"),
        ({"integrator__type": "photon"}, "integrator.type", "unknown value 'photon'"),
        ({"integrator__spp": 0}, "integrator.spp", "must be >= 1"),
        ({"integrator__max_depth": -2}, "integrator.max_depth", "must be >= -1"),
        ({"materials__w__reflectance": [1, 2]}, "materials.w.reflectance", "list of 3 numbers"),
        ({"materials__w__reflectance": -0.5}, "materials.w.reflectance", ">= 0"),
        ({"materials__w__type": "principled"}, "materials.w.type", "unknown value 'principled'"),
        ({"materials__w__twosided": 1}, "materials.w.twosided", "expected true or false"),
        ({"materials__m__alpha": 0}, "materials.m.alpha", "must be >="),
        ({"materials__w__ior": 1.5}, "materials.w.ior", "unknown key"),
        ({"shapes__0__type": "torus"}, "shapes[0].type", "unknown value 'torus'"),
        ({"shapes__0__material": ...}, "shapes[0].material", "missing required key"),
        ({"shapes__1__transform": [{"scale": [1, 0, 1]}]}, "shapes[1].transform[0].scale", "zero"),
        ({"shapes__1__transform": [{"rotate": {"axis": [0, 1, 0]}}]}, "shapes[1].transform[0].rotate.angle",
         "missing"),
        ({"shapes__1__transform": [{"translate": [1, 2, 3], "scale": 2}]}, "shapes[1].transform[0]", "exactly one"),
        ({"shapes__1__transform": [{"matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]}]},
         "shapes[1].transform[0].matrix[3]", "affine"),
        ({"shapes__2__transform": [{"scale": [1, 2, 1]}]}, "shapes[2].transform", "uniform scales"),
        ({"shapes__2__radius": -1}, "shapes[2].radius", "must be >"),
        ({"shapes__2__emitter": {"type": "area"}}, "shapes[2].emitter.radiance", "missing"),
        ({"shapes__2__emitter": {"type": "spot", "radiance": 1}}, "shapes[2].emitter.type", "unknown value"),
        ({"shapes__3__faces": [[0, 1, 3]]}, "shapes[3].faces[0]", "outside 0..2"),
        ({"shapes__3__faces": [[0, 1.5, 2]]}, "shapes[3].faces[0][1]", "expected an integer"),
        ({"shapes__3__vertices": [[0, 0, 0], [1, 0], [0, 1, 0]]}, "shapes[3].vertices[1]", "3 numbers"),
        ({"shapes__3__vertices": ...}, "shapes[3].vertices", "missing"),
        ({"shapes__3__flip_normals": 1}, "shapes[3].flip_normals", "true or false"),
        ({"shapes": {"a": 1}}, "shapes", "expected a list"),
        ({"environment": {"type": "constant"}}, "environment.radiance", "missing"),
        ({"sky": 1}, "sky", "unknown key"),
    ],
)
def test_validation_errors_name_file_and_key(tmp_path, changes, key, message):
    path = write(tmp_path, edit(**changes), "bad.json")
    with pytest.raises(InputError) as e:
        compile_scene(path)
    text = str(e.value)
    assert text.startswith(f"{path}: {key}: "), text
    assert message in text, text


def test_file_level_errors(tmp_path):
    with pytest.raises(InputError, match="cannot read scene file"):
        load_scene(tmp_path / "none.json")
    bad = tmp_path / "broken.json"
    bad.write_text('{"camera": {,}}')
    with pytest.raises(InputError, match=r"broken.json:1:\d+: not valid JSON"):
        load_scene(bad)
    bad.write_text('{"camera": NaN}')
    with pytest.raises(InputError, match="NaN is not valid JSON"):
        load_scene(bad)
    bad.write_text("[1, 2]")
    with pytest.raises(InputError, match="expected an object"):
        load_scene(bad)


def test_overrides_are_validated(tmp_path):
    cs = compile_scene(write(tmp_path, BASE), integrator="path", spp=9, max_depth=-1)
    assert (cs.integrator, cs.spp, cs.max_depth, cs.rr_depth) == ("path", 9, -1, 2)
    with pytest.raises(InputError, match="settings.type: unknown value 'foo'"):
        cs.with_settings(integrator="foo")
    with pytest.raises(InputError, match="settings.spp"):
        cs.with_settings(spp=0)


def test_obj_mesh_relative_to_scene_file(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "quad.obj").write_text(
        "# a quad as one polygon\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n"
        "f -4 -3 -2\n")
    scene = edit(shapes=[{"type": "mesh", "material": "w", "obj": "meshes/quad.obj",
                          "transform": [{"translate": [0, 0, 1]}]}])
    cs = compile_scene(write(tmp_path, scene))
    assert cs.num_triangles == 3  # the quad as a fan of two, plus one by negative indices
    np.testing.assert_array_equal(cs.tri_vertices[0, :, :3], [[0, 0, 1], [1, 0, 1], [1, 1, 1]])
    (tmp_path / "meshes" / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    scene["shapes"][0]["obj"] = "meshes/bad.obj"
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj: .*bad.obj:3: face index 6 is outside"):
        compile_scene(write(tmp_path, scene))
    (tmp_path / "meshes" / "bad.obj").write_text("v 0 0 0\nv 1 0\n")
    with pytest.raises(InputError, match=r"bad.obj:2: a vertex needs three numbers"):
        compile_scene(write(tmp_path, scene))
    scene["shapes"][0]["obj"] = "meshes/missing.obj"
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj: cannot read OBJ file"):
        compile_scene(write(tmp_path, scene))


def test_transform_order_and_orientation(tmp_path):
    # A mirror transform keeps the front side where the transformed normal points; flip_normals reverses it.
    scene = edit(shapes=[
        {"type": "rectangle", "material": "w", "transform": [{"scale": [1, 1, -1]}]},
        {"type": "rectangle", "material": "w", "transform": [{"scale": [-1, 1, 1]}]},
        {"type": "rectangle", "material": "w", "flip_normals": True},
        {"type": "rectangle", "material": "w",
         "transform": [{"scale": 2}, {"rotate": {"axis": [0, 0, 1], "angle": 90}}, {"translate": [5, 0, 0]}]},
    ])
    cs = compile_scene(write(tmp_path, scene))
    t = cs.tri_vertices[:, :, :3].astype(np.float64)
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(n[0:2], [[0, 0, -1]] * 2, atol=1e-6)
    np.testing.assert_allclose(n[2:4], [[0, 0, 1]] * 2, atol=1e-6)  # -1 in x: the normal stays +z
    np.testing.assert_allclose(n[4:6], [[0, 0, -1]] * 2, atol=1e-6)
    # scale 2, then rotate, then translate: the square [3, 7] x [-2, 2]
    np.testing.assert_allclose(t[6:8].reshape(-1, 3).min(0), [3, -2, 0], atol=1e-5)
    np.testing.assert_allclose(t[6:8].reshape(-1, 3).max(0), [7, 2, 0], atol=1e-5)


@pytest.mark.parametrize("rows", [1, tf._ROWS, tf._ROWS + 1, 5 * tf._ROWS + 77])
def test_blocked_point_transform_is_bit_identical(rows):
    # apply_points multiplies a block of rows at a time (sparing BLAS threads): the bits of one big product.
    rng = np.random.default_rng(rows)
    p = rng.standard_normal((rows, 3)) * 10.0 ** rng.uniform(-4, 4, (rows, 1))
    m = tf.compose([tf.scale([-1.5, 0.25, 3.0]), tf.rotate([1, 2, 3], 37.0), tf.translate([0.1, -7.0, 2.5])])
    np.testing.assert_array_equal(tf.apply_points(m, p).view(np.uint64), (p @ m[:3, :3].T + m[:3, 3]).view(np.uint64))
    inv = np.linalg.inv(m[:3, :3])
    np.testing.assert_array_equal(tf.rows_times(p, inv).view(np.uint64), (p @ inv).view(np.uint64))


# --- the shipped scenes -------------------------------------------------------------------------------


def shape_tris(cs, name):
    k = cs.shape_names.index(name)
    return cs.tri_vertices[cs.prim_shape[: cs.num_triangles] == k][:, :, :3].astype(np.float64)


def normals(t):
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_cornell_box_matches_mitsuba_spec():
    cs = compile_scene(SCENES / "cornell.json")
    assert (cs.width, cs.height, cs.integrator, cs.max_depth, cs.rr_depth) == (256, 256, "mis", 8, 5)
    walls = {  # name: (axis, position, inward normal, albedo)
        "floor": (1, -1.0, [0, 1, 0], [0.885809, 0.698859, 0.666422]),
        "ceiling": (1, 1.0, [0, -1, 0], [0.885809, 0.698859, 0.666422]),
        "back": (2, -1.0, [0, 0, 1], [0.885809, 0.698859, 0.666422]),
        "red-wall": (0, -1.0, [1, 0, 0], [0.570068, 0.0430135, 0.0443706]),
        "green-wall": (0, 1.0, [-1, 0, 0], [0.105421, 0.37798, 0.076425]),
    }
    for name, (axis, pos, n, albedo) in walls.items():
        t = shape_tris(cs, name)
        pts = t.reshape(-1, 3)
        np.testing.assert_allclose(pts[:, axis], pos, atol=1e-6)
        others = [a for a in range(3) if a != axis]
        np.testing.assert_allclose(pts[:, others].min(0), [-1, -1], atol=1e-6)
        np.testing.assert_allclose(pts[:, others].max(0), [1, 1], atol=1e-6)
        np.testing.assert_allclose(normals(t), [n] * len(t), atol=1e-6)
        mat = cs.materials[cs.shape_material[cs.shape_names.index(name)]]
        assert mat[0] == 0
        np.testing.assert_allclose(mat[1:4], albedo, rtol=1e-6)
    # The light: y = 0.99, x in [-0.23, 0.23], z in [-0.18, 0.20], facing -y, white, radiance as specified.
    light = shape_tris(cs, "light")
    pts = light.reshape(-1, 3)
    np.testing.assert_allclose(pts[:, 1], 0.99, atol=1e-6)
    np.testing.assert_allclose(pts.min(0)[[0, 2]], [-0.23, -0.18], atol=1e-6)
    np.testing.assert_allclose(pts.max(0)[[0, 2]], [0.23, 0.20], atol=1e-6)
    np.testing.assert_allclose(normals(light), [[0, -1, 0]] * 2, atol=1e-6)
    k = cs.shape_names.index("light")
    np.testing.assert_allclose(cs.emitter_radiance[cs.shape_emitter[k], :3], [18.387, 13.9873, 6.75357])
    assert (cs.shape_emitter[np.arange(len(cs.shape_names)) != k] == -1).all()
    np.testing.assert_allclose(cs.materials[cs.shape_material[k], 1:4], [0.885809, 0.698859, 0.666422], rtol=1e-6)
    assert len(cs.light_prims) == 2
    np.testing.assert_allclose(cs.light_area.sum(), 0.46 * 0.38, rtol=1e-5)
    np.testing.assert_allclose(cs.light_cdf, [0, 0.5, 1], atol=1e-6)
    # The boxes: the unit cube scaled, rotated about +y, translated (in that order).
    for name, s, ang, tr in (("small-box", [0.3] * 3, -17.0, [0.335, -0.7, 0.38]),
                             ("large-box", [0.3, 0.61, 0.3], 18.25, [-0.33, -0.4, -0.28])):
        m = tf.compose([tf.scale(s), tf.rotate([0, 1, 0], ang), tf.translate(tr)])
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        want = tf.apply_points(m, corners)
        got = np.unique(np.round(shape_tris(cs, name).reshape(-1, 3), 5), axis=0)
        assert len(got) == 8
        for w in want:
            assert np.min(np.linalg.norm(got - w, axis=1)) < 1e-5
        # Outward normals: from the box centre to each face.
        t = shape_tris(cs, name)
        assert np.all(np.einsum("ij,ij->i", normals(t), t.mean(1) - tr) > 0)
    # A corner of the small box, computed by hand: local (1, 1, 1) -> scale 0.3 -> rotate -17 deg about y.
    a = math.radians(-17.0)
    x, z = 0.3 * math.cos(a) + 0.3 * math.sin(a), -0.3 * math.sin(a) + 0.3 * math.cos(a)
    got = np.unique(np.round(shape_tris(cs, "small-box").reshape(-1, 3), 5), axis=0)
    assert np.min(np.linalg.norm(got - [0.335 + x, -0.4, 0.38 + z], axis=1)) < 1e-5
    # Camera: at (0, 0, 3.9), forward -z, +x to the right of the image, +y up; fov 39.3077 deg on 256 x 256.
    np.testing.assert_allclose(cs.camera[0, :3], [0, 0, 3.9], atol=1e-6)
    np.testing.assert_allclose(cs.camera[3, :3], [0, 0, -1], atol=1e-7)
    th = math.tan(math.radians(39.3077) / 2)
    np.testing.assert_allclose(cs.camera[1, :3], [th, 0, 0], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(cs.camera[2, :3], [0, th, 0], rtol=1e-6, atol=1e-7)


def primary_rays(cs, sx, sy):
    cam = cs.camera.astype(np.float64)
    ndc_x, ndc_y = 2 * sx / cs.width - 1, 1 - 2 * sy / cs.height
    d = cam[3, :3] + ndc_x[:, None] * cam[1, :3] + ndc_y[:, None] * cam[2, :3]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.broadcast_to(cam[0, :3], d.shape).astype(np.float32), d.astype(np.float32)


def test_cornell_box_image_layout():
    """Left of the image is the red wall, right the green one, the top centre the light."""
    cs = compile_scene(SCENES / "cornell.json")
    px = np.array([[20, 128], [236, 128], [128, 36], [128, 250], [128, 0.5], [0.5, 128]])
    o, d = primary_rays(cs, px[:, 0].astype(float), px[:, 1].astype(float))
    hits = cast_rays(cs, o, d)
    names = [cs.shape_names[cs.prim_shape[p]] if p != MISS else None for p in hits.prim]
    assert names == ["red-wall", "green-wall", "light", "floor", None, None]


def test_cornell_light_power_in_cdf_units():
    cs = compile_scene(SCENES / "cornell.json")
    lum = float(np.array([18.387, 13.9873, 6.75357]) @ LUMINANCE)
    assert lum > 0 and np.all(np.diff(cs.light_cdf) > 0) and cs.light_pmf.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("name", ["furnace.json", "furnace_sphere.json"])
def test_furnace_is_closed_and_uniform(name):
    cs = compile_scene(SCENES / name)
    # A closed enclosure: rays from the camera in every direction hit it from inside, on its front side.
    rng = np.random.default_rng(0)
    d = rng.normal(size=(5000, 3)).astype(np.float32)
    o = np.broadcast_to(cs.camera[0, :3], d.shape).astype(np.float32)
    hits = cast_rays(cs, o, d)
    assert np.all(hits.prim != MISS)
    p = o + hits.t[:, None] * d
    _, _, n = prim_geometry(cs, hits.prim, p)
    assert np.all(np.einsum("ij,ij->i", n, d) < 0)  # the front faces the camera
    # Every surface emits the same radiance and has the same albedo.
    assert (cs.shape_emitter >= 0).all()
    assert np.ptp(cs.materials[:, 1:4], axis=0).max() == 0 and (cs.materials[:, 0] == 0).all()


def prim_geometry(cs, prims, p):
    """Areas, centroids-or-centres and front normals at points p of primitives (NumPy, for checks)."""
    from mcocl.render.raycast import query_prims

    n, area, _, _ = query_prims(cs, prims, p, np.zeros((len(prims), 2)))
    return area, None, n


def test_veach_scene_lights_have_equal_power():
    cs = compile_scene(SCENES / "veach_mis.json")
    sph = cs.light_prims[cs.light_prims >= cs.num_triangles]
    sph = sph[cs.spheres[sph - cs.num_triangles, 1] == 0]  # the row of four (not the fill light)
    assert len(sph) == 4
    radii = cs.spheres[sph - cs.num_triangles, 3]
    assert radii.max() / radii.min() > 20
    pmf = cs.light_pmf[np.isin(cs.light_prims, sph)]
    np.testing.assert_allclose(pmf, pmf.mean(), rtol=1e-3)
    alphas = sorted(cs.materials[cs.materials[:, 0] == 2, 4])
    assert len(alphas) == 4 and alphas[0] < alphas[-1] / 10


# Hit distances of primary rays through an 8 x 8 grid of film points, computed with Mitsuba 3.9.1
# (scalar_rgb): mi.load_dict(mi.cornell_box()) with near_clip 1e-6, sensor.sample_ray at film
# position (sx / 256, sy / 256), scene.ray_intersect(ray).t; None = no hit.
MITSUBA_GRID_X = np.linspace(2.1, 253.9, 8)
MITSUBA_GRID_Y = np.linspace(3.3, 252.7, 8)
MITSUBA_T = [
    [None] * 8,
    [None, 4.22661, 4.19015, 4.10953, 4.10953, 4.19015, 4.22661, None],
    [None, 4.15168, 5.0088, 4.96028, 4.96028, 5.0088, 4.15168, None],
    [None, 4.11369, 4.13848, 3.91799, 4.91221, 4.9612, 4.1137, None],
    [None, 4.11369, 4.13848, 3.91799, 4.91221, 4.9612, 4.1137, None],
    [None, 4.15168, 4.17818, 3.95633, 3.2988, 3.23335, 4.15168, None],
    [None, 4.22661, 4.19015, 4.03192, 3.36182, 3.29395, 4.22661, None],
    [None] * 8,
]


def test_cornell_primary_hits_match_mitsuba():
    """Camera convention and geometry against Mitsuba 3's own cornell_box() (independent reference)."""
    cs = compile_scene(SCENES / "cornell.json")
    sx, sy = np.meshgrid(MITSUBA_GRID_X, MITSUBA_GRID_Y)
    o, d = primary_rays(cs, sx.ravel(), sy.ravel())
    hits = cast_rays(cs, o, d)
    want = np.array([np.inf if t is None else t for row in MITSUBA_T for t in row])
    np.testing.assert_array_equal(np.isfinite(hits.t), np.isfinite(want))
    fin = np.isfinite(want)
    np.testing.assert_allclose(hits.t[fin], want[fin], rtol=5e-6, atol=2e-5)
