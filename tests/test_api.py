"""The public Python API (``import stickslip``): light to import, every name documented, and
each wrapper gives what the command gives."""

from __future__ import annotations

import inspect
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import stickslip

REPO = Path(__file__).resolve().parents[1]
OUTPUT_FILES = REPO / "docs" / "reference" / "output-files.md"


def test_import_is_light_and_every_name_resolves():
    """``import stickslip`` loads no FE stack: the reduced model and scenes work without it."""
    code = ("import sys, stickslip; stickslip.load_scene('smoke'); "
            "print(sorted(m for m in ('dolfinx', 'petsc4py', 'mpi4py', 'matplotlib') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                         text=True, check=True).stdout
    assert out.strip() == "[]"
    for name in stickslip.__all__:
        assert getattr(stickslip, name) is not None
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        stickslip.nope  # noqa: B018


@pytest.mark.parametrize("name", [n for n in stickslip.__all__ if n[0].islower()])
def test_every_function_has_a_docstring_with_an_example(name):
    doc = inspect.getdoc(getattr(stickslip, name)) or ""
    assert len(doc) > 80, name
    if name not in ("plot_run", "plot_sweep"):
        assert "Example:" in doc and ">>> " in doc, name


def test_load_scene_takes_a_mapping_or_strings_and_refuses_a_bad_key():
    a = stickslip.load_scene("figure3_n132", {"loading.omega": 40, "initial.perturbation":
                                              "random", "output.probes_deg": [0.0, 90.0]})
    b = stickslip.load_scene("figure3_n132", ["loading.omega=40", 'initial.perturbation="random"',
                                              "output.probes_deg=[0.0, 90.0]"])
    assert a == b and a.loading.omega == 40.0 and a.output.probes_deg == (0.0, 90.0)
    assert stickslip.load_scene(a, {"mesh.n_inner": 264}).mesh.n_inner == 264
    with pytest.raises(stickslip.SceneError, match="loading.omegaa"):
        stickslip.load_scene("smoke", {"loading.omegaa": 1.0})


def test_reduced_waves_match_the_wave_command():
    """Same function as ``stickslip wave --json`` (paper's stick-slip example, k = 4)."""
    from stickslip.cli.main import main

    waves = stickslip.reduced_waves(nu=0.3, xi=1.25, f=0.7, k=4, delta=1e-3, omega=40.0)
    assert waves and waves[0]["admissible"]
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        main(["wave", "--nu", "0.3", "--xi", "1.25", "--f", "0.7", "--k", "4", "--delta",
              "0.001", "--omega", "40", "--json"])
    cli = json.loads(buf.getvalue())
    assert cli["solutions"][0]["celerity_m_s"] == pytest.approx(waves[0]["celerity_m_s"],
                                                                rel=1e-12)


def _documented_keys(section: str) -> set[str]:
    """The backquoted names in the first column of a table under ``## section``."""
    text = OUTPUT_FILES.read_text()
    body = text.split(f"## `{section}`", 1)[1].split("\n## ", 1)[0]
    cells = re.findall(r"^\| ([^|]*)\|", body, flags=re.M)
    return {name for cell in cells for name in re.findall(r"`([A-Za-z_]\w*)`", cell)}


@pytest.mark.dolfinx
def test_run_analyse_and_the_output_format_page(tmp_path):
    """``run`` + ``analyse`` on the smoke scene (36 nodes, 0.02 s): the summary is the file's,
    the analysis reproduces it exactly (same function, same samples), and every key and
    shape of samples.npz and final_field.npz is the one the reference page documents."""
    pytest.importorskip("dolfinx")
    run_dir = tmp_path / "smoke"
    summary = stickslip.run("smoke", run_dir, quiet=True)
    assert summary["status"] == "completed"
    on_disk = json.loads((run_dir / "summary.json").read_text())
    # the returned summary's profile also times the writing of the files
    assert {k: v for k, v in on_disk.items() if k != "profile_s"} == \
        {k: v for k, v in summary.items() if k != "profile_s"}
    wave = stickslip.analyse(run_dir)
    assert (wave.mode, wave.regime) == (summary["mode"], summary["regime"])
    assert wave.celerity_m_s == summary["celerity_m_s"]
    data = stickslip.load_run(run_dir)
    s = data.samples
    n_t, n = s["t"].size, s["theta"].size
    assert n == 36 and s["u_r"].shape == (n_t, n) and s["status"].dtype == np.int8
    assert set(np.unique(s["status"])) <= set(stickslip.STATUS_CODES)
    assert s["probe_data"].shape == (s["probe_deg"].size, s["probe_t"].size, 4)
    assert set(s) == _documented_keys("samples.npz")
    with np.load(run_dir / "final_field.npz") as ff:
        assert set(ff.files) == _documented_keys("final_field.npz")
    assert set(summary) - {"message"} <= _documented_keys("summary.json")


@pytest.mark.dolfinx
def test_cea_friction_sweep_is_stable_without_friction():
    """Smoke mesh, band up to 3 kHz: without friction the sliding state is a conservative
    system (every omega^2 real, no growth); at f = 0.7 flutter modes appear."""
    pytest.importorskip("dolfinx")
    free, rough = stickslip.cea_friction_sweep("smoke", [0.0, 0.7], fmax_hz=3000.0)
    assert free.unstable() == [] and len(rough.unstable()) > 0
    assert rough.unstable()[0].growth_rate > 0
