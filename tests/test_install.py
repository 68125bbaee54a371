"""`pip install .` puts one name, ``stickslip``, into a fresh environment, and the main job runs.

The environment is a virtual environment that sees Debian's packages (``--system-site-packages``:
dolfinx, PETSc and MPI come from trixie, never from pip). The install is offline
(``--no-index``, no build isolation) and from a copy of the source, so the repository gets no
``build/`` folder. The main job (README: ``stickslip run scenes/figure3_n132.toml``) is run for a
few steps from another directory, without the repository on ``PYTHONPATH``.
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
    """What the build reads: the metadata, the package and its linked folders (links kept)."""
    dest.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, dest / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("stickslip", *FOLDERS):
        shutil.copytree(REPO / name, dest / name, symlinks=True, ignore=ignore)
    return dest


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("install")
    env_dir = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", "--system-site-packages",
                    str(env_dir)], check=True)
    src = _source_copy(root / "src")
    res = subprocess.run([str(env_dir / "bin" / "python"), "-m", "pip", "install", "-q",
                          "--no-index", "--no-deps", "--no-build-isolation", str(src)],
                         capture_output=True, text=True, env=_clean_env())
    assert res.returncode == 0, res.stdout + res.stderr
    return env_dir


def _clean_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    return env


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
    res = subprocess.run([str(venv / "bin" / "python"), "-c", code], cwd=tmp_path,
                         capture_output=True, text=True, env=_clean_env())
    assert res.returncode == 0, res.stderr
    no_top_level, where = res.stdout.split()
    assert no_top_level == "True"
    assert Path(where).is_relative_to(_site_packages(venv))


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
