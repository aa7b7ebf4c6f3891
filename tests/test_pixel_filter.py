"""Reconstruction filters by filter importance sampling (kernels/render/pixel_filter.cl, mcocl/render/pixel_filter.py).

- chi-square of the film offsets the kernel draws against the filter's own
  profile, integrated exactly over the bins (tent and Gaussian in closed form);
- a constant-radiance scene renders to the same image under every filter;
- a straight edge between the environment and a black plane: each column's
  mean is the filter's mass on the bright side of the edge, a binomial
  proportion, checked column by column with z-tests (this fixes the
  centre convention and the sign of the offsets);
- the splatting integrators refuse non-box filters; the JSON key and the XML
  ``<rfilter>`` reach the compiled scene, with Mitsuba's Gaussian default in XML;
- the rest of the film and camera window: a crop renders its window of the
  film (gather and light tracing alike), near_clip hides what lies nearer and
  far_clip what lies farther (path tracing, light tracing and bdpt alike).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest
from chi2 import Chi2Family
from scipy import stats

import mcocl
from mcocl import runtime
from mcocl.errors import InputError
from mcocl.render.compiled import compile_scene
from mcocl.render.pixel_filter import BOX, PixelFilter, make_filter, parse_filter
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"

N = 1 << 17
FILTERS = [make_filter("tent"), make_filter("tent", radius=1.7), make_filter("gaussian"),
           make_filter("gaussian", stddev=0.3), BOX]
FAMILY = Chi2Family("pixel filter sampling", len(FILTERS))


def _offsets(f: PixelFilter, n: int = N, seed: int = 3, lanes: int = 1) -> np.ndarray:
    ctx = runtime.device_context()
    src = runtime.compose(["render/pixel_filter_test.cl"])
    prg = runtime.build(ctx, src, [f"-DLANES={lanes}", *f.defines()], what="pixel filter test kernel")
    out = np.empty(n, np.float32)
    buf = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    g, lsz = ctx.work_size(n // lanes)
    runtime.kernel(prg, "filter_offsets")(ctx.queue, g, lsz, *f.launch_values(), np.uint64(seed), np.uint32(n), buf)
    cl.enqueue_copy(ctx.queue, out, buf)
    return out


@pytest.mark.parametrize("f", FILTERS, ids=lambda f: f"{f.kind}-{f.radius:g}")
def test_offsets_follow_the_filter(f: PixelFilter) -> None:
    x = _offsets(f).astype(np.float64)
    assert np.all(np.abs(x) <= f.radius + 1e-6)
    edges = np.linspace(-f.radius, f.radius, 81)
    observed, _ = np.histogram(np.clip(x, -f.radius, f.radius), edges)
    mass = f.integral(edges[:-1], edges[1:])
    expected = N * mass / f.integral(np.array(-f.radius), np.array(f.radius))
    FAMILY.check(f"{f.kind} r={f.radius:g}", observed, expected)


def test_lane_build_draws_the_scalar_offsets() -> None:
    f = make_filter("gaussian")
    a, b = _offsets(f, 4096, lanes=8), _offsets(f, 4096, lanes=1)
    # the vector and scalar erf differ in the last bits; the root moves by ulp(H) / f1(x)
    tol = 4 * np.finfo(np.float32).eps / np.maximum(f.profile(b), 1e-3)
    assert np.all(np.abs(a - b) <= tol + 1e-6)


def _inverse_cdf(f: PixelFilter, u: np.ndarray) -> np.ndarray:
    """The exact quantiles of the filter (float64 bisection on its closed-form integral)."""
    lo, hi = np.full(len(u), -f.radius), np.full(len(u), f.radius)
    total = f.integral(np.array(-f.radius), np.array(f.radius))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        below = f.integral(np.full(len(u), -f.radius), mid) < u * total
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("f", [make_filter("gaussian"), make_filter("gaussian", stddev=1.3), make_filter("tent")],
                         ids=lambda f: f"{f.kind}-{f.stddev:g}")
def test_offsets_are_the_exact_quantiles(f: PixelFilter) -> None:
    # the kernel inverts the CDF to float precision: the error is ulp(CDF) / density
    n = 4096
    u = ((np.arange(n) + 0.5) / n).astype(np.float32)
    ctx = runtime.device_context()
    prg = runtime.build(ctx, runtime.compose(["render/pixel_filter_test.cl"]), ["-DLANES=8", *f.defines()],
                        what="pixel filter test kernel")
    mf = cl.mem_flags
    bu = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=u)
    out = np.empty(n, np.float32)
    bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
    g, lsz = ctx.work_size(n // 8)
    runtime.kernel(prg, "filter_offsets_of")(ctx.queue, g, lsz, *f.launch_values(), np.uint32(n), bu, bo)
    cl.enqueue_copy(ctx.queue, out, bo)
    exact = _inverse_cdf(f, u.astype(np.float64))
    peak = f.profile(np.array([0.0]))[0]
    tol = 8 * np.finfo(np.float32).eps * f.radius * peak / np.maximum(f.profile(exact), 1e-3 * peak) + 1e-6
    err = np.abs(out - exact)
    assert np.all(err <= tol), (err / tol).max()


def test_filter_profile_matches_mitsuba_definition() -> None:
    # Mitsuba 3: gaussian stddev 0.5, radius 4 stddev, exp(-x^2/(2 s^2)) minus its value at the radius
    g = make_filter("gaussian")
    assert g.radius == 2.0 and g.stddev == 0.5
    assert g.profile(np.array([0.5]))[0] == pytest.approx(math.exp(-0.5) - math.exp(-8.0))
    assert g.profile(np.array([2.0]))[0] == 0.0
    t = make_filter("tent")
    assert t.radius == 1.0 and t.profile(np.array([0.25]))[0] == 0.75


def _scene(tmp_path: Path, filt, shapes: list, env: float | None, max_depth: int = 1, size: int = 16,
           light_sampler: str = "auto") -> Path:
    cam = {"origin": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov": 90, "width": size, "height": size}
    if filt is not None:
        cam["filter"] = filt
    data = {"camera": cam, "integrator": {"type": "mis", "max_depth": max_depth, "spp": 4, "light_sampler": light_sampler},
            "materials": {"black": {"type": "diffuse", "reflectance": [0, 0, 0]}}, "shapes": shapes}
    if env is not None:
        data["environment"] = {"type": "constant", "radiance": [env, env, env]}
    p = tmp_path / "scene.json"
    p.write_text(json.dumps(data))
    return p


def test_constant_radiance_is_the_same_under_every_filter(tmp_path: Path) -> None:
    # the camera inside an emitting cube with black walls, max_depth 1: every sample sees exactly Le
    shapes = [{"type": "cube", "material": "black", "flip_normals": True, "transform": [{"scale": 3.0}],
               "emitter": {"type": "area", "radiance": [0.25, 0.5, 0.75]}}]
    images = [mcocl.render(_scene(tmp_path, f, shapes, None), spp=16, seed=2).mean
              for f in ("box", "tent", {"type": "gaussian", "stddev": 0.7})]
    for im in images:
        np.testing.assert_array_equal(im, images[0])
    np.testing.assert_allclose(images[0][..., 0], 0.25)


@pytest.mark.parametrize("filt,sampler", [(make_filter("gaussian"), "independent"),
                                          (make_filter("tent", radius=1.5), "independent"), (BOX, "independent"),
                                          (make_filter("gaussian"), "sobol")], ids=lambda x: getattr(x, "kind", x))
def test_an_edge_is_blurred_by_the_filter(tmp_path: Path, filt: PixelFilter, sampler: str) -> None:
    # a black plane covers x > 0 at z = -1: its edge is the film's centre line sx = W / 2 exactly
    size, spp = 16, 256
    shapes = [{"type": "rectangle", "material": "black",
               "transform": [{"scale": [50.0, 50.0, 1.0]}, {"translate": [50.0, 0.0, -1.0]}]}]
    # bvh, though the environment is the only light (chosen with probability 1 by any light sampler): the
    # builds of the Cornell-box filter tests (tests/test_render_bdpt_sobol.py, test_mitsuba_xml.py)
    p = _scene(tmp_path, filt.to_json(), shapes, 1.0, size=size, light_sampler="bvh")
    img = mcocl.render(p, spp=spp, seed=9, sampler=sampler).mean[..., 0]
    col = img.mean(axis=0).astype(np.float64)
    centre = np.arange(size) + 0.5
    total = filt.integral(np.array(-filt.radius), np.array(filt.radius))
    p = filt.integral(np.full(size, -filt.radius), np.minimum(size / 2 - centre, filt.radius)) / total
    p = np.clip(p, 0.0, 1.0)
    n = size * spp
    exact = (p <= 1e-12) | (p >= 1 - 1e-12)
    np.testing.assert_array_equal(col[exact], np.round(p[exact]))
    z = (col[~exact] - p[~exact]) / np.sqrt(p[~exact] * (1 - p[~exact]) / n)
    assert np.all(np.abs(z) < 4.5), (z, col, p)
    assert (~exact).sum() >= (2 if filt.kind != "box" else 0)  # the blur reaches past the edge pixels


@pytest.mark.parametrize("integrator", ["lt", "bdpt"])
@pytest.mark.parametrize("filt", [make_filter("gaussian"), make_filter("tent", radius=1.5)], ids=lambda f: f.kind)
def test_splatting_integrators_blur_an_edge_as_the_filter(tmp_path: Path, integrator: str, filt: PixelFilter) -> None:
    """The edge scene of the test above, by lt and bdpt: every pixel against its exact value, the filter's mass
    over the lit half (environment radiance 1).  lt sees the environment only through its splats
    (kernels/render/lt.cl, splat_filtered), so this checks the splat weights pixel by pixel, and in the first
    and last columns the connections that land in the margin past the image's edge (without them those
    columns lose the filter's mass outside the image, 22 % for the tent of radius 1.5).  Per-pixel z-tests
    with the batch variance at the Sidak level (family-wise 1e-3; dependent pixels keep Sidak's bound)."""
    size, spp = 16, 256
    shapes = [{"type": "rectangle", "material": "black",
               "transform": [{"scale": [50.0, 50.0, 1.0]}, {"translate": [50.0, 0.0, -1.0]}]}]
    # the light sampler is incidental here (the environment is the only light, chosen with probability 1): bvh
    # is the one the Cornell-box filter tests below build, so lt and bdpt share their shaped-filter builds
    # (a bdpt build costs 20 to 30 s on a cold PoCL cache)
    scene = _scene(tmp_path, filt.to_json(), shapes, 1.0, size=size, light_sampler="bvh")
    img = mcocl.render(scene, spp=spp, seed=4, integrator=integrator, spp_per_block=8)
    assert img.nonfinite == 0
    centre = np.arange(size) + 0.5
    total = filt.integral(np.array(-filt.radius), np.array(filt.radius))
    p = np.clip(filt.integral(np.full(size, -filt.radius), np.minimum(size / 2 - centre, filt.radius)) / total,
                0.0, 1.0)
    want = np.broadcast_to(p[None, :, None], img.mean.shape)
    mean, var = img.mean.astype(np.float64), img.variance.astype(np.float64)
    # bdpt's camera paths see the environment (radiance 1) with weight 1: exact where the filter lies in one
    # half; 0 or 1 where the other half holds a tail of the filter that none of the pixel's samples may reach
    exact = var <= 0.0
    level = 1e-3 / want.size
    missed = ((mean == 0.0) & ((1.0 - want) ** spp > level)) | ((mean == 1.0) & (want**spp > level))
    assert np.all((np.abs(mean - want) <= 1e-6)[exact & ~missed]), np.abs(mean - want)[exact & ~missed].max()
    z = (mean - want)[~exact] / np.sqrt(var[~exact])
    assert 2 * stats.norm.sf(np.abs(z).max()) > 1 - (1 - 1e-3) ** (1 / z.size), np.abs(z).max()


# Filters whose support does not reach the ceiling light from two pixel rows away: there a camera sample lands
# on the light rarely and brightly, a tail that a mis reference and its variance estimate sample poorly.
@pytest.mark.parametrize("integrator,filt", [("lt", make_filter("gaussian", stddev=0.3)),
                                             ("bdpt", make_filter("tent", radius=1.5))],
                         ids=["lt-gaussian", "bdpt-tent"])
def test_splatting_integrators_agree_with_mis_under_a_filter(integrator: str, filt: PixelFilter) -> None:
    """lt and bdpt splat camera connections with the filter's weight (kernels/render/lt.cl, splat_filtered) and
    bdpt's MIS weights stay those of the box (they do not depend on the pixel): on a 32 x 32 Cornell box every
    pixel agrees with mis under the same filter (the image's edge is black here: the test above checks it).

    Per-pixel z-tests with the Sidak level (family-wise 1e-3): one light path splats into several neighbouring
    pixels, so pixels are dependent, but each pixel's batch variance is honest and Sidak's bound holds for
    two-sided tests of dependent normal statistics."""
    sc = load_scene(SCENES / "cornell.json")
    sc.camera.width = sc.camera.height = 32
    sc.camera.pixel_filter = filt
    cs = compile_scene(sc)
    a = mcocl.render(cs, spp=4096, integrator="mis", seed=3)
    # the independent sampler this test was written for: its per-pixel z-scores are seed-sensitive for either
    # bdpt sampler (max |z| 4.1-6.3 over seeds 2-4 against this mis; tests/test_render_bdpt_sobol.py has sobol's
    # filter test, by blocks)
    b = mcocl.render(cs, spp=256 if integrator == "bdpt" else 512, integrator=integrator, seed=2, spp_per_block=8,
                     sampler="independent")
    assert b.nonfinite == 0
    z = (a.mean.astype(np.float64) - b.mean) / np.sqrt(a.variance.astype(np.float64) + b.variance)
    assert np.all(np.isfinite(z))
    assert 2 * stats.norm.sf(np.abs(z).max()) > 1 - (1 - 1e-3) ** (1 / z.size), np.abs(z).max()
    # the rows and columns at the image's edge, where the margin matters, agree on average as well: their
    # sum's variance is bounded by (sum of the pixels' standard errors)^2 whatever their correlation
    edge = np.zeros(z.shape[:2], bool)
    edge[[0, -1], :] = edge[:, [0, -1]] = True
    diff = (a.mean.astype(np.float64) - b.mean)[edge].sum(axis=0)
    bound = np.sqrt(a.variance.astype(np.float64) + b.variance)[edge].sum(axis=0)
    assert np.all(np.abs(diff) < 4.0 * bound), (diff, bound)


def test_json_filter_errors() -> None:
    assert parse_filter("gaussian") == make_filter("gaussian")
    assert parse_filter({"type": "tent", "radius": 2}).radius == 2.0
    for bad, what in (("lanczos", "unknown"), ({"type": "box", "radius": 1}, "radius"),
                      ({"type": "gaussian", "radius": 1}, "stddev"), ({"type": "tent", "radius": -1}, "radius"),
                      ({"type": "tent", "width": 1}, "width"), (3, "filter")):
        with pytest.raises(InputError, match=what):
            parse_filter(bad)


def _xml(tmp_path: Path, rfilter: str) -> Path:
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>'
                 '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>'
                 + rfilter + '</film></sensor><shape type="cube"/></scene>')
    return p


def test_xml_rfilter(tmp_path: Path) -> None:
    assert compile_scene(_xml(tmp_path, "")).pixel_filter == make_filter("gaussian")  # Mitsuba's default
    assert compile_scene(_xml(tmp_path, '<rfilter type="box"/>')).pixel_filter == BOX
    cs = compile_scene(_xml(tmp_path, '<rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter>'))
    assert cs.pixel_filter == make_filter("gaussian", stddev=0.25)
    cs = compile_scene(_xml(tmp_path, '<rfilter type="tent"><float name="radius" value="1.5"/></rfilter>'))
    assert cs.pixel_filter == make_filter("tent", radius=1.5)
    with pytest.raises(InputError, match="lanczos"):
        compile_scene(_xml(tmp_path, '<rfilter type="lanczos"/>'))


def _edge_columns(tmp_path: Path, crop, integrator: str = "mis", spp: int = 256) -> np.ndarray:
    shapes = [{"type": "rectangle", "material": "black",
               "transform": [{"scale": [50.0, 50.0, 1.0]}, {"translate": [50.0, 0.0, -1.0]}]}]
    p = _scene(tmp_path, None, shapes, 1.0, size=16)
    data = json.loads(p.read_text())
    if crop is not None:
        data["camera"]["crop"] = crop
    p.write_text(json.dumps(data))
    return mcocl.render(p, spp=spp, seed=4, integrator=integrator).mean[..., 0]


def test_crop_renders_its_window_of_the_film(tmp_path: Path) -> None:
    # the edge x = 0 is the film's column boundary 8; a crop at x offset 5 sees it at its column 3
    img = _edge_columns(tmp_path, {"offset": [5, 2], "size": [6, 9]})
    assert img.shape == (9, 6)
    np.testing.assert_array_equal(img[:, :3], 1.0)
    np.testing.assert_array_equal(img[:, 3:], 0.0)
    img = _edge_columns(tmp_path, {"offset": [9, 0], "size": [7, 16]})
    np.testing.assert_array_equal(img, 0.0)


def test_crop_light_tracing_lands_in_the_same_window(tmp_path: Path) -> None:
    # lt connects to the camera through the importance: the crop's window must match the gather side
    cam = {"origin": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov": 90, "width": 16, "height": 16,
           "crop": {"offset": [4, 6], "size": [8, 5]}}
    data = {"camera": cam, "integrator": {"type": "mis", "max_depth": 2, "spp": 4},
            "materials": {"white": {"type": "diffuse", "reflectance": [0.8, 0.8, 0.8]}},
            "shapes": [{"type": "rectangle", "material": "white", "transform": [{"scale": 2.0},
                                                                               {"translate": [0.3, 0, -1.0]}]},
                       {"type": "rectangle", "material": "white", "emitter": {"type": "area", "radiance": [4, 4, 4]},
                        "transform": [{"scale": 0.3}, {"rotate": {"axis": [1, 0, 0], "angle": 180}},
                                      {"translate": [0.0, 0.0, 1.0]}]}]}
    p = tmp_path / "lit.json"
    p.write_text(json.dumps(data))
    a = mcocl.render(p, spp=256, integrator="mis", seed=1)
    b = mcocl.render(p, spp=256, integrator="lt", seed=2, spp_per_block=16)
    z = (a.mean - b.mean) / np.sqrt(a.stderr ** 2 + b.stderr ** 2 + 1e-30)
    assert a.mean.shape == (5, 8, 3) and a.mean.mean() > 0.01
    assert np.all(np.abs(z) < 5.0), np.abs(z).max()


def test_crop_errors_and_xml(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="crop"):
        _edge_columns(tmp_path, {"offset": [10, 0], "size": [7, 16]})
    p = _xml(tmp_path, '<rfilter type="box"/><integer name="crop_offset_x" value="2"/>'
                       '<integer name="crop_width" value="3"/>')
    cs = compile_scene(p)
    assert (cs.width, cs.height) == (3, 8)
    with pytest.raises(InputError, match="crop_width"):
        compile_scene(_xml(tmp_path, '<integer name="crop_offset_x" value="6"/><integer name="crop_width" value="3"/>'))


def _assert_sees(img, seen: float) -> None:
    """The image is black where seen is 0; else it is the sky's radiance 1 (z-test of the image mean)."""
    if seen == 0.0:
        np.testing.assert_array_equal(img.mean, 0.0)
        return
    stderr = np.sqrt((img.stderr ** 2).sum()) / img.stderr.size
    assert abs(img.mean.mean() - seen) <= 5.0 * stderr, (img.mean.mean(), stderr)


def test_near_clip_hides_what_lies_nearer(tmp_path: Path) -> None:
    # a black plane 0.5 in front of the camera hides the environment unless the near clip passes it
    shapes = [{"type": "rectangle", "material": "black",
               "transform": [{"scale": 10.0}, {"translate": [0.0, 0.0, -0.5]}]}]
    p = _scene(tmp_path, None, shapes, 1.0, size=8)
    data = json.loads(p.read_text())
    np.testing.assert_array_equal(mcocl.render(p, spp=4, seed=1).mean, 0.0)
    for near, seen in ((0.45, 0.0), (0.55, 1.0)):
        data["camera"]["near_clip"] = near
        p.write_text(json.dumps(data))
        np.testing.assert_array_equal(mcocl.render(p, spp=4, seed=1).mean, seen)
    for integrator in ("lt", "bdpt"):
        # the splatting integrators see through the plane as mis does (kernels/render/camera.cl)
        _assert_sees(mcocl.render(p, spp=16, seed=1, integrator=integrator, spp_per_block=4), 1.0)
    assert compile_scene(_clip_xml(tmp_path, "near_clip", "0.25")).near_clip == 0.25
    assert compile_scene(_xml(tmp_path, "")).near_clip == 0.01  # Mitsuba's default


def _clip_xml(tmp_path: Path, name: str, value: str) -> Path:
    """``clip.xml``: the box-filter XML scene of :func:`_xml` with the sensor's float ``name`` set to ``value``."""
    xml = _xml(tmp_path, '<rfilter type="box"/>').read_text()
    p = tmp_path / "clip.xml"
    p.write_text(xml.replace('<float name="fov" value="40"/>',
                             f'<float name="fov" value="40"/><float name="{name}" value="{value}"/>'))
    return p


def test_far_clip_hides_what_lies_farther(tmp_path: Path) -> None:
    # the black plane 0.5 in front hides the environment unless the far clip plane lies before it
    # (Mitsuba 3: maxt = (far_clip - near_clip) / cos from the near-clipped origin)
    shapes = [{"type": "rectangle", "material": "black",
               "transform": [{"scale": 10.0}, {"translate": [0.0, 0.0, -0.5]}]}]
    p = _scene(tmp_path, None, shapes, 1.0, size=8)
    data = json.loads(p.read_text())
    for clip, seen in (({"far_clip": 0.45}, 1.0), ({"near_clip": 0.2, "far_clip": 0.55}, 0.0)):
        data["camera"].update(clip)
        p.write_text(json.dumps(data))
        np.testing.assert_array_equal(mcocl.render(p, spp=4, seed=1).mean, seen)
        for integrator in ("lt", "bdpt"):
            _assert_sees(mcocl.render(p, spp=16, seed=1, integrator=integrator, spp_per_block=4), seen)
    del data["camera"]["near_clip"]
    data["camera"].update(near_clip=0.6)
    p.write_text(json.dumps(data))
    with pytest.raises(InputError, match=r"camera\.far_clip"):
        compile_scene(p)
    assert compile_scene(_clip_xml(tmp_path, "far_clip", "25")).far_clip == 25.0
    assert compile_scene(_xml(tmp_path, "")).far_clip == 1e4  # Mitsuba's default
    with pytest.raises(InputError, match=r"clip\.xml:\d+: .*far_clip must exceed near_clip"):
        compile_scene(_clip_xml(tmp_path, "far_clip", "0"))
