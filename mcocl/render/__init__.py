"""The renderer: scene loading and geometry (this half), integrators and film (the other half).

Scene half: :func:`load_scene` (JSON, validated), :func:`compile_scene`
(flat arrays + BVH, the kernels' contract :class:`CompiledScene`),
:func:`cast_rays` (traversal from Python), EXR/PNG I/O in :mod:`.image_io`.
"""

from .compiled import CompiledScene, compile_scene, load_compiled
from .raycast import RayHits, cast_rays
from .scene import Scene, load_scene

__all__ = [
    "CompiledScene",
    "RayHits",
    "Scene",
    "cast_rays",
    "compile_scene",
    "load_compiled",
    "load_scene",
]
