"""`pip install .` puts one name, ``stickslip``, into a fresh environment, and the main job runs;
`pip install -e .` maps the same names onto the source folders.

The environment is a virtual environment that sees Debian's packages (``--system-site-packages``:
dolfinx, PETSc and MPI come from trixie, never from pip). The install is offline
(``--no-index``, no build isolation) and from a copy of the source, so the repository gets no
``build/`` folder. pyproject.toml's ``package-dir`` installs the folders ``solver/``, ``cli/``,
... as ``stickslip.solver``, ``stickslip.cli``, ... (there are no links in the tree). The main
job (README: ``stickslip run scenes/figure3_n132.toml``) is run for a few steps from another
directory, with neither the repository on ``PYTHONPATH`` nor ./dev's editable install (its user
site directory) in sight.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("meshes", "forms", "semianalytic", "exact", "solver", "postprocess", "studies", "cli")

pytestmark = pytest.mark.dolfinx
pytest.importorskip("dolfinx")


def _source_copy(dest: Path) -> Path:
    """What the build reads: the metadata, the package's root and its folders."""
    dest.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, dest / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("stickslip", *FOLDERS):
        shutil.copytree(REPO / name, dest / name, symlinks=True, ignore=ignore)
    return dest


def _install(root: Path, *editable: str) -> tuple[Path, Path]:
    """A fresh environment under ``root`` with the project installed from a source copy:
    (the environment, the source copy)."""
    env_dir = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", "--system-site-packages",
                    str(env_dir)], check=True)
    src = _source_copy(root / "src")
    res = subprocess.run([str(env_dir / "bin" / "python"), "-m", "pip", "install", "-q",
                          "--no-index", "--no-deps", "--no-build-isolation", *editable, str(src)],
                         capture_output=True, text=True, env=_clean_env())
    assert res.returncode == 0, res.stdout + res.stderr
    return env_dir, src


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> Path:
    return _install(tmp_path_factory.mktemp("install"))[0]


@pytest.fixture(scope="module")
def editable(tmp_path_factory) -> tuple[Path, Path]:
    return _install(tmp_path_factory.mktemp("editable"), "--editable")


def _clean_env() -> dict[str, str]:
    """The caller's environment less what would show another copy of the project: the
    repository on ``PYTHONPATH``, ./dev's editable install (its user site, PYTHONUSERBASE)."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONUSERBASE")}
    env["PYTHONNOUSERSITE"] = "1"
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    return env


def _python(env_dir: Path, code: str, cwd: Path) -> list[str]:
    res = subprocess.run([str(env_dir / "bin" / "python"), "-c", code], cwd=cwd,
                         capture_output=True, text=True, env=_clean_env())
    assert res.returncode == 0, res.stderr
    return res.stdout.split()


def _site_packages(env_dir: Path) -> Path:
    (site,) = env_dir.glob("lib/python3*/site-packages")
    return site


def test_only_stickslip_is_installed(venv):
    installed = sorted(p.name for p in _site_packages(venv).iterdir())
    assert [n for n in installed if not n.endswith(".dist-info")] == ["stickslip"], installed
    package = _site_packages(venv) / "stickslip"
    for folder in FOLDERS:  # the folders are real subpackages there, not links
        assert (package / folder / "__init__.py").is_file() and not (package / folder).is_symlink()


def test_the_folder_names_are_not_importable_on_their_own(venv, tmp_path):
    code = ("import importlib.util as u, stickslip.solver.scene as s; "
            "print(u.find_spec('solver') is None, s.__file__)")
    no_top_level, where = _python(venv, code, tmp_path)
    assert no_top_level == "True"
    assert Path(where).is_relative_to(_site_packages(venv))


def test_an_editable_install_maps_the_names_onto_the_source_folders(editable, tmp_path):
    """``pip install -e .``: ``stickslip.<folder>`` is the source's ``<folder>/`` (setuptools'
    editable finder reads the package-dir mapping), the bare folder names stay unimportable,
    and the console script runs."""
    env_dir, src = editable
    code = ("import importlib.util as u, stickslip, stickslip.solver.scene as s, "
            "stickslip.cli.main as m; print(u.find_spec('solver') is None, stickslip.__file__, "
            "s.__file__, m.__file__)")
    no_top_level, root, scene, main = _python(env_dir, code, tmp_path)
    assert no_top_level == "True"
    assert Path(root) == src / "stickslip" / "__init__.py"
    assert Path(scene) == src / "solver" / "scene" / "__init__.py"
    assert Path(main) == src / "cli" / "main.py"
    res = subprocess.run([str(env_dir / "bin" / "stickslip"), "--help"], cwd=tmp_path,
                         capture_output=True, text=True, env=_clean_env())
    assert res.returncode == 0 and res.stdout.startswith("usage: stickslip"), res.stderr


def test_a_source_copy_without_its_root_folder_hides_nothing(venv, tmp_path):
    """The image keeps the source tree as its working directory, less ``stickslip/``
    (Dockerfile): ``python3 -c`` there puts that directory first on ``sys.path``, and every
    name still comes from the install."""
    src = _source_copy(tmp_path / "src")
    shutil.rmtree(src / "stickslip")
    code = ("import stickslip, stickslip.node, stickslip.solver.scene as s; "
            "print(stickslip.__file__, stickslip.node.__file__, s.__file__)")
    for where in _python(venv, code, src):
        assert Path(where).is_relative_to(_site_packages(venv)), where


def test_the_main_job_runs_from_the_installed_package(venv, tmp_path):
    out = tmp_path / "run"
    res = subprocess.run([str(venv / "bin" / "stickslip"), "run",
                          str(REPO / "scenes" / "figure3_n132.toml"), "-o", str(out),
                          "--set", "time.end_time=2e-4"],
                         cwd=tmp_path, capture_output=True, text=True, env=_clean_env(),
                         timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed"
