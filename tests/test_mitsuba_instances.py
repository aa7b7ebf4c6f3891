"""Mitsuba ``shapegroup``/``instance`` (mcocl/render/mitsuba/instance.py): flattened copies of the group's shapes."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mcocl
from mcocl.errors import InputError
from mcocl.render.compiled import CompiledScene, compile_scene
from mcocl.render.mitsuba import read_mitsuba

HEAD = """<?xml version="1.0"?>
<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, 1, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.7, 0.2, 0.1"/></bsdf>
    <bsdf type="roughconductor" id="metal"><float name="alpha" value="0.3"/></bsdf>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="90"/><translate y="3"/></transform>
        <emitter type="area"><rgb name="radiance" value="4, 4, 3"/></emitter>
    </shape>
    <shape type="rectangle"><transform name="to_world"><scale value="5"/><rotate x="1" angle="-90"/>
        <translate y="-1"/></transform></shape>
"""
CUBE_OPS = '<scale value="0.4"/><rotate y="1" angle="30"/>'
SPHERE_OPS = '<translate x="0.6" y="0.3"/>'
INSTANCE_OPS = ['<rotate z="1" angle="10"/><translate x="-1.2"/>', '<scale value="0.7"/><translate x="1.3" z="0.5"/>']


def _scene(tmp_path: Path, body: str, name: str) -> Path:
    p = tmp_path / name
    p.write_text(HEAD + body + "\n</scene>\n")
    return p


def _instanced(tmp_path: Path) -> Path:
    group = f"""<shape type="shapegroup" id="g">
        <shape type="cube"><ref id="red"/><transform name="to_world">{CUBE_OPS}</transform></shape>
        <shape type="sphere"><ref id="metal"/><float name="radius" value="0.3"/>
            <transform name="to_world">{SPHERE_OPS}</transform></shape>
    </shape>"""
    inst = "".join(f'<shape type="instance" id="i{k}"><ref id="g"/><transform name="to_world">{ops}</transform>'
                   "</shape>" for k, ops in enumerate(INSTANCE_OPS))
    return _scene(tmp_path, group + inst, "instanced.xml")


def _written_out(tmp_path: Path) -> Path:
    body = "".join(f'<shape type="cube"><ref id="red"/><transform name="to_world">{CUBE_OPS}{ops}</transform></shape>'
                   f'<shape type="sphere"><ref id="metal"/><float name="radius" value="0.3"/>'
                   f'<transform name="to_world">{SPHERE_OPS}{ops}</transform></shape>' for ops in INSTANCE_OPS)
    return _scene(tmp_path, body, "written_out.xml")


def test_instances_equal_the_shapes_written_out(tmp_path):
    a, b = compile_scene(_instanced(tmp_path)), compile_scene(_written_out(tmp_path))
    arrays = [f.name for f in dataclasses.fields(CompiledScene) if isinstance(getattr(a, f.name), np.ndarray)]
    for k in arrays:
        x, y = getattr(a, k), getattr(b, k)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), k
    assert len(a.shape_names) == 6 and a.shape_names[2:4] == ["i0/cube", "i0/sphere"]
    ra = mcocl.render(_instanced(tmp_path), spp=2, seed=5)
    rb = mcocl.render(_written_out(tmp_path), spp=2, seed=5)
    assert np.array_equal(ra.mean, rb.mean) and np.array_equal(ra.variance, rb.variance)
    assert (ra.mean.sum(-1) > 0).mean() >= 0.4  # the floor and the shapes: not two black images


def test_group_alone_renders_nothing(tmp_path):
    d = read_mitsuba(_scene(tmp_path, '<shape type="shapegroup" id="g"><shape type="cube"/></shape>', "g.xml"))
    assert len(d["shapes"]) == 2  # the two rectangles of HEAD only


@pytest.mark.parametrize("body, message", [
    ('<shape type="instance"><ref id="nothing"/></shape>', r"unresolved reference to 'nothing'"),
    ('<shape type="instance"><ref id="red"/></shape>', r"'red' is <bsdf type=\"diffuse\">"),
    ('<shape type="instance"/>', r"an instance needs exactly one <ref"),
    ('<shape type="shapegroup" id="g"><shape type="cube"><emitter type="area"/></shape></shape>',
     r"an emitter inside a shapegroup"),
    ('<shape type="shapegroup" id="g"><shape type="shapegroup" id="h"><shape type="cube"/></shape></shape>',
     r"nested instancing: a shapegroup may not hold a shapegroup"),
    ('<shape type="shapegroup" id="g"><shape type="cube"/></shape><shape type="shapegroup" id="h">'
     '<shape type="instance"><ref id="g"/></shape></shape>', r"nested instancing: a shapegroup may not hold a instance"),
    ('<shape type="shapegroup" id="g"><shape type="sphere"/></shape><shape type="instance"><ref id="g"/>'
     '<transform name="to_world"><scale x="2"/></transform></shape>', r"makes the sphere <shape type=\"sphere\"> of "
     r"line \d+ an ellipsoid"),
])
def test_instance_errors(tmp_path, body, message):
    p = _scene(tmp_path, body, "bad.xml")
    with pytest.raises(InputError, match=r"bad\.xml:\d+: .*" + message):
        read_mitsuba(p)
