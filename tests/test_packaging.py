"""The package ships its kernels: a wheel, a wheel built from the sdist, and a source checkout
all find every ``.cl`` file under ``kernels/`` (installed as the package data ``mcocl/kernels``).

The builds run setuptools' PEP 517 backend in a subprocess, without build
isolation and without network, on a copy of the checkout in a temporary
folder, so they leave nothing behind.  pyproject.toml's ``packages`` list
must name every package folder under ``mcocl/``: a folder missing from it
would be left out of wheels while tests from the checkout still pass.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

from mcocl import runtime

ROOT = Path(__file__).resolve().parent.parent
# What a build reads: the project metadata, the readme and license it names, the code, the kernels.
BUILD_INPUTS = ("pyproject.toml", "README.md", "LICENSE", "mcocl", "kernels")
BUILD = ("from setuptools import build_meta as b; import sys; "
         "print(b.build_wheel(sys.argv[1]) if sys.argv[2] == 'wheel' else b.build_sdist(sys.argv[1]))")
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build", "dist")


def _kernel_files() -> set[str]:
    files = {p.relative_to(ROOT / "kernels").as_posix() for p in (ROOT / "kernels").rglob("*.cl")}
    assert len(files) > 20, "kernels/ looks empty"
    return files


def _module_files() -> set[str]:
    return {p.relative_to(ROOT).as_posix() for p in (ROOT / "mcocl").rglob("*.py") if "__pycache__" not in p.parts}


def _build(src: Path, kind: str, out: Path) -> Path:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PIP_")}
    env["PYTHONPATH"] = ""  # the backend must see the copy, not a checkout on the path
    r = subprocess.run([sys.executable, "-c", BUILD, str(out), kind], cwd=src, env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, f"building the {kind} failed:\n{r.stderr[-3000:]}"
    return out / r.stdout.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> dict[str, Path]:
    """A wheel and an sdist of a copy of the checkout, and a wheel built from the unpacked sdist."""
    pytest.importorskip("setuptools.build_meta")
    tmp = tmp_path_factory.mktemp("packaging")
    src = tmp / "checkout"
    src.mkdir()
    for name in BUILD_INPUTS:
        p = ROOT / name
        if p.is_dir():
            shutil.copytree(p, src / name, ignore=IGNORE)
        else:
            shutil.copy2(p, src / name)
    wheel = _build(src, "wheel", tmp / "dist")
    sdist = _build(src, "sdist", tmp / "dist")
    with tarfile.open(sdist) as t:
        t.extractall(tmp / "unpacked", filter="data")
    (top,) = (tmp / "unpacked").iterdir()
    wheel_from_sdist = _build(top, "wheel", tmp / "dist-from-sdist")
    return {"wheel": wheel, "sdist": sdist, "wheel_from_sdist": wheel_from_sdist, "tmp": tmp}


@pytest.mark.parametrize("which", ["wheel", "wheel_from_sdist"])
def test_wheel_ships_every_kernel_and_module(built: dict[str, Path], which: str) -> None:
    names = set(zipfile.ZipFile(built[which]).namelist())
    missing = {f"mcocl/kernels/{k}" for k in _kernel_files()} - names
    assert not missing, f"{which} lacks {sorted(missing)[:10]}"
    assert "mcocl/kernels/__init__.py" in names
    missing_py = _module_files() - names
    assert not missing_py, f"{which} lacks {sorted(missing_py)[:10]} (a package missing from pyproject.toml?)"


def test_sdist_ships_every_kernel(built: dict[str, Path]) -> None:
    with tarfile.open(built["sdist"]) as t:
        names = {n.split("/", 1)[1] for n in t.getnames() if "/" in n}
    missing = {f"kernels/{k}" for k in _kernel_files()} - names
    assert not missing, f"the sdist lacks {sorted(missing)[:10]}"


def test_installed_wheel_finds_its_kernels(built: dict[str, Path]) -> None:
    """Unpacked as site-packages would hold it, the wheel's runtime reads mcocl/kernels beside itself."""
    site = built["tmp"] / "site"
    zipfile.ZipFile(built["wheel"]).extractall(site)
    probe = ("import mcocl.runtime as r, pathlib, sys; d = r.KERNEL_DIR; "
             "print(d); print('\\n'.join(sorted(p.relative_to(d).as_posix() for p in d.rglob('*.cl'))))")
    r = subprocess.run([sys.executable, "-c", probe], cwd=built["tmp"], env={**os.environ, "PYTHONPATH": str(site)},
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert Path(lines[0]).resolve() == (site / "mcocl" / "kernels").resolve()
    assert set(lines[1:]) == _kernel_files()


def test_checkout_finds_every_kernel() -> None:
    """Run from the checkout (or installed editable), the runtime reads the top-level kernels/ folder."""
    assert runtime.KERNEL_DIR.resolve() == (ROOT / "kernels").resolve()
    found = {p.relative_to(runtime.KERNEL_DIR).as_posix() for p in runtime.KERNEL_DIR.rglob("*.cl")}
    assert found == _kernel_files()


def test_packages_list_names_every_package_folder() -> None:
    tomllib = pytest.importorskip("tomllib")
    setuptools_cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(setuptools_cfg["packages"])
    folders = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "mcocl").rglob("__init__.py")}
    assert folders - listed == set(), "add these to [tool.setuptools] packages"
    # the kernels' folders are listed too (setuptools warns about package data in unlisted folders)
    kernels = {"mcocl.kernels"} | {f"mcocl.kernels.{d.name}" for d in (ROOT / "kernels").iterdir()
                                   if d.is_dir() and any(d.glob("*.cl"))}
    assert listed == folders | kernels
    assert setuptools_cfg["package-dir"]["mcocl.kernels"] == "kernels"
