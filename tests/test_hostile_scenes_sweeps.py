"""Hostile but fair scenes and sweeps: warnings a sweep hid, failures it did not announce,
and physics beyond the small-strain model that a run accepted silently.

Each test is one case that failed before its fix, met through the CLI: a sweep's table,
console line and map carry every run warning (aliased samples, a start beyond small
strain); a scene that fails on a full disk gets its ``[i/n]`` line; a mismatch that the
small-strain model cannot mean is refused in one line (exit 2, nothing written); a start
beyond it is warned of in one line.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import re
from pathlib import Path

import pytest
from test_hostile_inputs import _full_disk_for, _one_point_sweep
from test_ownership import SMOKE, cli, one_line

from stickslip.cli.main import main
from stickslip.solver.scene import MAX_STRAIN, load_scene, scene_warnings

REPO = Path(__file__).resolve().parents[1]

# ------------------------------------------------------------------ a sweep's warnings

#: The smoke scene (36 x 2 mesh, 1 s a scene) for 0.05 s: its probe oscillates at about
#: 1565 Hz. Sampled every 4e-4 s (Nyquist about 1290 Hz: samples land on whole steps) it
#: aliases, 20 % beyond Nyquist, though the pre-check, which expects the reduced model's
#: 1067 Hz, lets it run; every 1e-4 s (Nyquist 5 kHz) it does not. Amplitude 100 starts the
#: contact circle at a strain of 0.16 > 5 % (scene_warnings).
WARNING_SWEEP = """base = "{base}"
set = ["time.end_time=0.05", "output.progress=false"]
[[points]]
"output.sample_interval" = 1e-4
"initial.amplitude" = 0.1
[[points]]
"output.sample_interval" = 4e-4
"initial.amplitude" = 0.1
[[points]]
"output.sample_interval" = 1e-4
"initial.amplitude" = 100.0
[map]
x = "output.sample_interval"
y = "initial.amplitude"
semianalytic = false
"""


@pytest.fixture(scope="module")
def warned_sweep(tmp_path_factory) -> dict:
    """The sweep of ``WARNING_SWEEP``, run and plotted once: its directory (``out``), its
    console output (``console``), its sweep.json rows by (sample interval, amplitude)
    (``rows``) and every text the map drew (``texts``: cell labels and titles)."""
    pytest.importorskip("dolfinx")
    import matplotlib.axes

    tmp = tmp_path_factory.mktemp("warned")
    spec = tmp / "s.toml"
    spec.write_text(WARNING_SWEEP.format(base=SMOKE))
    out = tmp / "out"
    texts: list[str] = []
    real_text, real_title = matplotlib.axes.Axes.text, matplotlib.axes.Axes.set_title

    def text(self, x, y, s, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        texts.append(s)
        return real_text(self, x, y, s, *args, **kwargs)

    def set_title(self, s, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        texts.append(s)
        return real_title(self, s, *args, **kwargs)

    console = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(console):
        mp.setattr(matplotlib.axes.Axes, "text", text)
        mp.setattr(matplotlib.axes.Axes, "set_title", set_title)
        assert main(["sweep", str(spec), "-o", str(out), "--plot"]) == 0
    rows = {(r["output.sample_interval"], r["initial.amplitude"]): r
            for r in json.loads((out / "sweep.json").read_text())["rows"]}
    return {"out": out, "console": console.getvalue(), "rows": rows, "texts": texts}


def _line(console: str, task_id: str) -> str:
    """The sweep's console line of scene ``task_id``."""
    (line,) = [s for s in console.splitlines() if f"] {task_id}: " in s]
    return line


def test_aliased_samples_reach_the_sweep_table_console_and_map(warned_sweep):
    """Each run's summary said "aliased: probe 1702 Hz > Nyquist 1264 Hz"; the sweep's console
    line showed only the (aliased) wave, the message column of sweep.csv was empty and the map
    showed k and c as if true. Now all three say so, with the sample interval that fixes it."""
    out, rows = warned_sweep["out"], warned_sweep["rows"]
    alias, clean = rows[(4e-4, 0.1)], rows[(1e-4, 0.1)]
    summary = json.loads((out / alias["run_dir"] / "summary.json").read_text())
    assert summary["status"] == "completed"  # the case: really aliased, not a failed run
    assert summary["probe_frequency_hz"] > 1.1 * summary["nyquist_hz"]
    assert summary["warning"].startswith("aliased:")
    assert summary["warnings"] == [summary["warning"]]
    # the table: sweep.json and sweep.csv
    assert alias["aliased"] is True and clean["aliased"] is False
    assert alias["message"] == f"warning: {summary['warning']}" and clean["message"] is None
    assert "output.sample_interval <" in alias["message"]
    with open(out / "sweep.csv") as fh:
        table = {r["id"]: r for r in csv.DictReader(fh)}
    assert table[alias["id"]]["aliased"] == "True" and table[clean["id"]]["aliased"] == "False"
    assert table[alias["id"]]["message"] == alias["message"] and not table[clean["id"]]["message"]
    # the console
    line = _line(warned_sweep["console"], alias["id"])
    assert re.match(r"\[\d/3\] ", line)
    assert f"; warning: {summary['warning']}" in line
    assert "warning" not in _line(warned_sweep["console"], clean["id"])
    # the map: the aliased cell is marked, the others not, and the title says what it means
    assert (out / "regime_map.png").is_file()
    cells = [s for s in warned_sweep["texts"] if s.startswith("k = ")]
    assert len(cells) == 3
    assert [s for s in cells if s.endswith("\naliased")] == [
        f"k = {alias['mode']}{'' if alias['limit_cycle'] else '*'}\n"
        f"{alias['celerity_m_s']:+.0f} m/s\naliased"]
    assert any("aliased: the samples alias the wave" in s for s in warned_sweep["texts"])


def test_every_run_warning_reaches_the_sweep_table_and_console(warned_sweep):
    """Not only aliasing: a scene's own warning (here a start beyond small strain) was said
    in the scene's log only. Now it is in summary.json's ``warnings``, the table's message
    and the console line."""
    out, big = warned_sweep["out"], warned_sweep["rows"][(1e-4, 100.0)]
    summary = json.loads((out / big["run_dir"] / "summary.json").read_text())
    (warning,) = summary["warnings"]
    assert warning.startswith("initial.amplitude = 100 starts the contact circle")
    assert big["message"] == f"warning: {warning}" and big["aliased"] is False
    assert f"; warning: {warning}" in _line(warned_sweep["console"], big["id"])


# ------------------------------------------------------------------ a full disk


@pytest.mark.parametrize("batch", ["off", "2"])
@pytest.mark.parametrize("fit", [1, 3, 5], ids=["scene.toml", "samples", "analysis"])
def test_a_full_disk_gives_the_failed_scene_its_progress_line(tmp_path, monkeypatch, capsys,
                                                             fit, batch):
    """ENOSPC in one scene's run directory (``fit`` writes fit: scene.toml, samples.npz or
    the analysis fails): the table said `failed`, but the console had no `[i/n]` line for
    it, only for the scene that completed. Batched, the sweep even ended with exit 2 and
    nothing run (scene.toml), or exit 0 with the scene `running` in its table. Now each
    scene has its line, the failed one with the error, and the sweep exits 1."""
    pytest.importorskip("dolfinx")
    spec, out = _one_point_sweep(tmp_path), tmp_path / "out"
    _full_disk_for(monkeypatch, "omega-2.0", fit)
    assert main(["sweep", str(spec), "-o", str(out), "--batch", batch]) == 1
    rows = {r["id"]: r for r in json.loads((out / "sweep.json").read_text())["rows"]}
    assert rows["omega-2.0"]["status"] == "failed" and rows["omega-3.0"]["status"] == "completed"
    lines = [s for s in capsys.readouterr().out.splitlines() if s.startswith("[")]
    assert len(lines) == 2, lines
    failed = next(s for s in lines if "] omega-2.0: " in s)
    assert "omega-2.0: failed: " in failed and "No space left" in failed
    assert any("] omega-3.0: " in s and "failed" not in s for s in lines)
    assert sorted(s[: s.index("]") + 1] for s in lines) == ["[1/2]", "[2/2]"]


# ------------------------------------------------------------------ physics beyond small strain


@pytest.mark.parametrize(("override", "words"), [
    ("geometry.delta=10", ["geometry.delta = 10.0", "delta <= 0.05", "lower delta"]),
    ("geometry.delta=1e6", ["geometry.delta = 1000000.0", "delta <= 0.05"]),
    ("geometry.d=0.5", ["geometry.delta = 0.5", "d below 0.05 R"]),
    ("geometry.delta=0.02", ["geometry.delta = 0.02 with geometry.xi = 1.25",
                             "strain of about d / min(R, (xi - 1) R) = 0.08",
                             "lower geometry.delta to <= 0.0125", "geometry.xi >= 1.4"]),
    ("geometry.xi=1.0000001", ["geometry.xi = 1.0000001", "strain of about",
                               "lower geometry.delta to <= 5e-09"]),
])
def test_a_mismatch_beyond_small_strain_is_refused_in_one_line(tmp_path, capsys, override,
                                                               words):
    """`--set geometry.delta=10` (or 1e6) reported `completed`: at 1e6 "stick-slip, k = 4,
    c = 0 m/s", slip fraction 0, pressure 5.5e15 Pa. The mismatch d strains the tube by
    about d / min(R, (xi - 1) R) (the wall is clamped outside): above 5 % the small-strain
    model means nothing. Refused in one line with the bound and the fix; nothing written."""
    out = tmp_path / "r"
    rc, err = cli(capsys, "run", SMOKE, "-o", out, "--set", override)
    one_line(rc, err, *words)
    assert "small-strain model" in err and not out.exists()


def test_a_mismatch_at_the_bound_on_a_thicker_wall_runs():
    """The bound is the strain, not delta alone: delta = 0.02 on xi = 1.25 is refused, on a
    wall of 0.4 R (strain 0.05, the bound, to round-off) it is a scene; on a thick tube the
    hoop strain d/R is the measure (delta = 0.05 at xi = 3)."""
    assert load_scene(SMOKE, ["geometry.delta=0.02", "geometry.xi=1.4"]).geometry.delta == 0.02
    assert load_scene(SMOKE, ["geometry.delta=0.05", "geometry.xi=3"]).geometry.xi == 3


def test_the_reduced_model_shares_the_bound(capsys):
    """`stickslip wave` reads the same range table: delta = 10 is refused there too."""
    rc, err = cli(capsys, "wave", "--delta", "10")
    one_line(rc, err, "--delta 10.0", "delta <= 0.05")


def test_a_start_beyond_small_strain_is_warned_in_one_line(tmp_path, capsys):
    """`initial.amplitude=1e6` (a 400 m bump on a 1 m tube) ran without a word. It is still a
    legitimate way to make a run blow up on purpose, so it runs, with one warning line that
    names the bound and the fix, before the run and in its summary."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "r"
    assert main(["run", str(SMOKE), "-o", str(out), "--set", "initial.amplitude=1e6",
                 "--set", "time.end_time=0.005", "--set", "output.progress=false"]) in (0, 1)
    said = [s for s in capsys.readouterr().out.splitlines() if "initial.amplitude" in s]
    assert len(said) == 1 and said[0].strip().startswith("warning: initial.amplitude = 1e+06")
    assert "use initial.amplitude <= 30.2" in said[0] and "5%" in said[0]
    summary = json.loads((out / "summary.json").read_text())
    assert said[0].strip() == f"warning: {summary['warnings'][0]}"


def _strains(scene) -> tuple[float, float]:  # noqa: ANN001
    """(the mismatch's strain, the start's strain) of a scene, as the checks measure them."""
    g, ini = scene.geometry, scene.initial
    start = 0.0 if ini.perturbation == "none" else ini.amplitude
    return g.d / g.strained_length, g.d * (1.0 + start) / g.strained_length


def test_every_shipped_scene_and_sweep_is_far_inside_the_bounds():
    """The bound must refuse nonsense only: every shipped scene and every scene of a shipped
    sweep (the largest is Figure 4's delta = 0.005 on a wall of 0.25 R, strain 0.02, its
    start 0.022) stays below half of it, and none is warned of."""
    from stickslip.studies.sweep import load_sweep, scene_for

    scenes = [load_scene(p) for p in sorted((REPO / "scenes").glob("*.toml"))]
    for path in sorted((REPO / "sweeps").glob("*.toml")):
        spec = load_sweep(path, large=True)
        scenes += [scene_for(spec, t) for t in spec.tasks]
    assert len(scenes) > 50
    worst = max(max(_strains(sc)) for sc in scenes)
    assert 0.02 <= worst <= 0.5 * MAX_STRAIN, worst
    assert not [w for sc in scenes for w in scene_warnings(sc) if "small-strain" in w]
