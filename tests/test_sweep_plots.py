"""Sweep maps and progress lines say what the runs found, for any key type a scene accepts.

No FE: each scene's ``summary.json`` is written by hand (the map and the progress lines read
only those), so every test takes well under a second apart from the reduced-model overlay.
"""

from __future__ import annotations

import io
import json
import time
from pathlib import Path

import pytest

from stickslip.studies.rundir.ownership import claim
from stickslip.studies.sweep import load_sweep, plot_sweep
from stickslip.studies.sweep.schedule import _Monitor
from stickslip.studies.sweep.table import write_table

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"

pytest.importorskip("matplotlib")

WAVE = {"status": "completed", "regime": "stick-slip-separation", "mode": 4,
        "celerity_m_s": -2507.0, "frequency_hz": 1596.0, "limit_cycle": True,
        "wall_time_s": 1.0}
STEADY = {"status": "completed", "regime": "steady-sliding", "mode": 4, "celerity_m_s": 0.0,
          "frequency_hz": 0.0, "limit_cycle": True, "wall_time_s": 1.0}


def _sweep(tmp_path: Path, grid: str, summaries) -> tuple[object, Path]:
    """A sweep file over ``grid`` and a sweep directory whose runs hold ``summaries(task)``."""
    path = tmp_path / "s.toml"
    path.write_text(f'name = "s"\nbase = "{SMOKE}"\n[grid]\n{grid}\n')
    spec = load_sweep(path)
    out = tmp_path / "out"
    for task in spec.tasks:
        run = out / "runs" / task.id
        claim(run, "run").release()  # a run directory of stickslip's (its marker)
        (run / "summary.json").write_text(json.dumps(summaries(task)))
    write_table(out, spec)
    return spec, out


def test_integer_keys_are_swept_and_plotted(tmp_path):
    """``initial.mode = [2, 4]`` (an integer key) beside a reduced-model key: the map draws,
    with the reduced model's overlay (which builds a scene at every grid point)."""
    spec, out = _sweep(tmp_path, '"initial.mode" = [2, 4]\n"geometry.delta" = [4e-4, 1e-3]',
                       lambda task: WAVE)
    assert [t.params["initial.mode"] for t in spec.tasks] == [2, 2, 4, 4]
    assert all(isinstance(t.params["initial.mode"], int) for t in spec.tasks)
    (png,) = plot_sweep(out)
    assert png.name == "regime_map.png" and png.stat().st_size > 10_000
    assert (out / "semianalytic.json").exists()


@pytest.mark.parametrize("grid", [
    '"friction.filter" = ["nodal", "1-2-1"]\n"output.fields" = [true, false]',
    '"output.probes_deg" = [[0.0], [90.0, 180.0]]\n"mesh.n_inner" = [36, 40]',
])
def test_every_key_type_is_swept_and_plotted(tmp_path, grid):
    """Strings, booleans, lists of numbers and integers on the axes (categorical or numeric)."""
    _, out = _sweep(tmp_path, grid, lambda task: WAVE)
    assert all(p.stat().st_size > 10_000 for p in plot_sweep(out))


def test_subtitle_names_only_the_parameters_that_are_not_swept():
    from stickslip.solver.scene import load_scene
    from stickslip.studies.sweep.regime_map import _fixed_subtitle

    scene = load_scene(SMOKE)
    text = _fixed_subtitle(scene, ["loading.f", "geometry.delta"])
    assert "f = " not in text and "δ = " not in text
    assert "Ω = 50 rad/s" in text and "N = 36" in text and "t_end = 0.02 s" in text
    assert "damping" in text  # the scene's damping is stated (none here)
    assert "Ω" not in _fixed_subtitle(scene, ["loading.omega"])
    assert "damping" not in _fixed_subtitle(scene, ["damping.loss_factor"])


def test_cells_say_what_their_run_found():
    from stickslip.studies.sweep.regime_map import cell_label

    assert cell_label(STEADY) == ("steady-sliding", "steady\nsliding")
    assert cell_label(WAVE) == ("stick-slip-separation", "k = 4\n-2507 m/s")
    assert cell_label({**WAVE, "limit_cycle": False})[1] == "k = 4*\n-2507 m/s"
    assert cell_label({"status": "diverged", "regime": "diverged"}) == ("diverged", "diverged")
    assert cell_label({"status": "failed"}) == ("failed", "error")
    assert cell_label({"status": "pending"}) == (None, "pending")


def test_progress_line_waits_for_the_wave_analysis_and_names_the_result(tmp_path):
    """A run is saved (status completed, ``"analysis": "pending"``) before its wave analysis
    is added: the monitor reports it once the analysis is there, with its regime."""
    grid = '"loading.omega" = [20.0, 50.0]'
    spec, out = _sweep(tmp_path, grid, lambda task: {"status": "pending"})
    stream = io.StringIO()
    mon = _Monitor(out, spec, spec.tasks, 0, stream, live=False)
    mon.t0 = time.time() - 10.0
    first, second = (out / "runs" / t.id / "summary.json" for t in spec.tasks)
    first.write_text(json.dumps({"status": "completed", "analysis": "pending",
                                 "wall_time_s": 0.1}))
    second.write_text(json.dumps(STEADY))
    mon.poll()
    (line,) = stream.getvalue().splitlines()
    assert line.startswith(f"[1/2] {spec.tasks[1].id}: steady sliding (no wave) (1.0 s)")
    first.write_text(json.dumps(WAVE))
    mon.poll()
    line = stream.getvalue().splitlines()[-1]
    assert line.startswith(f"[2/2] {spec.tasks[0].id}: stick-slip-separation, k = 4, "
                           "c = -2507 m/s")
