"""Mitsuba XML scenes: the shipped scenes' XML twins compile and render bit-identically to their JSON files;
every property type, transform, default and parameter is read as Mitsuba defines it; bad input is an
InputError naming the file and line."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import mcocl
from mcocl.cli import main
from mcocl.errors import InputError, SceneSubstitutionWarning
from mcocl.render.compiled import CompiledScene, compile_scene
from mcocl.render.mitsuba import read_mitsuba
from mcocl.render.mitsuba.sensor import FAR_CLIP, NEAR_CLIP
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
TWINS = ["cornell", "furnace", "furnace_sphere", "veach_mis"]
TINY = {"cornell": (8, 8), "furnace": (8, 6), "furnace_sphere": (6, 8), "veach_mis": (12, 8)}

SENSOR = """
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>"""


def write(tmp_path: Path, body: str, name: str = "s.xml", version: str = "3.0.0", sensor: bool = True) -> Path:
    p = tmp_path / name
    p.write_text(f'<?xml version="1.0"?>\n<scene version="{version}">{SENSOR if sensor else ""}\n{body}\n</scene>\n')
    return p


def line_of(path: Path, text: str) -> int:
    """1-based line of the first occurrence of ``text`` in ``path``."""
    return next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if text in ln)


def shape_with(tmp_path: Path, inner: str, shape: str = "rectangle", **kw) -> Path:
    return write(tmp_path, f'<shape type="{shape}">{inner}</shape>', **kw)


# --- the shipped scenes' twins ------------------------------------------------------------------------------


@pytest.mark.parametrize("name", TWINS)
def test_twin_compiles_to_the_same_arrays(name):
    a, b = compile_scene(SCENES / f"{name}.json"), compile_scene(SCENES / "xml" / f"{name}.xml")
    arrays = [f.name for f in dataclasses.fields(CompiledScene) if isinstance(getattr(a, f.name), np.ndarray)]
    assert len(arrays) >= 17
    for k in arrays:
        x, y = getattr(a, k), getattr(b, k)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), k
    for k in ("width", "height", "integrator", "max_depth", "rr_depth", "spp", "shape_names"):
        assert getattr(a, k) == getattr(b, k), k


@pytest.mark.parametrize("name", TWINS)
def test_twin_renders_bit_identically(name):
    w, h = TINY[name]
    data = json.loads((SCENES / f"{name}.json").read_text())
    # the XML sensor takes Mitsuba's clip planes by default (mcocl/render/mitsuba/sensor.py)
    data["camera"].update(width=w, height=h, near_clip=NEAR_CLIP, far_clip=FAR_CLIP)
    r_json = mcocl.render(parse_scene(data, SCENES / f"{name}.json"), spp=2, seed=3)
    r_xml = mcocl.render(SCENES / "xml" / f"{name}.xml", spp=2, seed=3, params={"resx": w, "resy": h})
    assert r_xml.mean.shape == (h, w, 3)
    assert np.array_equal(r_json.mean, r_xml.mean) and np.array_equal(r_json.variance, r_xml.variance)
    assert (r_xml.mean.sum(-1) > 0).mean() > 0.5  # mostly lit: the comparison is not between two black images


# --- property types -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("value,rgb", [("0.1 0.2 0.3", [0.1, 0.2, 0.3]), ("0.1, 0.2, 0.3", [0.1, 0.2, 0.3]),
                                       ("0.25", [0.25] * 3)])
def test_rgb_forms(tmp_path, value, rgb):
    p = write(tmp_path, f'<bsdf type="diffuse" id="m"><rgb name="reflectance" value="{value}"/></bsdf>')
    assert read_mitsuba(p)["materials"]["m"]["reflectance"] == (rgb[0] if len(set(rgb)) == 1 else rgb)


# What Mitsuba 3.9.1 (variant scalar_rgb) makes of <spectrum> properties, measured by loading each element
# inside a <scene version="3.0.0"> with mitsuba.load_string and reading the texture's value from
# mitsuba.traverse (e.g. "<bsdf type="diffuse"><spectrum name="reflectance" value="500:0.2, 600:0.8"/></bsdf>"
# -> reflectance.value). Mitsuba stores float32, so the bound is float32 rounding plus the sum's.
MITSUBA_SPECTRA = [
    # (element with the property, mcocl JSON path, Mitsuba's RGB)
    ('<bsdf type="diffuse" id="m"><spectrum name="reflectance" value="0.3"/></bsdf>',
     ("materials", "m", "reflectance"), [0.3, 0.3, 0.3]),
    # a reflectance is weighted by D65 (a flat one is grey up to the sum's error) and clipped to [0, 1]
    ('<bsdf type="diffuse" id="m"><spectrum name="reflectance" value="400:0.6, 700:0.6"/></bsdf>',
     ("materials", "m", "reflectance"), [0.5972052, 0.5998539, 0.5969455]),
    ('<bsdf type="diffuse" id="m"><spectrum name="reflectance" value="500:0.2, 600:0.8"/></bsdf>',
     ("materials", "m", "reflectance"), [0.2787710, 0.4713645, 0.0]),
    ('<bsdf type="diffuse" id="m"><spectrum name="reflectance" value="400:2, 700:2"/></bsdf>',
     ("materials", "m", "reflectance"), [1.0, 1.0, 1.0]),
    ('<bsdf type="plastic" id="m"><spectrum name="diffuse_reflectance" value="500:0.2, 600:0.8"/></bsdf>',
     ("materials", "m", "diffuse_reflectance"), [0.2787710, 0.4713645, 0.0]),
    # a conductor's eta/k: weighted by D65, not clipped above 1
    ('<bsdf type="conductor" id="m"><spectrum name="eta" value="400:2, 700:2"/>'
     '<spectrum name="k" value="500:0.2, 600:3"/></bsdf>', ("materials", "m", "eta"), [1.9906840, 1.9995128, 1.9898182]),
    ('<bsdf type="conductor" id="m"><spectrum name="eta" value="400:2, 700:2"/>'
     '<spectrum name="k" value="500:0.2, 600:3"/></bsdf>', ("materials", "m", "k"), [1.1470754, 1.4490148, 0.0]),
    # an emitted spectrum: one number is the equal-energy white, wavelength:value pairs have no D65 weight
    ('<emitter type="constant"><spectrum name="radiance" value="0.8"/></emitter>',
     ("environment", "radiance"), [0.9638352, 0.7586328, 0.7271329]),
    ('<emitter type="constant"><spectrum name="radiance" value="500:0.2, 600:0.8"/></emitter>',
     ("environment", "radiance"), [0.3151602, 0.4613314, 0.0]),
    ('<emitter type="constant"><spectrum name="radiance" value="400:2, 700:2"/></emitter>',
     ("environment", "radiance"), [2.3993871, 1.8990407, 1.8068867]),
    ('<shape type="sphere"><emitter type="area"><spectrum name="radiance" value="0.8"/></emitter></shape>',
     ("shapes", 0, "emitter", "radiance"), [0.9638352, 0.7586328, 0.7271329]),
    ('<emitter type="point"><spectrum name="intensity" value="2"/></emitter>',
     ("lights", 0, "intensity"), [2.4095879, 1.8965820, 1.8178321]),
    ('<emitter type="spot"><spectrum name="intensity" value="2"/></emitter>',
     ("lights", 0, "intensity"), [2.4095879, 1.8965820, 1.8178321]),
    ('<emitter type="directional"><spectrum name="irradiance" value="2"/></emitter>',
     ("lights", 0, "irradiance"), [2.4095879, 1.8965820, 1.8178321]),
    ('<emitter type="point"><spectrum name="intensity" value="500:0.2, 600:0.8"/></emitter>',
     ("lights", 0, "intensity"), [0.3151602, 0.4613314, 0.0]),
    # a <float> or <rgb> radiance is grey, as is the default
    ('<emitter type="constant"><float name="radiance" value="0.8"/></emitter>', ("environment", "radiance"),
     [0.8, 0.8, 0.8]),
    ('<emitter type="constant"><rgb name="radiance" value="0.8"/></emitter>', ("environment", "radiance"),
     [0.8, 0.8, 0.8]),
    ('<emitter type="constant"/>', ("environment", "radiance"), [1.0, 1.0, 1.0]),
]


@pytest.mark.parametrize("element,path,rgb", MITSUBA_SPECTRA)
def test_spectrum_as_mitsuba_reads_it(tmp_path, element, path, rgb):
    v = read_mitsuba(write(tmp_path, element))
    for k in path:
        v = v[k]
    np.testing.assert_allclose(np.broadcast_to(v, 3), rgb, rtol=2e-6, atol=1e-7)


def test_spectrum_constant_and_sampled(tmp_path):
    body = ('<bsdf type="diffuse" id="c"><spectrum name="reflectance" value="0.3"/></bsdf>'
            '<bsdf type="diffuse" id="flat"><spectrum name="reflectance" value="360:0.5, 830:0.5"/></bsdf>'
            '<bsdf type="diffuse" id="flat2"><spectrum name="reflectance" value="360:1, 600:1, 830:1"/></bsdf>'
            '<emitter type="constant"><spectrum name="radiance" value="0.5"/></emitter>')
    scene = read_mitsuba(write(tmp_path, body))
    m = scene["materials"]
    assert m["c"]["reflectance"] == 0.3
    # A flat reflectance is weighted by D65, whose linear sRGB is white: grey, up to Mitsuba's Riemann sum
    # (0.1 % low; Mitsuba 3.9.1 scalar_rgb gives (0.4994926, 0.4994369, 0.4994008), measured as above).
    np.testing.assert_allclose(m["flat"]["reflectance"], [0.4994926, 0.4994369, 0.4994008], rtol=2e-6)
    np.testing.assert_allclose(m["flat"]["reflectance"], 0.5, rtol=2e-3)
    np.testing.assert_allclose(m["flat2"]["reflectance"], 2 * np.array(m["flat"]["reflectance"]), rtol=1e-12)
    # A one-number radiance is the equal-energy white E: CIE 1931 normalises x̄, ȳ, z̄ to equal integrals, so
    # XYZ = (v, v, v), and its linear sRGB is v times the row sums of the XYZ -> sRGB matrix (IEC 61966-2-1).
    e_white = np.array([3.240479 - 1.537150 - 0.498535, -0.969256 + 1.875991 + 0.041556,
                        0.055648 - 0.204043 + 1.057311])
    np.testing.assert_allclose(scene["environment"]["radiance"], 0.5 * e_white, rtol=1e-12)


def test_spectrum_of_a_red_band_is_red(tmp_path):
    p = write(tmp_path, '<bsdf type="diffuse" id="r"><spectrum name="reflectance" '
                        'value="360:0, 599:0, 600: 1, 700 :1, 701:0, 830:0"/></bsdf>')
    r, g, b = read_mitsuba(p)["materials"]["r"]["reflectance"]
    assert r > 5 * g and g >= b >= 0.0


def test_scalar_types_and_their_errors(tmp_path):
    p = write(tmp_path, '<integrator type="path"><integer name="max_depth" value="7"/>'
                        '<integer name="rr_depth" value=" 3"/><boolean name="hide_emitters" value="FALSE"/></integrator>')
    integ = read_mitsuba(p)["integrator"]
    assert (integ["max_depth"], integ["rr_depth"]) == (7, 3)
    for elem, msg in [('<integer name="max_depth" value="7.5"/>', "could not parse integer"),
                      ('<boolean name="hide_emitters" value="yes"/>', "could not parse boolean"),
                      ('<integer name="max_depth" value="3"/><integer name="max_depth" value="4"/>', "given twice")]:
        p = write(tmp_path, f'<integrator type="path">\n{elem}\n</integrator>')
        with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, elem)}: .*{msg}"):
            read_mitsuba(p)
    p = shape_with(tmp_path, '<float name="radius" value="wide"/>', "sphere")
    with pytest.raises(InputError, match=r"could not parse float value 'wide'"):
        read_mitsuba(p)


def test_point_forms_and_sphere(tmp_path):
    for point in ('<point name="center" x="1" y="2" z="3"/>', '<point name="center" value="1 2 3"/>'):
        p = shape_with(tmp_path, point + '<float name="radius" value="0.5"/>', "sphere")
        sh = load_scene(p).shapes[0]
        assert sh.kind == "sphere" and list(sh.center) == [1, 2, 3] and sh.radius == 0.5


def _matrix_of(tmp_path, ops: str) -> np.ndarray:
    return load_scene(shape_with(tmp_path, f'<transform name="to_world">{ops}</transform>', "cube")).shapes[0].matrix


def test_transform_composes_in_the_order_written(tmp_path):
    m = _matrix_of(tmp_path, '<scale x="1" y="2" z="3"/><rotate z="1" angle="90"/><translate x="1" y="2" z="3"/>'
                             '<matrix value="1 0 0 0  0 0 -1 0  0 1 0 0  0 0 0 1"/>')
    s = np.diag([1.0, 2.0, 3.0, 1.0])
    rz = np.array([[0.0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])  # +90° about z
    t = np.eye(4)
    t[:3, 3] = [1, 2, 3]
    rx = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])  # the written matrix
    np.testing.assert_allclose(m, rx @ t @ rz @ s, atol=1e-12)
    m = _matrix_of(tmp_path, '<translate value="1 0 0"/><scale value="2"/>')  # translate first, then scale
    np.testing.assert_allclose(m[:3, 3], [2, 0, 0])


def test_lookat_transform(tmp_path):
    m = _matrix_of(tmp_path, '<lookat origin="0 0 0" target="1 0 0" up="0 1 0"/>')
    # Mitsuba: columns left = up × dir, up, dir, origin; looking along +x with up +y, left = -z.
    np.testing.assert_allclose(m[:3, :3], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-12)
    m = _matrix_of(tmp_path, '<lookat origin="1 2 3" target="1 2 9" up="0 1 0"/>')
    np.testing.assert_allclose(m, [[1, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]], atol=1e-12)


def test_sensor_matrix_equals_its_lookat(tmp_path):
    look = write(tmp_path, "", "a.xml")
    m = compile_scene(look).camera
    # the same camera as a rotation + translation: eye (0, 0, 5) looking along -z is a 180° turn about y
    sensor = SENSOR.replace('<lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>',
                            '<rotate y="1" angle="180"/><translate z="5"/>')
    p = tmp_path / "b.xml"
    p.write_text(f'<scene version="3.0.0">{sensor}</scene>')
    np.testing.assert_allclose(compile_scene(p).camera, m, atol=1e-6)
    mirrored = sensor.replace('<rotate', '<scale x="-1"/><rotate')
    p.write_text(f'<scene version="3.0.0">{mirrored}</scene>')
    with pytest.raises(InputError, match=r"b\.xml:\d+: <transform name=\"to_world\">: a mirrored camera"):
        read_mitsuba(p)


@pytest.mark.parametrize("axis", ["x", "y", "smaller", "larger", "diagonal", None])
def test_fov_axis(tmp_path, axis):
    extra = f'<string name="fov_axis" value="{axis}"/>' if axis else ""
    p = tmp_path / "s.xml"
    p.write_text(f'<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="50"/>{extra}'
                 '<film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/></film>'
                 '</sensor></scene>')
    cam = compile_scene(p).camera.astype(np.float64)
    half_w, half_h = np.linalg.norm(cam[1, :3]), np.linalg.norm(cam[2, :3])  # tan of the half angles
    extent = {"x": half_w, None: half_w, "larger": half_w, "y": half_h, "smaller": half_h,
              "diagonal": math.hypot(half_w, half_h)}[axis]
    assert extent == pytest.approx(math.tan(math.radians(25)), rel=1e-6)
    assert half_w / half_h == pytest.approx(2.0, rel=1e-6)



def test_properties_mitsuba_reads_and_a_pinhole_ignores(tmp_path):
    """focus_distance and the shutter of a perspective sensor, and hdrfilm's sample_border, are read (the
    Cornell box of Mitsuba's own tests sets them) and leave the camera as it is."""
    plain = write(tmp_path, "", name="plain.xml")
    extra = SENSOR.replace('<float name="fov" value="45"/>',
                           '<float name="fov" value="45"/><float name="focus_distance" value="1000"/>'
                           '<float name="shutter_open" value="0"/><float name="shutter_close" value="1"/>')
    extra = extra.replace('<integer name="height" value="6"/>',
                          '<integer name="height" value="6"/><boolean name="sample_border" value="false"/>')
    p = tmp_path / "extra.xml"
    p.write_text(f'<scene version="3.0.0">{extra}</scene>')
    a, b = read_mitsuba(plain)["camera"], read_mitsuba(p)["camera"]
    assert {k: v for k, v in a.items() if k != "comment"} == {k: v for k, v in b.items() if k != "comment"}
    assert any("sample_border false" in c for c in b["comment"])
    bad = tmp_path / "bad.xml"
    shifted = SENSOR.replace("<film", '<float name="principal_point_offset_x" value="0.1"/><film')
    bad.write_text(f'<scene version="3.0.0">{shifted}</scene>')
    with pytest.raises(InputError, match="principal_point_offset_x"):
        read_mitsuba(bad)

def test_mitsuba_defaults(tmp_path):
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="30"/></sensor>'
                 '<bsdf type="dielectric" id="glass"/>'
                 '<shape type="cube"/><shape type="sphere"><emitter type="area"/></shape></scene>')
    d = read_mitsuba(p)
    assert (d["camera"]["width"], d["camera"]["height"], d["integrator"]["spp"]) == (768, 576, 4)
    assert (d["integrator"]["max_depth"], d["integrator"]["rr_depth"]) == (-1, 5)
    assert d["materials"]["glass"]["int_ior"] == 1.5046 and d["materials"]["glass"]["ext_ior"] == 1.000277
    cube, sphere = d["shapes"]
    assert d["materials"][cube["material"]]["reflectance"] == 0.5
    assert d["materials"][sphere["material"]]["reflectance"] == 0.0 and sphere["emitter"]["radiance"] == 1.0
    # default fov_axis "x" on 768 x 576: the smaller axis is y
    assert d["camera"]["fov"] == pytest.approx(math.degrees(2 * math.atan(math.tan(math.radians(15)) * 576 / 768)))


@pytest.mark.parametrize("ior,value", [("water", 1.333), ("fused-quartz", 1.458), ("Diamond", 2.419),
                                       ("acrylic glass", 1.49), ("polypropylene", 1.49), ("vacuum", 1.0)])
def test_named_iors(tmp_path, ior, value):
    p = write(tmp_path, f'<bsdf type="dielectric" id="g"><string name="int_ior" value="{ior}"/></bsdf>')
    assert read_mitsuba(p)["materials"]["g"]["int_ior"] == value


def test_unknown_ior_names_the_closest(tmp_path):
    p = write(tmp_path, '<bsdf type="dielectric" id="g"><string name="int_ior" value="watr"/></bsdf>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: .*unknown index of refraction 'watr'.*water"):
        read_mitsuba(p)


def test_integrators_and_samplers(tmp_path):
    p = write(tmp_path, '<integrator type="direct"/>')
    assert read_mitsuba(p)["integrator"]["max_depth"] == 2
    for sampler in ("independent", "stratified", "multijitter", "ldsampler"):
        s = SENSOR.replace("</sensor>", f'<sampler type="{sampler}"><integer name="sample_count" value="9"/>'
                                        '</sampler></sensor>')
        p.write_text(f'<scene version="3.0.0">{s}</scene>')
        integ = read_mitsuba(p)["integrator"]
        assert integ["spp"] == 9
        # the samplers that stratify map to mcocl's stratified sampler
        assert integ.get("sampler", "independent") == ("independent" if sampler == "independent" else "sobol")
    p.write_text(f'<scene version="3.0.0"><integrator type="ptracer"/>{s}</scene>')  # ldsampler, light tracing
    assert "sampler" not in read_mitsuba(p)["integrator"]


def test_a_scene_s_stratified_sampler_is_a_preference_that_lt_declines(tmp_path):
    """A multijitter scene renders with sobol, also under --integrator bdpt (its Sobol' back end:
    kernels/render/bdpt.cl); --integrator lt on it draws independent samples and says so, while asking
    for sobol with lt outright stays an error."""
    s = SENSOR.replace("</sensor>", '<sampler type="multijitter"><integer name="sample_count" value="8"/>'
                                    '</sampler></sensor>')
    body = ('<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter>'
            '<transform name="to_world"><translate z="-2"/></transform></shape>')
    p = tmp_path / "mj.xml"
    p.write_text(f'<scene version="3.0.0">{s}{body}</scene>')
    r = mcocl.render(p, spp=8)
    assert any(n.startswith("sobol:") for n in r.notes)
    r = mcocl.render(p, spp=8, integrator="bdpt")
    assert r.sampler == "sobol" and any(n.startswith("sobol:") for n in r.notes)
    r = mcocl.render(p, spp=8, integrator="lt")
    assert r.sampler == "independent" and any("draws independent samples" in n for n in r.notes)
    with pytest.raises(InputError, match="sobol"):
        mcocl.render(p, spp=8, integrator="lt", sampler="sobol")


def test_mitsuba_06_names_are_upgraded(tmp_path):
    body = ('<bsdf type="dielectric" id="g"><float name="intIOR" value="1.7"/><string name="extIOR" value="water"/>'
            '</bsdf><bsdf type="diffuse" id="d"><rgb name="diffuseReflectance" value="0.2"/></bsdf>'
            '<integrator type="path"><integer name="maxDepth" value="4"/></integrator>')
    d = read_mitsuba(write(tmp_path, body, version="0.6.0"))
    assert d["materials"]["g"]["int_ior"] == 1.7 and d["materials"]["g"]["ext_ior"] == 1.333
    assert d["materials"]["d"]["reflectance"] == 0.2 and d["integrator"]["max_depth"] == 4
    p = write(tmp_path, body, version="3.0.0")
    with pytest.raises(InputError, match=r"property 'intIOR' of 'dielectric' is not supported \(nearest supported: "
                                         r"int_ior"):
        read_mitsuba(p)


# --- parameters ---------------------------------------------------------------------------------------------


def test_defaults_substitution_and_overrides(tmp_path):
    body = ('<default name="res" value="10"/><default name="r" value="0.5"/>'
            '<bsdf type="diffuse" id="m"><rgb name="reflectance" value="$r, $r, 0.1"/></bsdf>')
    sensor = SENSOR.replace('"width" value="8"', '"width" value="$res"')
    p = tmp_path / "s.xml"
    p.write_text(f'<scene version="3.0.0">{body}{sensor}</scene>')
    d = read_mitsuba(p)
    assert d["camera"]["width"] == 10 and d["materials"]["m"]["reflectance"] == [0.5, 0.5, 0.1]
    d = read_mitsuba(p, params={"res": 16, "r": 0.25})
    assert d["camera"]["width"] == 16 and d["materials"]["m"]["reflectance"] == [0.25, 0.25, 0.1]
    with pytest.raises(InputError, match=r"parameter\(s\) nope are not used"):
        read_mitsuba(p, params={"nope": 1})
    with pytest.warns(SceneSubstitutionWarning):
        read_mitsuba(p, params={"nope": 1}, lenient=True)
    p.write_text(f'<scene version="3.0.0">{SENSOR}\n<bsdf type="diffuse"><rgb name="reflectance" value="$x"/></bsdf>'
                 '</scene>')
    with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, '$x')}: <rgb name=\"reflectance\">: undefined parameter \$x"):
        read_mitsuba(p)


def test_cli_defines_and_convert(tmp_path, capsys):
    out = tmp_path / "c.json"
    assert main(["convert", str(SCENES / "xml" / "cornell.xml"), "-D", "resx=12", "-D", "spp=3", "-o", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["camera"]["width"] == 12 and data["integrator"]["spp"] == 3 and "comment" in data["integrator"]
    assert np.array_equal(compile_scene(out).tri_vertices, compile_scene(SCENES / "cornell.json").tri_vertices)
    with pytest.raises(SystemExit):  # argparse: "-D resx" is not name=value
        main(["convert", str(SCENES / "xml" / "cornell.xml"), "-D", "resx"])
    exr = tmp_path / "f.exr"
    rc = main(["render", str(SCENES / "xml" / "furnace.xml"), "-D", "resx=4", "-D", "resy=3", "--spp", "1",
               "--quiet", "--out", str(exr), "--json"])
    assert rc == 0 and exr.exists()
    assert '"width": 4' in capsys.readouterr().out


# --- includes and references --------------------------------------------------------------------------------


def test_include_and_ref(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "mats.xml").write_text('<scene version="3.0.0"><bsdf type="diffuse" id="grey">'
                                               '<rgb name="reflectance" value="0.3"/></bsdf></scene>')
    p = write(tmp_path, '<include filename="sub/mats.xml"/><shape type="cube"><ref id="grey"/></shape>')
    d = read_mitsuba(p)
    assert d["shapes"][0]["material"] == "grey" and d["materials"]["grey"]["reflectance"] == 0.3
    p = write(tmp_path, '<shape type="cube">\n<ref id="gray"/></shape>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: <ref id=\"gray\">: unresolved reference to 'gray'"):
        read_mitsuba(p)


def test_include_confinement_cycles_and_missing(tmp_path):
    (tmp_path / "outside.xml").write_text('<scene version="3.0.0"/>')
    (tmp_path / "scene").mkdir()
    p = write(tmp_path / "scene", '\n<include filename="../outside.xml"/>')
    with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, 'outside')}: <include>: .*outside the scene's folder"):
        read_mitsuba(p)
    (tmp_path / "scene" / "a.xml").write_text('<scene version="3.0.0">\n<include filename="b.xml"/></scene>')
    (tmp_path / "scene" / "b.xml").write_text('<scene version="3.0.0">\n\n<include filename="a.xml"/></scene>')
    p = write(tmp_path / "scene", '<include filename="a.xml"/>')
    with pytest.raises(InputError, match=r"b\.xml:3: <include>: include cycle: s\.xml -> a\.xml -> b\.xml -> a\.xml"):
        read_mitsuba(p)
    p = write(tmp_path / "scene", '<include filename="nope.xml"/>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: <include>: included file 'nope\.xml' not found"):
        read_mitsuba(p)


def test_obj_meshes(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    p = shape_with(tmp_path, '<string name="filename" value="m/tri.obj"/><boolean name="face_normals" value="true"/>'
                             '<boolean name="flip_normals" value="true"/>', "obj")
    sh = load_scene(p).shapes[0]
    assert sh.kind == "mesh" and sh.faces.tolist() == [[0, 1, 2]] and sh.flip_normals
    (tmp_path / "out").mkdir()
    assert main(["convert", str(p), "-o", str(tmp_path / "out" / "s.json")]) == 0  # OBJ path rewritten for out/
    assert json.loads((tmp_path / "out" / "s.json").read_text())["shapes"][0]["obj"] == "../m/tri.obj"
    with pytest.raises(InputError, match="outside the scene's folder"):  # meshes stay confined (issue 10) ...
        load_scene(tmp_path / "out" / "s.json")
    converted = load_scene(tmp_path / "out" / "s.json", mesh_folder=tmp_path / "m")  # ... unless a folder is allowed
    np.testing.assert_array_equal(converted.shapes[0].vertices, sh.vertices)
    for name, msg in [("m/none.obj", "mesh file 'm/none.obj' not found"), ("../x.obj", "outside the scene's folder")]:
        p = shape_with(tmp_path, f'\n<string name="filename" value="{name}"/>', "obj")
        with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, name)}: <string name=\"filename\">: .*{msg}"):
            read_mitsuba(p)


# --- errors and lenient substitutes -------------------------------------------------------------------------


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(InputError, match=r"nope\.xml: cannot read scene file"):
        load_scene(tmp_path / "nope.xml")
    p = tmp_path / "bad.xml"
    p.write_text('<scene version="3.0.0">\n  <shape type="cube">\n</scene>\n')
    with pytest.raises(InputError, match=r"bad\.xml:3:\d+: not well-formed XML: mismatched tag"):
        load_scene(p)
    p.write_text('<scene>\n</scene>')
    with pytest.raises(InputError, match=r"bad\.xml:1: <scene>: missing the version attribute"):
        load_scene(p)


def test_doctype_entity_bomb_is_refused(tmp_path):
    p = tmp_path / "bomb.xml"
    lol = "".join(f'<!ENTITY l{i} "{f"&l{i - 1};" * 10}">\n' for i in range(1, 10))
    p.write_text(f'<?xml version="1.0"?>\n<!DOCTYPE scene [\n<!ENTITY l0 "lol">\n{lol}]>\n'
                 '<scene version="3.0.0"><string name="x" value="&l9;"/></scene>')
    with pytest.raises(InputError, match=r"bomb\.xml:2: DOCTYPE and ENTITY declarations are refused"):
        load_scene(p)


def test_unknown_plugin_names_line_element_and_nearest(tmp_path):
    p = write(tmp_path, '\n<bsdf type="difuse" id="m"/>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: <bsdf type=\"difuse\" id=\"m\">: the BSDF plugin 'difuse' "
                                         r"is not supported \(nearest supported: diffuse\)"):
        read_mitsuba(p)
    p = write(tmp_path, '\n<shap type="cube"/>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: <shap type=\"cube\">: unknown or misplaced element.*"
                                         r"nearest: shape"):
        read_mitsuba(p)


def test_lenient_substitutes_with_a_warning(tmp_path):
    body = ('<bsdf type="roughplastic" id="p"><rgb name="diffuse_reflectance" value="0.2, 0.3, 0.4"/>'
            '<float name="alpha" value="0.2"/><boolean name="nonlinear" value="true"/></bsdf>'
            '<bsdf type="conductor" id="gold"><float name="sheen" value="1"/></bsdf>'
            '<bsdf type="mask" id="t"><bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></bsdf>'
            '<shape type="heightfield"/><emitter type="sunsky"/>')  # serialized and envmap are supported now
    p = write(tmp_path, body)
    with pytest.raises(InputError, match=r"the nonlinear plastic model is not supported \(nearest supported: "
                                         r"nonlinear=false\)"):
        read_mitsuba(p)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = read_mitsuba(p, lenient=True)
    msgs = [str(w.message) for w in caught if w.category is SceneSubstitutionWarning]
    assert len(msgs) == 5 and all(re.match(r".*s\.xml:\d+: <", m) for m in msgs)
    m = d["materials"]
    assert m["p"] == {"type": "roughplastic", "diffuse_reflectance": [0.2, 0.3, 0.4], "int_ior": 1.49,
                      "ext_ior": 1.000277, "alpha": 0.2, "distribution": "beckmann", "comment": m["p"]["comment"]}
    assert m["gold"]["type"] == "conductor" and m["t"]["reflectance"] == 0.7
    assert d["shapes"] == [] and "environment" not in d
    parse_scene(d, p)  # the substituted scene is valid
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the disk is supported now (tessellated): no substitute, no warning
        sh = load_scene(write(tmp_path, '<shape type="disk"/>')).shapes[0]
    assert sh.kind == "disk" and len(sh.faces) == 128
    np.testing.assert_allclose(np.linalg.norm(sh.vertices[1:], axis=1), 1.0)


def test_conductors(tmp_path):
    p = write(tmp_path, '<bsdf type="conductor" id="c"><string name="material" value="none"/>'
                        '<rgb name="specular_reflectance" value="0.9"/></bsdf>'
                        '<bsdf type="roughconductor" id="r"><string name="material" value="none"/>'
                        '<string name="distribution" value="ggx"/><float name="alpha" value="0.3"/></bsdf>')
    m = read_mitsuba(p)["materials"]
    assert m["c"] == {"type": "conductor", "specular_reflectance": 0.9}
    assert m["r"] == {"type": "roughconductor", "specular_reflectance": 1.0, "alpha": 0.3}
    p = write(tmp_path, '<bsdf type="conductor" id="c">\n<string name="material" value="Au"/></bsdf>'
                        '<bsdf type="conductor" id="d"/>'
                        '<bsdf type="roughconductor" id="e"><rgb name="eta" value="0.2, 0.4, 1.4"/>'
                        '<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf>')
    m = read_mitsuba(p)["materials"]
    assert m["c"]["material"] == "Au" and "material" not in m["d"]  # Mitsuba 3's default: "none", a mirror
    assert m["e"]["eta"] == [0.2, 0.4, 1.4] and (m["e"]["alpha_u"], m["e"]["alpha_v"]) == (0.1, 0.3)
    p = write(tmp_path, '<bsdf type="conductor" id="c">\n<string name="material" value="Gold"/></bsdf>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: <string name=\"material\">: unknown conductor material 'Gold'"):
        read_mitsuba(p)
    p = write(tmp_path, '<bsdf type="conductor" id="c">\n<string name="material" value="Au"/>'
                        '<float name="k" value="2"/></bsdf>')
    with pytest.raises(InputError, match=r"either material or eta/k"):
        read_mitsuba(p)
    p = write(tmp_path, '<bsdf type="roughconductor" id="c"><string name="material" value="none"/></bsdf>')
    c = read_mitsuba(p)["materials"]["c"]  # Mitsuba's default distribution
    assert c["distribution"] == "beckmann" and c["alpha"] == 0.1
    p = write(tmp_path, '<bsdf type="roughconductor" id="c"><string name="material" value="none"/>'
                        '<string name="distribution" value="phong"/></bsdf>')
    with pytest.raises(InputError, match=r"microfacet distribution 'phong'.*distribution=\"ggx\" or \"beckmann\""):
        read_mitsuba(p)


def test_validation_errors_point_at_the_xml_element(tmp_path):
    p = write(tmp_path, '<bsdf type="roughconductor" id="r">\n<string name="material" value="none"/>'
                        '<string name="distribution" value="ggx"/><float name="alpha" value="2"/></bsdf>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: <bsdf type=\"roughconductor\" id=\"r\">: materials\.r\.alpha: "
                                         r"must be <= 1"):
        load_scene(p)
    p = shape_with(tmp_path, '<transform name="to_world"><scale x="1" y="2" z="1"/></transform>', "sphere")
    line = line_of(p, 'y="2"')
    with pytest.raises(InputError, match=rf"s\.xml:{line}: .*a sphere's to_world may only"):
        load_scene(p)


def test_twosided_and_plastic(tmp_path):
    body = ('<bsdf type="twosided" id="t"><bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></bsdf>'
            '<bsdf type="roughconductor" id="r"><string name="material" value="none"/>'
            '<string name="distribution" value="ggx"/></bsdf>'
            '<bsdf type="twosided" id="tr"><ref id="r"/></bsdf>'
            '<bsdf type="twosided" id="tp"><bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/>'
            '<string name="int_ior" value="water"/></bsdf></bsdf>'
            '<bsdf type="twosided" id="tg"><bsdf type="dielectric"/></bsdf>'
            '<bsdf type="plastic" id="p"/>')
    m = read_mitsuba(write(tmp_path, body))["materials"]
    assert m["t"] == {"type": "diffuse", "reflectance": 0.7, "twosided": True}
    assert m["tr"]["type"] == "roughconductor" and m["tr"]["twosided"] is True and "twosided" not in m["r"]
    assert m["tp"]["twosided"] is True and m["tp"]["int_ior"] == 1.333 and m["tp"]["diffuse_reflectance"] == [0.1, 0.2, 0.3]
    assert m["tg"]["type"] == "dielectric" and "twosided" not in m["tg"]
    assert {k: m["p"][k] for k in ("type", "diffuse_reflectance", "int_ior", "ext_ior")} == \
        {"type": "plastic", "diffuse_reflectance": 0.5, "int_ior": 1.49, "ext_ior": 1.000277}
    for bad, msg in (('<bsdf type="plastic"><boolean name="nonlinear" value="true"/></bsdf>', "nonlinear plastic"),
                     ('<bsdf type="plastic"><rgb name="specular_reflectance" value="0.5"/></bsdf>', "specular_reflectance"),
                     ('<bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>', "different front and back"),
                     ('<bsdf type="twosided"/>', "needs a nested")):
        with pytest.raises(InputError, match=msg):
            read_mitsuba(write(tmp_path, bad.replace('<bsdf type', '<bsdf id="x" type', 1)))


# --- real scenes' file layout and references (Mitsuba's own data repository, the Blender add-on's tests) -------


def _tri(path: Path, size: float) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"v 0 0 0\nv {size} 0 0\nv 0 {size} 0\nf 1 2 3\n")


def _mesh_size(p: Path, **kw) -> float:
    return float(load_scene(p, **kw).shapes[0].vertices.max())


def test_path_elements_and_mitsubas_file_lookup(tmp_path):
    """Mitsuba 3.9.1 (scalar_rgb) finds a relative filename in the folder of the <path> written last, then in
    the main file's folder, also for a file named in an included file (its cbox.xml includes fragments/
    shapes.xml whose meshes lie beside cbox.xml): measured with mi.load_file, the bounding boxes were
    sizes 2 and 1 for these two layouts."""
    scene = tmp_path / "scene"
    for folder, size in (("meshes", 1), ("lib/meshes", 2), ("lib2/meshes", 3), ("frag/meshes", 4)):
        _tri(scene / folder / "tri.obj", size)
    obj = '<shape type="obj"><string name="filename" value="meshes/tri.obj"/></shape>'
    a = write(scene, f'<path value="lib2"/><path value="lib"/>{obj}', name="a.xml")
    assert _mesh_size(a) == 2.0
    assert read_mitsuba(a)["shapes"][0]["obj"] == "lib/meshes/tri.obj"
    (scene / "frag" / "shapes.xml").write_text(f'<scene version="3.0.0">{obj}</scene>')
    assert _mesh_size(write(scene, '<include filename="frag/shapes.xml"/>', name="b.xml")) == 1.0
    (scene / "meshes" / "tri.obj").unlink()  # mcocl's earlier rule, kept as the last resort: beside the file itself
    assert _mesh_size(write(scene, '<include filename="frag/shapes.xml"/>', name="b.xml")) == 4.0
    p = write(scene, '\n<path value="nowhere"/>', name="c.xml")
    with pytest.raises(InputError, match=rf"c\.xml:{line_of(p, 'nowhere')}: <path>: folder 'nowhere' not found"):
        read_mitsuba(p)


def test_path_outside_the_scene_needs_the_mesh_folder(tmp_path):
    """Mitsuba's documentation scenes write <path value="../../common"/>: the files found there are read only
    when the user allows that folder (--mesh-folder), for load, render and convert alike."""
    _tri(tmp_path / "common" / "meshes" / "tri.obj", 5)
    (tmp_path / "docs").mkdir()
    p = write(tmp_path / "docs", '<path value="../common"/>\n<shape type="obj">\n'
                                 '<string name="filename" value="meshes/tri.obj"/></shape>')
    with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, 'filename')}: <string name=\"filename\">: "
                                         r".*outside the scene's folder.*--mesh-folder"):
        load_scene(p)
    assert _mesh_size(p, mesh_folder=tmp_path / "common") == 5.0
    out = tmp_path / "docs" / "s.json"
    assert main(["convert", str(p), "-o", str(out), "--mesh-folder", str(tmp_path / "common")]) == 0
    assert json.loads(out.read_text())["shapes"][0]["obj"] == "../common/meshes/tri.obj"
    assert _mesh_size(out, mesh_folder=tmp_path / "common") == 5.0


def test_top_level_sampler_film_filter_and_area_emitter_by_reference(tmp_path):
    """Mitsuba's docs declare the sampler at the top level and <ref> it from the sensor; its cbox.xml declares
    the area emitter at the top level and <ref>s it from the light's shape; hdrfilm's pre-3.0 name of
    sample_border, high_quality_edges, is still written by the Blender add-on."""
    body = ('<sampler type="independent" id="smp"><integer name="sample_count" value="7"/></sampler>'
            '<rfilter type="tent" id="rf"><float name="radius" value="1.5"/></rfilter>'
            '<film type="hdrfilm" id="f"><integer name="width" value="5"/><integer name="height" value="3"/>'
            '<boolean name="high_quality_edges" value="false"/><ref id="rf"/></film>'
            '<sensor type="perspective"><float name="fov" value="45"/><ref id="smp"/><ref id="f"/></sensor>'
            '<emitter type="area" id="light"><rgb name="radiance" value="3"/></emitter>'
            '<shape type="rectangle"><ref id="light"/></shape>')
    d = read_mitsuba(write(tmp_path, body, sensor=False))
    cam = d["camera"]
    assert d["integrator"]["spp"] == 7 and (cam["width"], cam["height"]) == (5, 3)
    assert cam["filter"] == {"type": "tent", "radius": 1.5}
    assert any("high_quality_edges false" in c for c in cam["comment"])
    assert not any("edge pixels can differ" in c for c in cam["comment"])  # said where the file leaves it out:
    assert any("edge pixels can differ" in c for c in read_mitsuba(write(tmp_path, ""))["camera"]["comment"])
    assert len(d["shapes"]) == 1 and d["shapes"][0]["emitter"]["radiance"] == 3.0 and "environment" not in d
    p = write(tmp_path, '<shape type="disk">\n<sensor type="irradiancemeter"/></shape>', sensor=False)
    with pytest.raises(InputError, match=r"no top-level <sensor> \(the <sensor type=\"irradiancemeter\"> at "
                                         rf".*s\.xml:{line_of(p, 'irradiance')} lies inside a <shape>"):
        read_mitsuba(p)
    p = write(tmp_path, '\n<emitter type="area" id="unused"/>')
    with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, 'unused')}: .*an area emitter belongs inside a <shape>"):
        read_mitsuba(p)
    p = write(tmp_path, '<sensor type="perspective">\n<rfilter type="box"/></sensor>', sensor=False)
    with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, 'rfilter')}: <rfilter type=\"box\">: "
                                         r".*inside the sensor's <film>"):
        read_mitsuba(p)
    p = write(tmp_path, '<sensor type="perspective"><sampler type="independent"/>\n<sampler type="independent"/>'
                        '</sensor>', sensor=False)
    with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, '<sampler type') + 1}: <sampler type=\"independent\">: "
                                         r"a sensor takes one <sampler>"):
        read_mitsuba(p)


def test_flip_tex_coords_as_mitsuba(tmp_path):
    """Mitsuba 3.9.1 (scalar_rgb, mi.traverse(...)['m.vertex_texcoords']) of a triangle with vt (0.25, 0.1),
    (0.5, 0.2), (0.75, 0.3): v flipped to 0.9, 0.8, 0.7 by default or with flip_tex_coords true, kept with
    false. A PLY's UVs are kept unless it is true (Mitsuba's default false). The converted JSON carries the key
    only when it differs from the default."""
    (tmp_path / "t.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.1\nvt 0.5 0.2\nvt 0.75 0.3\nf 1/1 2/2 3/3\n")
    (tmp_path / "t.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nproperty float u\nproperty float v\nelement face 1\n"
                                    "property list uchar int vertex_indices\nend_header\n"
                                    "0 0 0 0.25 0.1\n1 0 0 0.5 0.2\n0 1 0 0.75 0.3\n3 0 1 2\n")
    flipped, kept = [0.9, 0.8, 0.7], [0.1, 0.2, 0.3]
    for kind, flag, v in (("obj", None, flipped), ("obj", "true", flipped), ("obj", "false", kept),
                          ("ply", None, kept), ("ply", "true", flipped), ("ply", "false", kept)):
        prop = "" if flag is None else f'<boolean name="flip_tex_coords" value="{flag}"/>'
        p = shape_with(tmp_path, f'<string name="filename" value="t.{kind}"/>{prop}', kind)
        np.testing.assert_allclose(load_scene(p).shapes[0].uvs[:, 1], v, rtol=0, atol=1e-6)
        assert ("flip_tex_coords" in read_mitsuba(p)["shapes"][0]) == (flag is not None and (flag == "true") != (kind == "obj"))
    p = write(tmp_path, '<shape type="cube">\n<boolean name="flip_tex_coords" value="false"/></shape>')
    with pytest.raises(InputError, match=rf"s\.xml:{line_of(p, 'flip_tex')}: .*property 'flip_tex_coords' of 'cube'"):
        read_mitsuba(p)


def test_rotate_axis_is_not_normalised_as_in_mitsuba(tmp_path):
    """Mitsuba 3.9.1's <rotate> applies Rodrigues' formula to the axis as written: ScalarTransform4f.rotate(
    [1, 1, 0], 30) is the matrix below (not a rotation: det 1.4175). A unit axis stays mcocl's rotate op."""
    mitsuba = np.array([[1.0, 0.13397461, 0.5], [0.13397461, 1.0, -0.5], [-0.5, 0.5, 0.8660254]])
    p = shape_with(tmp_path, '<transform name="to_world"><rotate x="1" y="1" z="0" angle="30"/></transform>', "cube")
    np.testing.assert_allclose(load_scene(p).shapes[0].matrix[:3, :3], mitsuba, atol=1e-7)
    assert "matrix" in read_mitsuba(p)["shapes"][0]["transform"][0]
    p = shape_with(tmp_path, '<transform name="to_world"><rotate y="1" angle="30"/></transform>', "cube")
    assert read_mitsuba(p)["shapes"][0]["transform"] == [{"rotate": {"axis": [0.0, 1.0, 0.0], "angle": 30.0}}]


ICOSAHEDRON = Path(__file__).resolve().parent / "data" / "mitsuba" / "meshes" / "icosahedron.obj"


def test_mesh_files_without_normals_are_smoothed_as_in_mitsuba(tmp_path):
    """A mesh file without vertex normals shades with the angle-weighted average of its faces' normals
    computed after to_world, as Mitsuba 3.9.1 does (face_normals=false, its default). Measured with
    mi.traverse(scene)['m.vertex_normals'] for the icosahedron scaled by (2, 0.5, 1): the vertex at
    (-1.051462, 0.4253255, 0) has (-0.25354534, 0.9673235, 0), the one at (-1.701302, 0, 0.525731) has
    (-0.8172787, 0, 0.5762425); all twelve agree to 1.3e-7, also after a rotation and a translation."""
    from mcocl.render import transform as tf
    from mcocl.render.shading_normals import _world_normals

    (tmp_path / "ico.obj").write_bytes(ICOSAHEDRON.read_bytes())
    p = shape_with(tmp_path, '<string name="filename" value="ico.obj"/>'
                             '<transform name="to_world"><scale x="2" y="0.5" z="1"/></transform>', "obj")
    assert read_mitsuba(p)["shapes"][0]["compute_normals"] is True
    sh = load_scene(p).shapes[0]
    world, at = _world_normals(sh), tf.apply_points(sh.matrix, np.asarray(sh.vertices, np.float64))
    for position, normal in (((-1.051462, 0.4253255, 0.0), (-0.25354534, 0.9673235, 0.0)),
                             ((-1.701302, 0.0, 0.525731), (-0.8172787, 0.0, 0.5762425))):
        i = int(np.argmin(np.linalg.norm(at - position, axis=1)))
        np.testing.assert_allclose(world[i], normal, atol=2e-7)
    # unscaled, the regular icosahedron's vertex normals point away from its centre (an independent check)
    p = shape_with(tmp_path, '<string name="filename" value="ico.obj"/>', "obj")
    sh = load_scene(p).shapes[0]
    v = np.asarray(sh.vertices, np.float64)
    np.testing.assert_allclose(sh.normals, v / np.linalg.norm(v, axis=1, keepdims=True), atol=1e-6)
    # face_normals=true keeps the facets; a JSON mesh only smooths when asked (its results do not change)
    p = shape_with(tmp_path, '<string name="filename" value="ico.obj"/><boolean name="face_normals" value="true"/>',
                   "obj")
    assert load_scene(p).shapes[0].normals is None
    data = {"camera": {"origin": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 4,
                       "height": 4}, "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
            "shapes": [{"type": "mesh", "obj": "ico.obj", "material": "m"}]}
    assert parse_scene(data, tmp_path / "s.json").shapes[0].normals is None
    data["shapes"][0]["compute_normals"] = True
    np.testing.assert_allclose(parse_scene(data, tmp_path / "s.json").shapes[0].normals, sh.normals)
    data["shapes"][0] = {"type": "cube", "material": "m", "compute_normals": True}
    with pytest.raises(InputError, match="shapes"):
        parse_scene(data, tmp_path / "s.json")


def test_roughplastic_says_it_is_brighter_than_mitsubas(tmp_path):
    """mcocl's roughplastic is knowingly 1-2 % brighter than Mitsuba's (tests/data/README.md); the converted
    scene says so instead of passing it off as Mitsuba's."""
    m = read_mitsuba(write(tmp_path, '<bsdf type="roughplastic" id="r"/><bsdf type="plastic" id="p"/>'))["materials"]
    assert any("brighter than Mitsuba's" in c for c in m["r"]["comment"])
    assert not any("brighter" in c for c in m["p"].get("comment", []))
