"""Render the reference images of tests/data/mitsuba/ with Mitsuba 3.

Run with the Python of a separate virtual environment that has ``mitsuba``
(it is not a dependency of mcocl, and the tests never import it):

    /work/mitsuba-venv/bin/python bench/make_mitsuba_references.py              # every scene
    /work/mitsuba-venv/bin/python bench/make_mitsuba_references.py shapes glass # only these
    /work/mitsuba-venv/bin/python bench/make_mitsuba_references.py --stale      # new or changed XML only

For each scene ``tests/data/mitsuba/<name>.xml`` (the same file mcocl reads in
tests/test_mitsuba_references.py) it renders ``--batches`` independent images
of ``--spp`` samples per pixel, batch k with seed ``--seed + k``, and writes
``<name>.npz`` with (all float32):

- ``mean`` (H, W, 3): the mean of the batches;
- ``stderr`` (H, W, 3): the per-pixel standard error of that mean, the
  spread of the batches (sample standard deviation / sqrt(batches));
- ``block_stderr`` (H/8, W/8, 3): the standard error of the mean of every
  8 x 8 block of pixels, from the spread of the batches' block means.  It is
  right also when neighbouring pixels are correlated (a filter wider than a
  pixel splats one sample into several pixels), where adding up per-pixel
  variances would not be.

and records in ``manifest.json`` (one entry per scene, the others kept) the
Mitsuba version, variant, spp, batches, seeds, the SHA-256 of the XML file
(the test refuses a reference whose XML changed since), the date and the
command.  Scalar variants compute in double precision per sample as the
XML says; ``scalar_rgb`` renders in RGB, as mcocl does (a spectral variant
would upsample every RGB value to a spectrum: another image).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "mitsuba"
BLOCK = 8


def block_means(img: np.ndarray) -> np.ndarray:
    """Means of the BLOCK x BLOCK pixel blocks of an (H, W, C) image (H, W multiples of BLOCK)."""
    h, w, c = img.shape
    if h % BLOCK or w % BLOCK:
        raise SystemExit(f"image {w} x {h} is not a multiple of {BLOCK} x {BLOCK} blocks")
    return img.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, c).mean(axis=(1, 3))


def render_batches(mi, xml: Path, spp: int, batches: int, seed: int) -> np.ndarray:
    """(batches, H, W, 3) float64 images of ``xml``, batch k rendered with seed ``seed + k``."""
    scene = mi.load_file(str(xml), spp=str(spp))
    out = []
    for k in range(batches):
        img = np.array(mi.render(scene, spp=spp, seed=seed + k), dtype=np.float64)
        out.append(img[..., :3])
    return np.stack(out)


def stale(data: Path, name: str, manifest: dict) -> bool:
    """Whether ``<name>.xml`` has no reference, or changed since its reference was made."""
    xml, npz = data / f"{name}.xml", data / f"{name}.npz"
    if name not in manifest or not npz.exists():
        return True
    return hashlib.sha256(xml.read_bytes()).hexdigest() != manifest[name].get("xml_sha256")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", help="scene names (XML files in tests/data/mitsuba/); default: all")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel of one batch")
    ap.add_argument("--batches", type=int, default=64, help="independent batches (the standard error's spread)")
    ap.add_argument("--seed", type=int, default=1000, help="seed of the first batch (then seed + 1, ...)")
    ap.add_argument("--data", type=Path, default=DATA, help="the folder of the XML files and references")
    ap.add_argument("--stale", action="store_true",
                    help="only the scenes without a reference or whose XML changed since theirs was made")
    args = ap.parse_args()
    if args.batches < 2:
        raise SystemExit("--batches must be at least 2 (the standard error is their spread)")
    names = args.scenes or sorted(p.stem for p in args.data.glob("*.xml"))
    manifest_path = args.data / "manifest.json"
    manifest = json.loads(manifest_path.read_text()) if manifest_path.exists() else {}
    if args.stale:
        names = [n for n in names if stale(args.data, n, manifest)]
        print("stale:", " ".join(names) or "none", flush=True)

    import mitsuba as mi

    mi.set_variant(args.variant)
    command = "python " + " ".join(shlex.quote(a) for a in [Path(sys.argv[0]).as_posix()] + sys.argv[1:])
    for name in names:
        xml = args.data / f"{name}.xml"
        t0 = time.perf_counter()
        imgs = render_batches(mi, xml, args.spp, args.batches, args.seed)
        n = args.batches
        mean = imgs.mean(axis=0)
        stderr = imgs.std(axis=0, ddof=1) / np.sqrt(n)
        blocks = np.stack([block_means(i) for i in imgs])
        block_stderr = blocks.std(axis=0, ddof=1) / np.sqrt(n)
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(stderr))):
            raise SystemExit(f"{name}: Mitsuba produced non-finite pixels")
        np.savez_compressed(args.data / f"{name}.npz", mean=mean.astype(np.float32),
                            stderr=stderr.astype(np.float32), block_stderr=block_stderr.astype(np.float32))
        seconds = time.perf_counter() - t0
        manifest[name] = {
            "xml": xml.name,
            "xml_sha256": hashlib.sha256(xml.read_bytes()).hexdigest(),
            "renderer": "Mitsuba 3",
            "mitsuba_version": mi.__version__,
            "variant": args.variant,
            "spp_per_batch": args.spp,
            "batches": n,
            "seeds": [args.seed, args.seed + n - 1],
            "width": int(mean.shape[1]),
            "height": int(mean.shape[0]),
            "seconds": round(seconds, 1),
            "date": datetime.date.today().isoformat(),
            "command": command,
        }
        manifest_path.write_text(json.dumps(dict(sorted(manifest.items())), indent=2) + "\n")
        rel = float(np.mean(stderr / np.maximum(mean, 1e-6)))
        print(f"{name}: {mean.shape[1]}x{mean.shape[0]}, {n} x {args.spp} spp, {seconds:.1f} s, "
              f"mean relative stderr per pixel {rel:.3g}", flush=True)


if __name__ == "__main__":
    main()
