"""The renderer: scene loading and geometry (this half), integrators and film (the other half).

Calling the package renders: ``mcocl.render("scenes/cornell.json", spp=256)`` is
:func:`render` (integrator half: :mod:`.api`, :mod:`.job`, :mod:`.film` and the
kernels camera, bsdf*, lights, integrator under ``kernels/render``).

Scene half: :func:`load_scene` (JSON, validated), :func:`compile_scene`
(flat arrays + BVH, the kernels' contract :class:`CompiledScene`),
:func:`cast_rays` (traversal from Python), EXR/PNG I/O in :mod:`.image_io`.
"""

import sys
import types

from .api import NonFiniteSampleWarning, RenderResult, render
from .compiled import CompiledScene, compile_scene, load_compiled
from .raycast import RayHits, cast_rays
from .scene import Scene
from .scene_file import load_scene

__all__ = [
    "CompiledScene",
    "NonFiniteSampleWarning",
    "RenderResult",
    "RayHits",
    "Scene",
    "cast_rays",
    "compile_scene",
    "load_compiled",
    "load_scene",
    "render",
]


class _RenderPackage(types.ModuleType):
    """``mcocl.render`` is this package and also the render function: ``mcocl.render(scene, spp=...)``."""

    def __call__(self, *args, **kwargs) -> RenderResult:
        return render(*args, **kwargs)


sys.modules[__name__].__class__ = _RenderPackage
