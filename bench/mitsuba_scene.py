"""mcocl's JSON scene (scenes/README.md) as a Mitsuba 3 scene dictionary, for the efficiency comparison.

Runs in the Python of Mitsuba's own virtual environment (Mitsuba is not a
dependency of mcocl), so it reads the JSON itself instead of importing mcocl.
The two formats share their conventions (scenes/README.md): local shapes
([-1, 1]² rectangle, [-1, 1]³ cube), transforms applied in list order,
one-sided BSDFs and front-side area emitters, ``fov`` on the smaller axis.
What the comparison adds: a box pixel filter, the independent sampler and the
``path`` integrator with the scene's max_depth and rr_depth.  Meshes keep face
normals (mcocl shades with the geometric normal); inline meshes are written
to OBJ files in ``mesh_dir``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np


def _rgb(v: Any) -> dict:
    """An RGB value (one number is grey) as Mitsuba's ``rgb`` texture."""
    return {"type": "rgb", "value": [float(v)] * 3 if isinstance(v, (int, float)) else [float(x) for x in v]}


def _rotation(axis: list[float], degrees: float) -> np.ndarray:
    """Right-handed rotation about ``axis`` (Rodrigues' formula)."""
    a = np.asarray(axis, dtype=np.float64)
    x, y, z = a / np.linalg.norm(a)
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    one_c = 1.0 - c
    return np.array([[c + x * x * one_c, x * y * one_c - z * s, x * z * one_c + y * s],
                     [y * x * one_c + z * s, c + y * y * one_c, y * z * one_c - x * s],
                     [z * x * one_c - y * s, z * y * one_c + x * s, c + z * z * one_c]])


def transform_matrix(ops: list[dict]) -> np.ndarray:
    """The 4x4 local-to-world matrix of a transform list, applied in list order."""
    m = np.eye(4)
    for op in ops:
        t = np.eye(4)
        if "translate" in op:
            t[:3, 3] = op["translate"]
        elif "scale" in op:
            s = op["scale"]
            t[:3, :3] = np.diag([s] * 3 if isinstance(s, (int, float)) else s)
        elif "rotate" in op:
            t[:3, :3] = _rotation(op["rotate"]["axis"], op["rotate"]["angle"])
        elif "matrix" in op:
            rows = np.asarray(op["matrix"], dtype=np.float64)
            t[: rows.shape[0], :] = rows
        else:
            raise ValueError(f"unknown transform operation {op}")
        m = t @ m
    return m


def _bsdf(mat: dict) -> dict:
    """A material as a Mitsuba BSDF (``twosided`` wraps it)."""
    kind = mat["type"]
    if kind == "diffuse":
        b = {"type": "diffuse", "reflectance": _rgb(mat["reflectance"])}
    elif kind == "conductor":
        b = {"type": "conductor", "material": "none", "specular_reflectance": _rgb(mat.get("specular_reflectance", 1.0))}
    elif kind == "roughconductor":
        b = {"type": "roughconductor", "material": "none", "alpha": float(mat.get("alpha", 0.1)),
             "distribution": mat.get("distribution", "ggx"),
             "specular_reflectance": _rgb(mat.get("specular_reflectance", 1.0))}
    elif kind == "dielectric":
        b = {"type": "dielectric", "int_ior": float(mat.get("int_ior", 1.5046)), "ext_ior": float(mat.get("ext_ior", 1.0))}
    elif kind == "plastic":
        b = {"type": "plastic", "diffuse_reflectance": _rgb(mat.get("diffuse_reflectance", 0.5)),
             "int_ior": float(mat.get("int_ior", 1.49)), "ext_ior": float(mat.get("ext_ior", 1.00028)), "nonlinear": False}
    else:
        raise ValueError(f"material type {kind!r} has no Mitsuba twin here")
    return {"type": "twosided", "bsdf": b} if mat.get("twosided") else b


def _write_obj(path: Path, vertices: list, faces: list) -> None:
    """An OBJ file of inline mesh data (``faces`` 0-based)."""
    with path.open("w") as f:
        np.savetxt(f, np.asarray(vertices, dtype=np.float64), fmt="v %.9g %.9g %.9g")
        np.savetxt(f, np.asarray(faces, dtype=np.int64) + 1, fmt="f %d %d %d")


def mitsuba_dict(scene_file: str | Path, mesh_dir: str | Path, spp: int, sampler: str = "independent") -> dict:
    """The scene as a dictionary for ``mitsuba.load_dict`` (transforms as nested 4x4 lists under ``to_world``)."""
    scene_file = Path(scene_file)
    d = json.loads(scene_file.read_text())
    mesh_dir = Path(mesh_dir)
    mesh_dir.mkdir(parents=True, exist_ok=True)
    cam = d["camera"]
    integ = d.get("integrator", {})
    out: dict[str, Any] = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": int(integ.get("max_depth", -1)), "rr_depth": int(integ.get("rr_depth", 5))},
        "sensor": {"type": "perspective", "fov": float(cam["fov"]), "fov_axis": "smaller",
                   "look_at": {"origin": cam["origin"], "target": cam["target"], "up": cam.get("up", [0, 1, 0])},
                   "sampler": {"type": sampler, "sample_count": spp},
                   "film": {"type": "hdrfilm", "width": int(cam["width"]), "height": int(cam["height"]),
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"}},
    }
    if cam.get("aperture_radius", 0.0):
        raise ValueError("thin-lens cameras are not converted")
    mats = d.get("materials", {})
    if "environment" in d:
        out["environment"] = {"type": "constant", "radiance": _rgb(d["environment"]["radiance"])}
    for k, s in enumerate(d.get("shapes", [])):
        m = transform_matrix(s.get("transform", []))
        kind = s["type"]
        if kind == "sphere":
            local = np.eye(4)
            local[:3, :3] *= float(s.get("radius", 1.0))
            local[:3, 3] = s.get("center", [0.0, 0.0, 0.0])
            shape: dict[str, Any] = {"type": "sphere"}
            m = m @ local
        elif kind in ("rectangle", "cube"):
            shape = {"type": kind}
        elif kind == "mesh" and "ply" in s:  # a PLY keeps its own vertex normals, as mcocl shades with them
            shape = {"type": "ply", "filename": str((scene_file.parent / s["ply"]).resolve())}
        elif kind == "mesh":
            if "obj" in s:
                obj = (scene_file.parent / s["obj"]).resolve()
            else:
                obj = mesh_dir / f"{scene_file.stem}_shape{k}.obj"
                _write_obj(obj, s["vertices"], s["faces"])
            shape = {"type": "obj", "filename": str(obj), "face_normals": True}
        else:
            raise ValueError(f"shape type {kind!r} has no Mitsuba twin here")
        shape["to_world"] = m.tolist()
        shape["flip_normals"] = bool(s.get("flip_normals", False))
        shape["bsdf"] = _bsdf(mats[s["material"]])
        if "emitter" in s:
            shape["emitter"] = {"type": "area", "radiance": _rgb(s["emitter"]["radiance"])}
        out[s.get("name", f"shape{k}").replace(".", "_") or f"shape{k}"] = shape
    return out


def load(mi: Any, scene_file: str | Path, mesh_dir: str | Path, spp: int, sampler: str = "independent") -> Any:
    """Load the scene in Mitsuba (``mi`` with its variant set): the dictionary with real transforms."""
    d = mitsuba_dict(scene_file, mesh_dir, spp, sampler)
    s = d["sensor"]
    la = s.pop("look_at")
    s["to_world"] = mi.ScalarTransform4f().look_at(origin=la["origin"], target=la["target"], up=la["up"])
    for v in d.values():
        if isinstance(v, dict) and "to_world" in v:
            v["to_world"] = mi.ScalarTransform4f(v["to_world"])
    return mi.load_dict(d)
