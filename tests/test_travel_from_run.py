"""``stickslip travel --from RUN`` solves the wave the run computes (studies/travel/from_run.py).

One transient (~6 s): the damped Figure-3 scene (scenes/figure3_n132_damped.toml: Ω = 50 rad/s,
δ = 4e-4, f = 0.7, N = 132, β₂ = 1/2, η = 2 % at 1.6 kHz, dt = 0.9 dt_crit = 25.9 µs, mode-4
bump 0.1 d) to 0.3 s: it settles on a k = 12 stick-slip-separation wave at −892.3 m/s
against the rotation, node passage 53.3 µs = 2.06 dt, so the matched S is 2 (h = 26.7 µs).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from stickslip.cli.main import main


@pytest.fixture(scope="module")
def figure3_run(tmp_path_factory):
    run = tmp_path_factory.mktemp("from_run") / "run"
    assert main(["run", "scenes/figure3_n132_damped.toml", "-o", str(run)]) == 0
    return run


def test_wave_from_run_agrees_with_the_run(figure3_run):
    """The transient's own discrete wave at the matched step. Tolerances: the wave crosses
    less than one node per step, where the wave's step h differs from the run's dt only by
    the rounding of S (h/dt = 1.03 here), so the celerity agrees to 0.2 % (measured +0.03 %:
    −892.6 against −892.3 m/s); the amplitude to 2 % (measured −0.85 %); the zone fractions to
    2 steps of the period (a node's status changes only at a step: 22 steps per period here,
    so 2 steps = 0.09; measured 0.070, i.e. 1.5 steps)."""
    from stickslip.studies.travel import wave_from_run

    w = wave_from_run(figure3_run)
    assert w["converged"], w["message"]
    assert w["k"] == w["run"]["k"] == 12 and w["samples"] == 2
    assert w["regime"] == w["run"]["regime"] == "stick-slip-separation"
    assert w["direction"] == w["run"]["direction"]
    assert w["node_passage_s"] > w["dt_s"]
    d = w["difference"]
    assert abs(d["celerity_rel"]) < 2e-3, w["message"]
    assert abs(d["amplitude_rel"]) < 0.02, w["message"]
    assert d["fractions_steps"] <= 2.0, w["message"]
    assert w["frame_spread"] < 0.1 and w["residual"] < 1e-10
    assert abs(w["frequency_hz"] - abs(w["celerity_m_s"]) * 12 / (2 * math.pi)) < 1e-6 * 1e3


def test_travel_from_run_defaults_to_the_runs_k_and_step(figure3_run, tmp_path, capsys):
    """No --k, no route flags: the run's k and the matched S, and a line against the run."""
    out = tmp_path / "w"
    assert main(["travel", str(figure3_run / "scene.toml"), "--from", str(figure3_run),
                 "-o", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["k"] == 12 and s["samples_per_node"] == 2 and s["time_scheme"] == "central"
    assert abs(s["from_run"]["difference"]["celerity_rel"]) < 2e-3
    assert "against the run: k = 12 wave at S = 2" in capsys.readouterr().out


def test_a_run_that_is_not_a_rigid_wave_is_refused_in_one_line(figure3_run, tmp_path,
                                                               monkeypatch, capsys):
    """With the rigid tolerance below the run's frame spread, the run counts as modulated:
    ``NotRigidWave`` (a ValueError) naming the spread, and the command exits 1 in one line."""
    import stickslip.studies.travel.from_run as F
    from stickslip.studies.travel import NotRigidWave

    with pytest.raises(NotRigidWave, match="frame spread") as err:
        F.read_end_state(figure3_run, tolerance=1e-6)
    assert isinstance(err.value, ValueError) and "\n" not in str(err.value)
    monkeypatch.setattr(F, "RIGID_TOLERANCE", 1e-6)
    rc = main(["travel", str(figure3_run / "scene.toml"), "--from", str(figure3_run),
               "-o", str(tmp_path / "x")])
    msg = capsys.readouterr().err.strip()
    assert rc == 1 and "frame spread" in msg and len(msg.splitlines()) == 1


def test_end_state_window_is_the_callers(figure3_run):
    """A census reads an extended start over its own window W, not the run's last third (a
    long run's third reaches back into the transient). The spread over W is the one that
    ``frame_spread`` gives over the last W s of the samples, to round-off (same arithmetic),
    and it differs from the spread over the default window (the wave still settles)."""
    import stickslip.studies.travel.from_run as F
    from stickslip.postprocess.analysis import load_run

    default = F.read_end_state(figure3_run)
    w = 0.03  # s: about 40 periods of the k = 12 wave (1.4 kHz), a tenth of the run
    mine = F.read_end_state(figure3_run, window=w)
    spread, _ = F.frame_spread(load_run(figure3_run).samples, mine.omega, w)
    assert mine.spread == pytest.approx(spread, rel=1e-12, abs=1e-15)
    assert mine.spread != default.spread


def test_frame_spread_is_zero_for_a_rigid_wave_and_large_for_two_waves():
    """A rigidly turning profile sampled on 132 nodes has spread ~0 at its own speed (the
    Fourier shift is exact on a band-limited profile, and the search recovers ω from a start
    0.02 % off: measured 1e-6, the minimiser's ω tolerance of 1e-7 turning k = 24 by 1e-6
    rad over the window; asserted < 1e-4); adding a second mode-5 wave
    at another speed, 30 % of the first, gives a spread of 0.29 (its u_r part: the second wave's
    RMS over the first's), asserted above twice the rigid tolerance (0.1)."""
    from stickslip.studies.travel.from_run import RIGID_TOLERANCE, frame_spread

    theta = np.arange(132) * 2 * math.pi / 132
    t = np.arange(400) * 1e-4
    om = -900.0
    phase = theta[None, :] - om * t[:, None]
    rigid = {"theta": theta, "t": t, "u_r": np.cos(12 * phase) + 0.3 * np.cos(24 * phase),
             "u_theta": np.sin(12 * phase)}
    spread, best = frame_spread(rigid, om * 1.0002, 0.03)
    assert spread < 1e-4 and abs(best / om - 1.0) < 1e-6  # the minimiser's ω tolerance
    two = dict(rigid)
    two["u_r"] = rigid["u_r"] + 0.3 * np.cos(5 * (theta[None, :] - 1500.0 * t[:, None]))
    assert frame_spread(two, om, 0.03)[0] > 2 * RIGID_TOLERANCE


def test_the_runs_wave_is_stable_to_a_small_bump(figure3_run):
    """``wave_stability``: the transient started on the k = 12 wave (dt = h) plus a 0.02 d
    bump of the modes 1 … 12 keeps it over 0.05 s: same k, celerity within 0.1 % (measured
    0.017 %) and amplitude within 5 % (measured 0.4 %) of the wave, as the run itself did."""
    from stickslip.studies.travel import wave_stability

    s = wave_stability(figure3_run)
    assert s["stable"] and s["end_k"] == 12 and s["status"] == "end_time", s
    assert abs(s["drift"]["celerity_rel"]) < 1e-3 and abs(s["drift"]["amplitude_rel"]) < 0.05


def test_a_pseudo_arclength_step_lands_on_the_natural_branch(figure3_run):
    """``arclength_step`` from the waves at δ = 4e-4 and 4.5e-4 (the run's k = 12 wave at
    S = 2, one wavelength) along their secant: its λ is an unknown, so it lands about one
    secant further on (measured δ = 5.54e-4; the secant is measured in W/d, ω/ω₀, λ/λ₀, and W
    moves more than δ does); the natural-parameter Newton at that λ, started from the
    δ = 4.5e-4 wave, finds the same wave (ω to 1e-8 relative, W to 1e-6 d: both residuals
    are ≤ 1e-10 c·d)."""
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.arclength import arclength_step, phase_row_of, problem_at
    from stickslip.studies.travel.from_run import read_end_state, solve_matched
    from stickslip.studies.travel.newton import fold_state

    end = read_end_state(figure3_run)
    st, sol, _ = solve_matched(end)
    R = st.scene.geometry.R
    prob0 = D.folded(st, 12).prob
    x = [np.r_[fold_state(np.r_[sol.W_r, sol.W_t], 12), sol.omega, 4e-4]]
    st2 = D.retarget(st, st.scene.with_overrides("geometry.delta=4.5e-4"))
    w2 = D.solve_free(st2, 12, np.r_[sol.W_r, sol.W_t], sol.omega)
    x.append(np.r_[fold_state(np.r_[w2.W_r, w2.W_t], 12), w2.omega, 4.5e-4])
    n = prob0.n
    scale = np.r_[np.full(2 * n, prob0.d), abs(sol.omega), 4e-4]
    t = (x[1] - x[0]) / scale
    ds = float(np.linalg.norm(t))
    x3, w3 = arclength_step(lambda lam: problem_at(prob0, "geometry.delta", lam, R), 12, x[1],
                            t / ds, ds, scale, phase_row_of(x[1][n: 2 * n], prob0.theta, 12))
    lam = float(x3[-1])
    assert 4.6e-4 < lam < 6e-4 and w3.violated is None  # forward, about one secant on
    st3 = D.retarget(st, st.scene.with_overrides(f"geometry.delta={lam!r}"))
    ref = D.solve_free(st3, 12, np.r_[w2.W_r, w2.W_t], w2.omega)
    assert abs(ref.omega / w3.omega - 1.0) < 1e-8
    W_ref = fold_state(np.r_[ref.W_r, ref.W_t], 12)
    assert np.abs(W_ref - x3[: 2 * n]).max() < 1e-6 * st.scene.geometry.d


def test_the_dt_limit_wave_agrees_with_the_transients_dt_limit(figure3_run):
    """``dt_limit``: the waves at S = 2, 4, 8 extrapolated in h. The transients of this scene
    at Δt, Δt/2, Δt/4 (each started on the run's member; ``benchmarks/travel_dt_limit.py``)
    give −892.32, −882.58, −880.17 m/s, extrapolated (order 2.01) to −879.38 m/s, amplitude
    3.109 mm. The travel limit was measured at −879.11 m/s (0.03 %), 3.125 mm (0.5 %):
    asserted within 0.1 % and 2 % (the transients' own extrapolation moves by 0.2 m/s and
    0.04 mm between orders 1.8 and 2.0). The run's own Δt error is then +1.5 %."""
    from stickslip.studies.travel import wave_from_run

    lim = wave_from_run(figure3_run, dt_limit=True)["dt_limit"]
    assert [lv["samples"] for lv in lim["levels"]] == [2, 4, 8]
    assert abs(lim["celerity_m_s"] / -879.38 - 1.0) < 1e-3, lim
    assert abs(lim["amplitude_m"] / 3.109e-3 - 1.0) < 0.02, lim
    assert 0.01 < lim["run_dt_error"] < 0.02 and lim["order"] is not None


def test_a_beta2_wave_is_a_periodic_orbit_of_the_beta2_transient(figure3_run):
    """β₂ ≠ 1/2 (the paper's undamped scenes use 0.6): the frame's explicit step takes the
    scene's β₂ (``FrameOperators.step_factors``: a = (z − 1)²u/(h²D), D = 1 + (β₂ + 1/2)(z − 1)).
    The run's scene at β₂ = 0.6, its k = 12 wave at S = 2 solved from the run, and the β₂ = 0.6
    transient started on it (``shift_state``) at dt = h: after n steps node i holds W at
    point 2i − n·sign(ω), checked at every sample over 5 periods (~110 steps) to 1e-6 d (the
    β₂ = 1/2 counterpart in tests/test_travel_fe.py measures 5e-8 d; the same start built
    with β₂ = 1/2 in the symbol and in v, a ends 1.3 d off the orbit)."""
    from mpi4py import MPI

    from stickslip.solver.run import Simulation
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.from_run import read_end_state

    end = read_end_state(figure3_run)
    end.scene = end.scene.with_overrides("time.beta2=0.6")
    st = D.setup(end.scene, float(end.scene.damping.tau), rate="bdf1", inertia="shift",
                 samples=2, time_scheme="central")
    assert st.ops.beta2 == 0.6
    W0, om0, _ = D.start_from_run(end.path, st, end.data)
    wave = D.solve_free(st, 12, W0, om0)
    h = float(st.ops.step(wave.omega))
    period = float(2.0 * np.pi / (12 * abs(wave.omega)))
    scene = end.scene.with_overrides(f"time.dt={h!r}", f"time.end_time={5 * period!r}",
                                     f"output.sample_interval={3 * h!r}",
                                     "output.progress=false")
    W = np.r_[wave.W_r, wave.W_t]
    sim = Simulation(scene, MPI.COMM_SELF, initial_state=st.ops.shift_state(W, wave.omega))
    sim.proceed()
    rec = sim.recorder.arrays()
    order = np.argsort(rec["theta"])
    node = np.arange(st.ops.mesh_n) * 2
    worst = 0.0
    for t, ur, ut in zip(rec["t"], rec["u_r"], rec["u_theta"], strict=True):
        at = (node - int(round(t / h)) * int(np.sign(wave.omega))) % st.prob.n
        worst = max(worst, np.abs(ur[order] - wave.W_r[at]).max(),
                    np.abs(ut[order] - wave.W_t[at]).max())
    assert rec["t"].size > 30
    assert worst < 1e-6 * end.scene.geometry.d, worst


def test_without_a_run_the_step_is_the_one_stickslip_run_uses(tmp_path):
    """No --from: S = round(node passage / dt) with dt the scene's own (``stickslip run``'s:
    0.9 dt_crit) and the node passage of the start speed; the wave then converges on that
    route (damped Figure-1 physics at N = 36, start −2300 m/s: measured −2392.2 m/s, S = 1)."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel.from_run import matched_samples, scene_time_step

    out = tmp_path / "w"
    argv = ["scenes/figure1_n132_damped.toml", "--set", "mesh.n_inner=36"]
    assert main(["travel", *argv, "--k", "4", "--celerity", "-2300", "-o", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    dt = scene_time_step(load_scene(argv[0], ["mesh.n_inner=36"]))
    assert s["time_scheme"] == "central"
    assert s["samples_per_node"] == matched_samples(2 * math.pi / (36 * 2300.0), dt)
    assert s["inequalities"]["all_satisfied"] and s["mode"] == 4


def test_a_rigid_stick_slip_wave_has_a_small_frame_spread():
    """A stick-slip wave keeps u_r = d at every node: its u_r part is round-off over
    round-off, so the spread takes both components together (a wave travelling in u_theta
    only, with 1e-18 m noise on u_r, measures ~1e-14, far below the 0.1 tolerance)."""
    from stickslip.studies.travel.from_run import RIGID_TOLERANCE, frame_spread

    n, steps, om = 72, 200, 300.0
    theta = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    t = np.linspace(0.0, 0.02, steps)
    noise = 1e-18 * np.random.default_rng(0).normal(size=(steps, n))
    samples = {"t": t, "theta": theta, "u_r": 1e-3 + noise,
               "u_theta": 1e-4 * np.cos(6 * (theta[None, :] - om * t[:, None])) + 2e-5}
    spread, _ = frame_spread(samples, om, 0.01)
    assert spread < 1e-6 * RIGID_TOLERANCE


@pytest.mark.parallel
def test_the_wave_frame_solver_runs_on_one_rank_of_many():
    """A census under ``mpirun`` certifies its members on rank 0 only: the wave-frame solver
    builds its own mesh on that rank (a mesh on every rank's communicator would wait for the
    others forever). Here rank 0 alone sets up the central-scheme frame of the smoke scene
    and finds the run's step, then every rank meets at the barrier."""
    pytest.importorskip("dolfinx")
    from mpi4py import MPI
    from petsc4py import PETSc  # noqa: F401  (PETSc and SLEPc start and end on every rank:
    from slepc4py import SLEPc  # noqa: F401  their start and end are collective, as in a census)

    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver
    from stickslip.studies.travel.from_run import scene_time_step

    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        scene = load_scene("scenes/smoke.toml", [])
        st = driver.setup(scene, 0.0, rate="bdf1", inertia="shift", samples=1,
                          time_scheme="central")
        assert st.ops is not None and scene_time_step(scene) > 0.0
    comm.Barrier()
