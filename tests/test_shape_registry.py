"""The shape registry (mcocl/render/shape_registry.py): scene-file shape types declared once.

- the shapes table of scenes/README.md is the generated one, and the scene
  file accepts exactly the registered types;
- a shape type registered from outside (here a one-triangle shape with its
  own key) is validated, compiled to world-space triangles and reported by its
  key path, with no other change: the recipe of docs/architecture.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from mcocl import layouts
from mcocl.errors import InputError
from mcocl.render import scene as scene_mod
from mcocl.render import shape_registry as reg
from mcocl.render.compiled import compile_scene


def test_scenes_readme_shapes_table_is_the_generated_one():
    readme = layouts.scenes_readme()
    if readme is None:
        pytest.skip("no scenes/README.md beside the kernels (an installed package)")
    assert reg.shapes_table() in readme.read_text(), "run `python -m mcocl.layouts`"


def test_scene_file_types_are_the_registry():
    assert scene_mod.SHAPE_KINDS == ("rectangle", "cube", "disk", "cylinder", "sphere", "mesh") == tuple(reg.SHAPES)
    with pytest.raises(ValueError, match="already registered"):
        reg.register_shape(type("Again", (reg.ShapeSpec,), {"name": "cube"}))


class _Triangle(reg.ShapeSpec):
    """One triangle (0,0,0), (1,0,0), (0,height,0): front side +z."""

    name = "triangle"
    keys = ("height",)
    geometry = "a right triangle"

    def build(self, c, o, key, shape, base):
        h = c.number(o.get("height", 1.0), f"{key}.height", 0.0, lo_open=True)
        shape.vertices = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, h, 0.0]])
        shape.faces = np.array([[0, 1, 2]])


def _scene(shape: dict) -> dict:
    return {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
            "materials": {"m": {"type": "diffuse", "reflectance": 0.5}}, "shapes": [shape]}


def test_a_registered_triangle_shape_compiles(monkeypatch):
    # what @register_shape does, undone after the test (SHAPE_KINDS is read once at import)
    monkeypatch.setitem(reg.SHAPES, "triangle", _Triangle())
    monkeypatch.setattr(scene_mod, "SHAPE_KINDS", tuple(reg.SHAPES))
    shape = {"type": "triangle", "material": "m", "height": 2.0, "transform": [{"translate": [0, 0, 1]}]}
    cs = compile_scene(scene_mod.parse_scene(_scene(shape), "t.json"))
    np.testing.assert_array_equal(cs.tri_vertices[0, :, :3], [[0, 0, 1], [1, 0, 1], [0, 2, 1]])
    assert cs.num_spheres == 0 and "triangle" in reg.shapes_table()
    with pytest.raises(InputError, match=r"t\.json: shapes\[0\]\.height: must be > 0"):
        scene_mod.parse_scene(_scene({**shape, "height": 0}), "t.json")
    with pytest.raises(InputError, match=r"shapes\[0\]\.radius: unknown key"):
        scene_mod.parse_scene(_scene({**shape, "radius": 1}), "t.json")
