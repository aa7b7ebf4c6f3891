"""The BSDF registry (mcocl/bsdf_registry.py) and what is derived from it.

- the committed dispatcher ``kernels/render/bsdf.cl`` and the materials table of
  ``scenes/README.md`` are what the generators write;
- ``MaterialKind`` carries the registered codes; a registration with a taken
  name or code, or a field the material record lacks, is refused;
- a new registration gets its branch in the dispatcher;
- every registered BSDF, at its scene-file defaults, passes the checks any BSDF
  must: the scene file accepts it and packs its record, the kernel's ``delta``
  and ``eta`` agree with the registration's flags, a non-delta BSDF's sample
  weight is eval / pdf at the sampled direction, a delta BSDF evaluates to
  zero, and no BSDF reflects more energy than arrives (mean weight <= 1 within
  five standard errors).  Each BSDF's own test (tests/test_render_bsdf.py) checks
  its distribution against an independent reference.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_render_bsdf import _unit, evaluate, sample

from mcocl import bsdf_registry as reg
from mcocl import layouts
from mcocl.errors import InputError
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene


def test_committed_dispatcher_is_the_generated_one():
    assert layouts.dispatcher_file().read_text() == reg.dispatcher_source(), "run `python -m mcocl.layouts`"


def test_scenes_readme_table_is_the_generated_one():
    readme = layouts.scenes_readme()
    if readme is None:
        pytest.skip("no scenes/README.md beside the kernels (an installed package)")
    text = readme.read_text()
    assert reg.markdown_table() in text, "run `python -m mcocl.layouts`"


def test_material_kind_is_the_registry():
    assert {k.name.lower(): int(k) for k in layouts.MaterialKind} == {n: s.code for n, s in reg.BSDFS.items()}
    # the codes of the first four materials are saved in scenes' records: they never move
    assert [(k.name, int(k)) for k in layouts.MaterialKind][:4] == [
        ("DIFFUSE", 0), ("CONDUCTOR", 1), ("ROUGHCONDUCTOR", 2), ("DIELECTRIC", 3)]


def test_registration_refuses_clashes():
    class SameName(reg.BsdfSpec):
        name, code, summary = "diffuse", 90, ""

    class SameCode(reg.BsdfSpec):
        name, code, summary = "other", 0, ""

    class BadField(reg.BsdfSpec):
        name, code, summary = "other", 91, ""
        params = (reg.Param("sheen", "number", "sheen", ""),)

    for cls, msg in ((SameName, "already registered"), (SameCode, "already registered"), (BadField, "no material_record")):
        with pytest.raises(ValueError, match=msg):
            reg.register_bsdf(cls)
    assert "other" not in reg.BSDFS


def test_new_registration_gets_a_dispatcher_branch(monkeypatch):
    monkeypatch.setattr(reg, "BSDFS", dict(reg.BSDFS))

    class Sheen(reg.BsdfSpec):
        name, code, summary = "sheen", 9, "a test"
        params = (reg.Param("tint", "rgb", "rgb", "", default=0.5),)

    reg.register_bsdf(Sheen)
    src = reg.dispatcher_source()
    assert '#include "render/bsdf_sheen.cl"' in src
    assert "vec3v fk = sheen_bsdf_eval(m, wi, wo, &pk);" in src
    assert "sheen_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);" in src
    assert "(m->kind == MAT_SHEEN)" in src.split("bsdf_is_smooth")[1].split("}")[0]
    assert "`sheen` | `tint` (RGB, default 0.5) | a test |" in reg.markdown_table()


def _record(spec: reg.BsdfSpec) -> np.ndarray:
    """The material record of ``spec`` at its defaults (0.8 grey for a required colour), via the scene file."""
    mat = {"type": spec.name}
    for p in spec.params:
        if p.default is None:
            mat[p.key] = 0.8 if p.kind == "rgb" else (p.lo or 0.0) + 0.5
    scene = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
             "materials": {"m": mat}, "shapes": [{"type": "rectangle", "material": "m"}]}
    return compile_scene(parse_scene(scene, "registry.json")).materials


def test_dielectric_check_runs_on_the_scene_file():
    scene = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
             "materials": {"g": {"type": "dielectric", "int_ior": 1.2, "ext_ior": 1.2}}}
    with pytest.raises(InputError, match=r"materials\.g\.int_ior: int_ior equals ext_ior"):
        parse_scene(scene, "g.json")


@pytest.mark.parametrize("name", list(reg.BSDFS))
def test_every_registered_bsdf_keeps_the_contract(name: str) -> None:
    spec = reg.BSDFS[name]
    mat = _record(spec)
    assert mat[0, 0] == spec.code
    n = 1 << 14
    for theta in (30.0, 75.0):
        wi = _unit(theta)
        s = sample(mat, wi, n=n, seed=3)
        valid = s["pdf"] > 0
        assert valid.any()
        assert np.all(np.isfinite(s["weight"])) and np.all(s["weight"] >= 0)
        assert np.all(s["weight"][~valid] == 0)
        if spec.mixed:  # a delta lobe beside smooth ones: both are sampled, eval covers the smooth ones
            smooth = valid & (s["delta"] == 0)
            assert smooth.any() and (valid & (s["delta"] == 1)).any()
        else:
            assert np.all(s["delta"][valid] == float(spec.delta))
            smooth = valid
        if not spec.transmissive:
            assert np.all(s["eta"] == 1.0)
            assert np.all(s["wo"][valid, 2] > 0), "a reflection-only BSDF sampled below the surface"
        f, pdf = evaluate(mat, wi, s["wo"][smooth][:2048])
        if spec.delta:
            assert np.all(f == 0) and np.all(pdf == 0)
        else:
            np.testing.assert_allclose(pdf, s["pdf"][smooth][:2048], rtol=2e-3)
            np.testing.assert_allclose(f / pdf[:, None], s["weight"][smooth][:2048], rtol=2e-3)
        # energy: E[weight] is the albedo for direction wi, at most 1 per channel
        w = s["weight"].astype(np.float64)
        mean, se = w.mean(axis=0), w.std(axis=0, ddof=1) / np.sqrt(n)
        assert np.all(mean <= 1.0 + 5.0 * se + 1e-6), (theta, mean, se)


def test_mitsuba_import_reads_a_registered_bsdf_by_its_keys(monkeypatch, tmp_path):
    from mcocl.render.mitsuba import read_mitsuba

    class Sheen(reg.BsdfSpec):
        name, code, summary = "sheen", 9, "a test"
        params = (reg.Param("tint", "rgb", "rgb", "", default=0.5), reg.Param("alpha", "number", "alpha", ""))

    monkeypatch.setitem(reg.BSDFS, "sheen", Sheen())  # what @register_bsdf does, undone after the test
    head = ('<?xml version="1.0"?>\n<scene version="3.0.0">\n<sensor type="perspective">'
            '<transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>'
            '</sensor>\n')
    p = tmp_path / "s.xml"
    p.write_text(head + '<bsdf type="sheen" id="s"><float name="alpha" value="0.2"/></bsdf>\n</scene>\n')
    assert read_mitsuba(p)["materials"]["s"] == {"type": "sheen", "tint": 0.5, "alpha": 0.2}
    p.write_text(head + '<bsdf type="sheen" id="s"><rgb name="tint" value="0.1, 0.2, 0.3"/></bsdf>\n</scene>\n')
    with pytest.raises(InputError, match="needs the property 'alpha'"):
        read_mitsuba(p)
    p.write_text(head + '<bsdf type="sheen" id="s"><float name="alpha" value="0.2"/>'
                 '<float name="sigma" value="1"/></bsdf>\n</scene>\n')
    with pytest.raises(InputError, match=r"property 'sigma' of 'sheen'.*supported: tint, alpha"):
        read_mitsuba(p)
