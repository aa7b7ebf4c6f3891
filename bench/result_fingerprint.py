"""Fingerprints of results that must not change: hex estimates and image hashes (issue 9).

Run it on two trees and diff the outputs to show that a refactoring kept every
result bit-identical:

    cd OLD && PYTHONPATH=$PWD python bench/result_fingerprint.py > /tmp/old.json
    cd NEW && PYTHONPATH=$PWD python bench/result_fingerprint.py > /tmp/new.json
    diff /tmp/old.json /tmp/new.json

Covers integrate (independent, stratified, nrooks at lanes 1 and 16), the four
walk estimators, and path/nee/mis renders of the Cornell box at lanes 1 and 16;
then sobol and vegas integration, lt, bdpt, sobol rendering, the light BVH, and
the other shipped scenes.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np

import mcocl

CORNELL = str(Path(__file__).resolve().parent.parent / "scenes" / "cornell.json")


def _digest(*arrays: np.ndarray) -> str:
    return hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)).hexdigest()[:16]


def fingerprints() -> dict[str, object]:
    """Hex estimates and stderrs, and hashes of walk values and images, keyed by case."""
    out: dict[str, object] = {}
    for sampler in ("independent", "stratified", "nrooks"):
        for lanes in (1, 16):
            r = mcocl.integrate("exp(-x[0]*x[1])*cos(x[2])", dim=3, samples=10**6, sampler=sampler, seed=5,
                                lanes=lanes)
            out[f"int-{sampler}-{lanes}"] = (r.estimate.hex(), float(r.stderr).hex())
    for est in ("truncated", "roulette", "subcritical", "nee"):
        w = mcocl.solve_fredholm("0.5f*x[0]*y[0]", "1.0f", dim=1, at=[0.3, 0.7], walks=10**5, estimator=est, seed=3)
        out[f"walk-{est}"] = _digest(np.asarray(w.values, np.float64), np.asarray(w.stderr, np.float64))
    for integrator in ("path", "nee", "mis"):
        for lanes in (1, 16):
            img = mcocl.render(CORNELL, spp=2, integrator=integrator, seed=1, lanes=lanes)
            out[f"render-{integrator}-{lanes}"] = _digest(img.mean, img.variance)
    out.update(later_fingerprints())
    return out


def later_fingerprints() -> dict[str, object]:
    """Results of what came after issue 9: QMC and VEGAS, splatting integrators, light BVH, other scenes."""
    out: dict[str, object] = {}
    for sampler in ("sobol", "vegas"):
        r = mcocl.integrate("exp(-x[0]*x[1])*cos(x[2])", dim=3, samples=2**20, sampler=sampler, seed=5)
        out[f"int-{sampler}"] = (r.estimate.hex(), float(r.stderr).hex())
    scenes = Path(CORNELL).parent
    cases = [
        ("cornell.json", {"integrator": "lt"}),
        ("cornell.json", {"integrator": "bdpt"}),
        ("cornell.json", {"integrator": "mis", "sampler": "sobol"}),
        ("veach_mis.json", {"integrator": "mis"}),
        ("caustic.json", {"integrator": "mis"}),
        ("many_lights.json", {"integrator": "nee"}),
        ("xml/cornell.xml", {"integrator": "mis"}),
    ]
    for name, options in cases:
        img = mcocl.render(str(scenes / name), spp=2, seed=1, **options)
        key = "-".join([name] + [f"{k}={v}" for k, v in sorted(options.items())])
        out[f"render-{key}"] = _digest(img.mean, img.variance)
    with tempfile.TemporaryDirectory() as folder:
        # The light BVH is a scene option, so the Veach scene is copied with it set.
        scene = json.loads((scenes / "veach_mis.json").read_text())
        scene.setdefault("integrator", {})["light_sampler"] = "bvh"
        path = Path(folder) / "veach_bvh.json"
        path.write_text(json.dumps(scene))
        img = mcocl.render(str(path), spp=2, seed=1, integrator="mis")
        out["render-veach_mis.json-light_sampler=bvh"] = _digest(img.mean, img.variance)
    return out


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    print(json.dumps(fingerprints(), indent=0, sort_keys=True))
