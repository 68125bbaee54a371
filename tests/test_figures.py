"""The figures of a run (``stickslip run --plot``) tell the truth: what each one shows is
checked against the run's own numbers on one small run.

The run: scenes/smoke.toml (36 contact nodes, 2 layers, 0.02 s) with Kelvin–Voigt damping and
the paper's β₂ = 0.6, so that every term of the energy balance is non-zero (work of the
cylinder, frictional, impact, viscous and algorithmic dissipation). About 1 s of FE and a few
seconds of drawing.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"
DAMPED = ("damping.loss_factor=0.02", "damping.reference_frequency_hz=1600.0")

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    from mpi4py import MPI

    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir import run_scene

    out = tmp_path_factory.mktemp("figures") / "smoke_damped"
    summary = run_scene(load_scene(SMOKE, DAMPED), out, comm=MPI.COMM_SELF)
    assert summary["status"] == "completed"
    return out


@pytest.fixture(scope="module")
def run(run_dir):
    from stickslip.postprocess.analysis import load_run

    return load_run(run_dir)


def _close(fig) -> None:
    import matplotlib.pyplot as plt

    plt.close(fig)


# ------------------------------------------------------------------------ space-time window


def test_window_option_parses_periods_durations_and_all():
    import argparse

    from stickslip.postprocess.plotting import parse_window

    assert parse_window("5T") == (5.0, "T")
    assert parse_window("2.5 periods") == (2.5, "T")
    assert parse_window("4ms") == pytest.approx((0.004, "s"))
    assert parse_window("0.01s") == (0.01, "s")
    assert parse_window("all") is None
    for bad in ("3x", "-1T", "0ms", "ms"):
        with pytest.raises(argparse.ArgumentTypeError, match="number of periods"):
            parse_window(bad)


def test_spacetime_map_shows_the_last_periods_by_default(run):
    """Default: the last 5 periods a fixed point sees (1/frequency), not the whole run; a
    duration and "all" as asked. Whole sample rows: the span to within one sample."""
    from stickslip.postprocess.plotting import DEFAULT_WINDOW, parse_window, spacetime_figure

    t = run.samples["t"]
    freq = run.summary["frequency_hz"]
    assert freq > 0, "the smoke run grows a wave within 0.02 s"
    sample = float(np.median(np.diff(t)))
    for text, span in ((DEFAULT_WINDOW, 5.0 / freq), ("2ms", 2e-3), ("all", t[-1] - t[0])):
        fig = spacetime_figure(run, parse_window(text))
        for ax in fig.axes[:2]:  # the two maps (their colour bars follow)
            rows = ax.collections[0].get_array().shape[0]
            times = 1e-3 * ax.collections[0].get_coordinates()[:, 0, 1]  # cell edges (ms)
            assert times.max() == pytest.approx(t[-1] + sample / 2, rel=1e-6)
            assert abs((rows - 1) * sample - span) <= sample * 1.01, (text, rows)
        _close(fig)


# ------------------------------------------------------------------------ energy balance


def test_energy_terms_sum_to_E0_within_the_stated_residual(run):
    """E(0) = E(t) − W_cyl + D_f + D_n + D_v − r(t) with r the summary's stated residual.

    The figure counts the flows from the first sample (E(0) is that sample's energy); the
    summary states totals since the start, whose first-sample part is the row e[0] of the
    same columns. Each end value is the summary's to 1e-12 relative (the same sums, one
    subtraction apart), and with the stated residual the drawn terms give E(0) back to
    round-off of the largest term (1e-12 of W_cyl).
    """
    from stickslip.postprocess.energy_balance import energy_terms

    e = run.samples["energies"]
    terms = energy_terms(e)
    stated = run.summary["energy"]
    wcyl = stated["work_cylinder_J_per_m"]
    for key, name, col in (("work_cylinder", "work_cylinder_J_per_m", 3),
                           ("friction_dissipation", "friction_dissipation_J_per_m", 4),
                           ("viscous_dissipation", "damping_dissipation_J_per_m", 5)):
        assert terms[key][-1] + e[0, col] == pytest.approx(stated[name], rel=1e-12), key
        assert stated[name] > 0.0, f"{key}: every term is exercised by this run"
    assert terms["impact_dissipation"][-1] > 0.0  # inelastic impacts of the explicit step
    e0 = (terms["total"][-1] - terms["work_cylinder"][-1] + terms["friction_dissipation"][-1]
          + terms["impact_dissipation"][-1] + terms["viscous_dissipation"][-1]
          - stated["balance_residual_J_per_m"])
    assert e0 == pytest.approx(stated["initial_J_per_m"], abs=1e-12 * wcyl)
    # beta2 = 0.6 removes energy: the residual is the (negative) algorithmic dissipation
    assert stated["balance_residual_J_per_m"] < 0.0


def test_energy_figure_draws_every_term_and_the_residual(run):
    from stickslip.postprocess.energy_balance import energy_terms
    from stickslip.postprocess.plotting import energy_figure

    fig = energy_figure(run)
    stored, flows = fig.axes
    labels = [ln.get_label() for ln in stored.lines + flows.lines]
    for word in ("kinetic", "strain", "cylinder", "frictional", "impact", "viscous",
                 "algorithmic", "residual"):
        assert any(word in lab for lab in labels), word
    terms = energy_terms(run.samples["energies"])
    # the drawn residual curve ends at the summary's stated residual
    (res,) = [ln for ln in flows.lines if ln.get_label().startswith("residual")]
    assert res.get_ydata()[-1] == pytest.approx(run.summary["energy"]["balance_residual_J_per_m"],
                                                rel=1e-9)
    assert np.array_equal(res.get_ydata(), terms["residual"])
    _close(fig)


# ------------------------------------------------------------------------ iso-map


def test_isomap_shows_u_minus_d_and_the_steady_state_vanishes():
    """The plane-strain Lamé and torsion fields of a tube clamped at ξR (the steady sliding
    state's axisymmetric part) give no wave displacement: the map shows u_r − d, not d."""
    from stickslip.postprocess.isomap import wave_displacement

    R, xi, d, ut = 1.0, 1.25, 4e-4, 3e-3
    rng = np.random.default_rng(0)
    r = rng.uniform(R, xi * R, 200)
    r[:10] = R
    th = rng.uniform(0, 2 * np.pi, 200)
    pts = np.column_stack([r * np.cos(th), r * np.sin(th), np.zeros_like(r)])
    b2 = (xi * R) ** 2
    w = (r - b2 / r) / (R - b2 / R)
    er = np.column_stack([np.cos(th), np.sin(th)])
    et = np.column_stack([-np.sin(th), np.cos(th)])
    u = (d * w)[:, None] * er + (ut * w)[:, None] * et
    disp, ur = wave_displacement(pts, u, R, xi, d)
    assert np.abs(disp).max() < 1e-15 and np.abs(ur).max() < 1e-15  # round-off of d, ut
    # a wave on top: u_r − d on the contact circle is the wave's radial part
    bump = 1e-3 * np.cos(4 * th)
    _, ur = wave_displacement(pts, u + bump[:, None] * er, R, xi, d)
    assert np.allclose(ur[:10], bump[:10], rtol=0, atol=1e-15)


def test_isomap_contact_nodes_sit_on_the_cylinder(run_dir, run):
    from stickslip.postprocess.isomap import _panel, wave_displacement

    with np.load(run_dir / "final_field.npz") as ff:
        pts, u = ff["points"], ff["u"]
    geo = run.scene["geometry"]
    _, ur = wave_displacement(pts, u, run.radius, geo["xi"], run.d)
    from stickslip.postprocess.analysis import load_run

    panel = _panel(run_dir, load_run)
    ring = panel["ring"]
    assert ring.size == run.scene["mesh"]["n_inner"]
    gap = ur[ring]
    # contact (stick, slip) nodes are on the cylinder to round-off of d; separated ones off it
    assert gap.min() >= -1e-12 * run.d
    assert (gap > 1e-9).any()


# ------------------------------------------------------------------------ one look, true titles


def test_one_colour_code_and_true_titles_in_every_run_figure(run_dir, run, monkeypatch):
    """Every figure of ``plot_run`` is drawn (the iso-map where Xvfb or a display exists);
    zones and status maps use the one colour code of postprocess.style, and every title names
    the run's own scene (not another figure's). The reduced-model overlay (seconds of root
    finding, tested with the reduced model) is left out."""
    import matplotlib.colors as mc
    import matplotlib.pyplot as plt

    from stickslip.postprocess import plotting
    from stickslip.postprocess.style import STATUS_COLORS, STATUS_LABELS

    monkeypatch.setattr(plotting, "reduced_curves", lambda *args, **kwargs: [])
    if not (shutil.which("Xvfb") or os.environ.get("DISPLAY")):
        (run_dir / "final_field.npz").rename(run_dir / "final_field.hidden.npz")

    code = [mc.to_rgb(c) for c in STATUS_COLORS]
    fig = plotting.spacetime_figure(run)
    status_map = fig.axes[1].collections[0]
    assert [mc.to_rgb(status_map.cmap(status_map.norm(k))) for k in range(3)] == code
    _close(fig)
    fig = plotting.profile_figure(run)
    spans = {p.get_label(): mc.to_rgb(p.get_facecolor()) for p in fig.axes[0].patches
             if p.get_label() in STATUS_LABELS}
    assert spans and all(spans[lab] == code[STATUS_LABELS.index(lab)] for lab in spans)
    assert fig.axes[0].get_ylabel() == "displacement (mm)"
    _close(fig)
    paths = plotting.plot_run(run_dir, window="4ms")
    names = {p.name for p in paths}
    assert {"spacetime.png", "profile.png", "phase.png", "energy.png", "uvpq.png"} <= names
    assert ("isomap.png" in names) == (run_dir / "final_field.npz").exists()
    assert ("stress.png" in names) == (run_dir / "final_field.npz").exists()
    assert all(p.stat().st_size > 10_000 for p in paths)
    for fig_fn in (plotting.spacetime_figure, plotting.phase_figure, plotting.energy_figure):
        fig = fig_fn(run)
        assert fig._suptitle.get_text().startswith("smoke: Ω = 50 rad/s, δ = 0.0004, f = 0.7")
        assert "Figure-1" not in fig._suptitle.get_text()
        plt.close(fig)


def test_reduced_model_wave_uses_the_same_colours(tmp_path):
    """wave.png (``stickslip wave --plot``) shades its zones with the project's code."""
    import matplotlib.colors as mc

    from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
    from stickslip.semianalytic.waves import find_waves

    co = coefficients(0.3, 1.25, gamma_from_physical(1000.0, 1.0, 1.0))
    waves = find_waves(co, 0.7, 4, 4e-4, regime="stick-slip")
    assert waves
    seen = []

    import matplotlib.axes

    original = matplotlib.axes.Axes.axvspan

    def spy(self, *args, **kwargs):
        seen.append(mc.to_rgb(kwargs["color"]))
        return original(self, *args, **kwargs)

    from stickslip.postprocess.style import STATUS_COLORS
    from stickslip.semianalytic.plotting import plot_wave

    matplotlib.axes.Axes.axvspan = spy
    try:
        plot_wave(waves[0], str(tmp_path / "wave.png"), zone_colours=STATUS_COLORS)
    finally:
        matplotlib.axes.Axes.axvspan = original
    assert seen and set(seen) <= {mc.to_rgb(c) for c in STATUS_COLORS}


def test_plot_command_refuses_a_bad_window(run_dir, capsys):
    from stickslip.cli.main import main

    with pytest.raises(SystemExit) as exc:
        main(["plot", str(run_dir), "--window", "five"])
    assert exc.value.code == 2
    assert "number of periods (5T)" in capsys.readouterr().err
    assert json.loads((run_dir / "summary.json").read_text())["status"] == "completed"


def test_travel_profiles_use_the_same_colours_and_units(tmp_path, monkeypatch):
    """``stickslip travel --plot``'s profiles: zones in the one colour code, mm and MPa."""
    import matplotlib.colors as mc
    import matplotlib.pyplot as plt

    from stickslip.postprocess.style import STATUS_COLORS, STATUS_LABELS
    from stickslip.studies.travel.output import plot_profiles

    phi = np.linspace(0.0, np.pi / 2, 40, endpoint=False)
    status = np.repeat([0, 1, 2, 1], 10)
    prof = {"phi": phi, "status": status, "U": 1e-3 * np.sin(4 * phi) ** 2,
            "V": 1e-3 * np.cos(4 * phi), "P": 1e8 + 1e6 * np.sin(phi), "Q": 7e5 * phi}
    summary = {"regime": "stick-slip-separation", "k": 4, "celerity_m_s": -2507.0,
               "psi1_subnode": 0.69, "psi2_subnode": 0.85}
    kept = []
    monkeypatch.setattr(plt, "close", lambda fig: kept.append(fig))
    plot_profiles(tmp_path, prof, summary)
    (fig,) = kept
    code = {lab: mc.to_rgb(c) for lab, c in zip(STATUS_LABELS, STATUS_COLORS, strict=True)}
    spans = [(p.get_label(), mc.to_rgb(p.get_facecolor())) for p in fig.axes[0].patches]
    assert {lab for lab, _ in spans if lab in code} == set(STATUS_LABELS)
    assert all(rgb == code[lab] for lab, rgb in spans if lab in code)
    assert [ax.get_ylabel() for ax in fig.axes] == ["u_r − d (mm)", "u_θ (mm)", "p (MPa)",
                                                    "q (MPa)"]
    # p in MPa without an offset: 1e8 Pa reads as 100 MPa
    assert fig.axes[2].lines[0].get_ydata().max() == pytest.approx(101.0, rel=1e-3)
    monkeypatch.undo()
    plt.close(fig)
