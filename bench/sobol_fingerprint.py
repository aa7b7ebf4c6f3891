"""Fingerprints of every result drawn through the Sobol' sampler back end, to show a speed-up kept them bit-identical.

kernels/samplers/sobol_sampler.cl serves the render sampler ``sobol``, the
integration sampler ``sobol`` and the walks' ``sobol``; this hashes the images
of the shipped scenes with path, nee and mis (16 lanes, and 1 lane on the
Cornell box), with several block sizes (so several SOBOL_LOG2_POINTS), a thin
lens (the camera's dimensions 2-3), a white furnace deep enough for the padded
dimensions past the table, and the integration and walk estimates.  Run it on
two trees and diff:

    cd OLD && PYTHONPATH=$PWD python bench/sobol_fingerprint.py > /tmp/old.json
    cd NEW && PYTHONPATH=$PWD python bench/sobol_fingerprint.py > /tmp/new.json
    diff /tmp/old.json /tmp/new.json
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import warnings
from pathlib import Path

import numpy as np

import mcocl
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def _digest(*arrays: np.ndarray) -> str:
    return hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)).hexdigest()[:16]


def _scene(name: str, width: int, **camera: float):
    """scenes/<name>.json at ``width`` pixels across (aspect kept), camera fields replaced."""
    scene = load_scene(str(SCENES / f"{name}.json"))
    cam = scene.camera
    scene.camera = dataclasses.replace(cam, width=width, height=max(1, round(width * cam.height / cam.width)), **camera)
    return scene


def render_fingerprints() -> dict[str, str]:
    """Image hashes of sobol renders, keyed by case."""
    out: dict[str, str] = {}
    cases = [(name, integrator, None, None) for name in ("cornell", "veach_mis", "many_lights", "caustic")
             for integrator in ("path", "nee", "mis")]
    cases += [("cornell", "mis", 1, None), ("cornell", "path", 1, None), ("cornell", "mis", None, 4),
              ("cornell", "mis", None, 64), ("cornell", "nee", None, 512), ("furnace", "mis", None, None)]
    for name, integrator, lanes, block in cases:
        scene = _scene(name, 32)
        img = mcocl.render(scene, spp=8 if block is None else max(8, block), seed=3, integrator=integrator,
                           sampler="sobol", lanes=lanes, spp_per_block=block)
        out[f"render-{name}-{integrator}-lanes{lanes}-block{block}"] = _digest(img.mean, img.variance)
    scene = _scene("cornell", 32, aperture_radius=0.05, focus_distance=3.0)
    img = mcocl.render(scene, spp=8, seed=3, integrator="mis", sampler="sobol")
    out["render-cornell-thinlens"] = _digest(img.mean, img.variance)
    return out


def estimate_fingerprints() -> dict[str, object]:
    """Hex estimates of sobol integration (float and double, 1 and 16 lanes) and hashes of sobol walks."""
    out: dict[str, object] = {}
    for lanes in (1, 16):
        for precision in ("single", "double"):
            r = mcocl.integrate("exp(-x[0]*x[1])*cos(x[2])", dim=3, samples=2**18, sampler="sobol", seed=5,
                                lanes=lanes, precision=precision)
            out[f"int-sobol-{lanes}-{precision}"] = (r.estimate.hex(), float(r.stderr).hex())
    w = mcocl.solve_fredholm("0.5f*x[0]*y[0]", "1.0f", dim=1, at=[0.3, 0.7], walks=2**14, seed=3, sampler="sobol")
    out["walk-sobol"] = _digest(np.asarray(w.values, np.float64), np.asarray(w.stderr, np.float64))
    return out


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    print(json.dumps({**render_fingerprints(), **estimate_fingerprints()}, indent=0, sort_keys=True))
