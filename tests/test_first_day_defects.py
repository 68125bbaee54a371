"""Defects a new user meets on the first day, each the case that was wrong before its fix:
the scene reference printed formulas in italics, ``continue`` on a fields run named the wrong
format and gave no command, ``travel`` moved the start's speed without a word and followed
a branch onto another wave, two figures were cramped, and a README command wrote into the
repository root.
"""

from __future__ import annotations

import json
import re
import shlex
import sys
from pathlib import Path

import numpy as np
import pytest
from test_ownership import copy_run, one_line, run
from test_readme import fenced_commands, stickslip_args

from stickslip.cli.main import main

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "docs" / "_ext"))

import stickslip_reference as reference  # noqa: E402

#: The tutorial's travelling wave (docs/tutorial/travelling-wave.md): the damped Figure-1
#: scene at N = 36, k = 4, started at -2300 m/s with the speed held.
TUTORIAL_WAVE = ["travel", "figure1_n132_damped", "--set", "mesh.n_inner=36", "--k", "4",
                 "--celerity", "-2300", "--fixed-omega"]


@pytest.fixture(scope="module")
def fields_run(tmp_path_factory) -> Path:
    """A finished smoke run (0.005 s) that wrote its fields (VTX: fields.bp, stress.bp)."""
    pytest.importorskip("dolfinx")
    d = tmp_path_factory.mktemp("fields") / "r"
    assert run(d, "output.fields=true")["status"] == "completed"
    assert (d / "fields.bp").is_dir() and (d / "stress.bp").is_dir()
    return d


# ------------------------------------------------------------------ the scene reference


def test_the_scene_reference_renders_formulas_as_code_not_italics():
    """`p~_i … p_{i-1}` in [friction] rendered as italics (the underscores paired up). The
    pages are rendered as CommonMark with tables (what MyST reads): no emphasis anywhere,
    and the 1-2-1 filter's formula is one code span."""
    from markdown_it import MarkdownIt

    md = MarkdownIt("commonmark").enable("table")
    scene = md.render(reference.scene_markdown())
    for html in (scene, md.render(reference.cli_markdown())):
        assert "<em>" not in html and "<strong>" not in html
    friction = scene.split('id="friction"' if 'id="friction"' in scene else "[friction]", 1)[1]
    assert "<code>p~_i = in_contact_i (p_{i-1} + 2 p_i + p_{i+1}) / 4</code>" in friction
    assert "<code>d sigma_eff/dt = -(|V| + V*) / L (sigma_eff - p)</code>" in friction
    # text outside code is escaped, code is kept as written; a table cell escapes `|`
    assert reference._cell("p_i and ``q_i|r*``", table=False) == "p\\_i and ``q_i|r*``"
    assert reference._cell("a|b ``c|d``") == "a\\|b ``c\\|d``"


# ------------------------------------------------------------------ continue on a fields run


@pytest.mark.parametrize("fmt, files", [("vtx", "fields.bp + stress.bp"),
                                        ("xdmf", "fields.xdmf + fields.h5")])
def test_continue_on_a_fields_run_names_its_files_and_the_command(fields_run, tmp_path,
                                                                   capsys, fmt, files):
    """`continue` on a VTX run said "whose XDMF series is not continued" and gave no command.
    Now one line names the run's own field files and the `stickslip run` that writes the
    fields to T; the run is untouched, and that command does write them to T."""
    from faults import digest

    from stickslip.solver.writers import FIELD_FILES
    from stickslip.studies.rundir.continuation import FIELD_FILES as NAMED

    assert NAMED == FIELD_FILES  # the line names the files the writer writes
    if fmt == "vtx":
        d = copy_run(fields_run, tmp_path / "r")
    else:
        d = tmp_path / "r"
        assert run(d, "output.fields=true", "output.field_format=xdmf")["status"] == \
            "completed"
    before = digest(d)
    rc = main(["continue", str(d), "--until", "0.008"])
    err = capsys.readouterr().err
    one_line(rc, err, f"output.fields = true: {files}", "time.end_time=0.008")
    assert fmt == "xdmf" or "xdmf" not in err.lower()
    assert digest(d) == before
    if fmt == "vtx":  # the command given writes the fields of the run to T
        command = shlex.split(re.search(r"`(stickslip run [^`]+)`", err).group(1))
        assert main([*command[1:], "--set", "output.progress=false"]) == 0
        capsys.readouterr()
        out = Path(command[command.index("-o") + 1])
        summary = json.loads((out / "summary.json").read_text())
        assert summary["sim_time_s"] >= 0.008 * (1 - 1e-12)
        assert (out / "fields.bp").is_dir() and (out / "stress.bp").is_dir()


# ------------------------------------------------------------------ travel: start and branch


def test_travel_says_why_its_celerity_is_not_the_start(tmp_path, capsys):
    """Started at -2300 m/s with the speed held, travel returned -2357.5 m/s with no word.
    No wave of the family is admissible at -2300 m/s; the fixed-speed search steps the speed
    by 0.25 % and takes the nearest admissible one, ten steps out: exactly 2.50 % faster. One
    line says so, and summary.json carries it."""
    pytest.importorskip("dolfinx")
    assert main([*TUTORIAL_WAVE, "-o", str(tmp_path / "w")]) == 0
    out = capsys.readouterr().out
    summary = json.loads((tmp_path / "w" / "summary.json").read_text())
    assert summary["celerity_m_s"] == pytest.approx(-2300.0 * 1.025, rel=1e-12)
    notes = [ln for ln in out.splitlines() if ln.startswith("note: ")]
    assert len(notes) == 1 and "2.50 % faster than the start's -2300.0 m/s" in notes[0]
    assert "nearest speed" in notes[0] and notes[0][6:] == summary["celerity_note"]


def test_travel_without_a_gap_says_nothing():
    """The note is for a gap a user reads (over 0.1 %), not for round-off."""
    from stickslip.studies.travel.command import celerity_note

    assert celerity_note(-2300.0, -2300.0 * (1 + 1e-4), "fixed omega") is None
    note = celerity_note(1000.0, 1100.0, "free omega (phase condition)")
    assert "10.00 % faster" in note and "unknown of the solve" in note


def test_a_branch_that_jumps_to_another_wave_is_marked_and_stopped(tmp_path, capsys):
    """Along loading.omega = 40 … 60 (5 points) the branch went at Ω = 60 to another wave
    (amplitude 0.0131 -> 0.0073 m, ψ₁ = ψ₂: no stick zone; celerity 4 % off a trend of 0.25 %
    steps) and called it converged. Now that point is "jumped", a warning says so, and the
    branch stops there (exit 0: four points of the branch did converge)."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "b"
    assert main([*TUTORIAL_WAVE, "--continue", "loading.omega=40:60:5", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    rows = json.loads((out / "branch.json").read_text())
    assert [r["status"] for r in rows] == ["converged"] * 4 + ["jumped"]
    jumped = rows[-1]
    assert jumped["value"] == 60.0 and jumped["psi1_subnode"] == pytest.approx(
        jumped["psi2_subnode"]) and jumped["amplitude_m"] < 0.6 * rows[-2]["amplitude_m"]
    assert "celerity_m_s" in jumped["violated"]
    warnings = [ln for ln in text.splitlines() if ln.startswith("warning: ")]
    assert len(warnings) == 1 and "loading.omega = 60 jumped to another wave" in warnings[0]
    assert "stops after loading.omega = 55" in warnings[0]
    assert "4/5 points converged" in text
    assert (out / "branch.csv").read_text().splitlines()[-1].startswith("60.0,jumped,")


def test_jump_bounds_and_trend():
    """A smooth branch is no jump even when it moves fast everywhere (its own trend); a
    zone boundary that moves a quarter wavelength against a still trend is."""
    from stickslip.studies.travel.continuation import jump

    def row(value, c, a, p1, p2):  # noqa: ANN001, ANN202
        return {"value": value, "celerity_m_s": c, "amplitude_m": a, "psi1_subnode": p1,
                "psi2_subnode": p2}

    smooth = [row(40, -1000, 1e-3, 0.40, 0.80), row(45, -1050, 1.5e-3, 0.42, 0.82)]
    assert jump(smooth, row(50, -1100, 2.0e-3, 0.44, 0.84)) is None  # 5 % and 33 % a step
    assert jump(smooth[:1], row(45, -1005, 1.1e-3, 0.41, 0.81)) is None
    why = jump(smooth, row(50, -1100, 2.0e-3, 0.44, 0.60))
    assert why is not None and why.startswith("psi2_subnode 0.6")
    assert jump(smooth[:1], row(45, -1050, 1e-3, 0.4, 0.8)).startswith("celerity_m_s")
    assert jump([], row(45, -1050, 1e-3, 0.4, 0.8)) is None


# ------------------------------------------------------------------ figures


def test_spacetime_colour_bar_label_clears_the_next_panel(fields_run):
    """The u_r − d colour bar's label sat 17 px (at 100 dpi) from the contact-status panel,
    whose tick marks take 5 of them: it read as that panel's axis label. Now at least 30 px
    between the label's right edge and that panel's frame, several times the label's 6 px
    from its own bar's tick labels."""
    import matplotlib

    matplotlib.use("Agg")
    from stickslip.postprocess.analysis import load_run
    from stickslip.postprocess.plotting import spacetime_figure

    fig = spacetime_figure(load_run(fields_run))
    fig.set_dpi(100)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    panels = [ax for ax in fig.axes if ax.get_title()]
    bar = next(ax for ax in fig.axes if ax.get_ylabel() == "u_r − d (mm)")
    label = bar.yaxis.label.get_window_extent(renderer)
    right = panels[1].get_window_extent(renderer)
    assert right.x0 - label.x1 >= 30.0, (label, right)


def _title_line_heights(png: Path) -> list[int]:
    """Height (px) of the first text line at the top of each half of ``png``."""
    from PIL import Image

    img = np.asarray(Image.open(png).convert("L"))
    top = img[: int(0.15 * img.shape[0])]
    heights = []
    for half in (top[:, : img.shape[1] // 2], top[:, img.shape[1] // 2:]):
        dark = np.flatnonzero((half < 110).any(axis=1))
        gaps = np.flatnonzero(np.diff(dark) > 1)
        heights.append(int(dark[gaps[0]] - dark[0] + 1 if gaps.size else np.ptp(dark) + 1))
    return heights


def test_stress_map_titles_are_readable_and_alike(fields_run, tmp_path):
    """stress.png's left title came out at about 11 px, the right at 16 px (a corner
    annotation shrinks long text to fit): now both panels' first title lines are the same
    height, at least 18 px on the 1520 x 860 picture."""
    pytest.importorskip("pyvista")
    from stickslip.postprocess.stressmap import stress_maps

    png = stress_maps(fields_run, tmp_path / "stress.png")
    left, right = _title_line_heights(png)
    assert left >= 18 and abs(left - right) <= 2, (left, right)


# ------------------------------------------------------------------ README


def test_readme_commands_write_under_runs_or_tmp():
    """`flutter-fe … --plot cea.png` wrote into the repository root; every file or folder
    a README command names for its output is under runs/ (where the others write) or /tmp."""
    from stickslip.cli.main import build_parser

    parser = build_parser()
    named = []
    for cmd in fenced_commands():
        args = stickslip_args(cmd)
        if args is None:
            continue
        ns = parser.parse_args(args)
        for dest in ("output", "plot", "csv"):
            value = getattr(ns, dest, None)
            if isinstance(value, str):
                named.append(value)
                assert value.startswith(("runs/", "/tmp/")), (cmd, dest, value)
    assert "runs/cea.png" in named
