"""The travelling wave that a run computes: the transient's own discrete wave at the run's step.

``stickslip travel SCENE --from RUN`` and ``wave_from_run(RUN)`` (the attractor census's entry
point) solve, from a finished ``stickslip run`` directory, the wave that the run's explicit
scheme (β₂ = 1/2, lumped mass, Kelvin–Voigt τ) carries on the run's own mesh and time step:

* **rigid end state.** A rigid travelling wave u(θ, t) = W(θ − ωt) is stationary in its own
  frame. The run's inner-circle samples over its analysis window, each turned back by
  ω(t − t_end) (an exact Fourier shift), are compared with their mean: the *frame spread*
  is the RMS deviation over the RMS of the mean (axisymmetric part excluded), u_r and u_θ
  together (a stick-slip wave has u_r = d everywhere: its u_r part alone is noise). Below
  ``RIGID_TOLERANCE`` the end state is a rigid wave; above it (a
  modulated cycle, two waves, a wave still growing) there is no travelling wave to solve,
  and ``NotRigidWave`` says so with the spread.
* **the matched step.** The wave passes one mesh node every τ = Δφ/|ω| (Δφ = 2π/N, the node
  passage). The central-scheme frame with S points per node solves the transient's discrete
  wave at the step h = τ/S (``studies.travel.frame``, "Central scheme"), so S = round(τ/Δt)
  (at least 1) makes h the run's Δt up to the rounding of S: |h/Δt − 1| ≤ 1/(2S). Where
  τ < Δt the wave crosses more than one node per step; S = 1 (h = τ < Δt) is then the
  closest discrete wave, and the run itself is far from converged in Δt: the result says so
  (``message``) with the change of the wave when h is halved (S = 2), the size of the run's
  own Δt error.
* **the Δt → 0 wave** (``dt_limit``): the waves at S, 2S, 4S (h halved twice, nested starts)
  extrapolated in h with their observed order p, c₀ = c₄ₛ + (c₄ₛ − c₂ₛ)/(2ᵖ − 1) (and the
  same for the amplitude and ψ); what the transient on this mesh tends to as Δt → 0.

Starts: the run's every-step probe history over its last wave period (``driver.
probe_history``), then its last sample; if the free-ω Newton fails from both, the fixed-ω
wave nearest the run's speed (``driver.solve_scene``, steps of 0.25 % up to ±5 %) starts it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import stickslip.studies.travel.driver as D
from stickslip.postprocess.analysis import analyse, analyse_run, load_run
from stickslip.solver.errors import Diverged
from stickslip.solver.run import Simulation
from stickslip.solver.scene import load_scene, require_plane_strain
from stickslip.solver.schemes import time_step
from stickslip.studies.travel.newton import NotConverged

__all__ = ["RIGID_TOLERANCE", "NotRigidWave", "RunEndState", "frame_spread", "matched_samples",
           "read_end_state", "solve_matched", "wave_from_run", "dt_limit_wave",
           "wave_stability", "transient_next_to", "compare_with_run", "scene_time_step",
           "dt_limit_scene"]

#: Largest frame spread of a rigid travelling wave. A run started exactly on a solved discrete
#: wave (``FrameOperators.shift_state``) measures 0 where each sample lies a whole number of
#: node passages after the last, and up to 0.04 otherwise (k = 12, S = 2: the nodes hold the
#: profile's history between node passages, which a Fourier shift only approximates); the
#: modulated end states of the benchmark's runs measure 0.16 and more
#: (benchmarks/travel_from_runs.py, docs/travelling_waves.md).
RIGID_TOLERANCE = 0.1


class NotRigidWave(ValueError):
    """The run's end state is not a rigidly travelling wave (one line naming the spread)."""


@dataclass
class RunEndState:
    """What a run directory says about its end state (module doc)."""

    path: Path
    scene: object  # solver.scene.Scene
    summary: dict
    samples: dict
    data: object  # postprocess.analysis.RunData (scene table, summary, samples)
    k: int
    omega: float  # measured angular speed of the wave, rad/s
    dt: float  # the run's time step, s
    spread: float  # frame spread

    @property
    def node_passage(self) -> float:
        """τ = Δφ_e/|ω| (s): the time the wave takes to pass one contact edge, Δφ_e = 2π/E
        the mesh's symmetry step (E = N/degree edges: one node on P1, a vertex and a mid-edge
        node on P2; ``studies.travel.frame``, "Tracks")."""
        edges = self.samples["theta"].size // int(self.scene.mesh.degree)
        return 2.0 * math.pi / (edges * abs(self.omega))


def frame_spread(samples: dict, omega: float, window_s: float, degree: int = 1
                 ) -> tuple[float, float]:
    """(spread, ω*): the frame spread of the samples over the last ``window_s`` (module doc)
    in the frame turning at ω*, over the harmonics |m| ≤ E/2 that the mesh's symmetry group
    Z_E carries as travelling ones (E = N/``degree`` contact edges): on a P2 circle a wave's
    harmonic m comes with its aliases m ± E (the vertex and mid-edge nodes hold different
    values), which a Fourier shift by less than one edge does not turn with it. The
    measured ω carries an error δω that turns the frame by
    kδω·window over the window (at k = 12, 900 m/s and 1e-4 relative error, 0.1 rad over
    0.1 s: a spread of ~0.05 on a rigid wave), so ω* is fitted: in the frame of ``omega`` the
    dominant harmonic m of the samples turns at the rate m(ω − ω*), whose least-squares slope
    of the unwrapped phase gives ω*. The smaller of the spreads at ω and ω* is returned."""
    order = np.argsort(samples["theta"])
    n = order.size
    t = samples["t"]
    sel = t >= t[-1] - window_s
    lag = t[sel] - t[-1]
    m = np.fft.rfftfreq(n, 1.0 / n)
    spectra = []
    for comp in ("u_r", "u_theta"):
        F = np.fft.rfft(samples[comp][sel][:, order], axis=1)
        F[:, 0] = 0.0  # the axisymmetric part (steady sliding) is excluded
        F[:, m > n / (2 * degree)] = 0.0  # the aliases of a P2 circle (docstring)
        spectra.append(F)

    def spread(om: float) -> float:
        """Both components together (as the census's ``frame_spread``): a stick-slip wave
        has u_r = d at every node, so its u_r part alone is round-off over round-off."""
        dev = mean_sq = 0.0
        turn = np.exp(1j * om * np.outer(lag, m))
        for F in spectra:  # Parseval: the spread in Fourier space
            back = F * turn
            mean = back.mean(axis=0)
            dev += float(np.sum(np.abs(back - mean) ** 2)) / back.shape[0]
            mean_sq += float(np.sum(np.abs(mean) ** 2))
        return math.sqrt(dev / max(mean_sq, 1e-300))

    F = spectra[1]
    dom = int(np.argmax(np.mean(np.abs(F) ** 2, axis=0)))
    best = omega
    if dom > 0 and lag.size > 2:
        phase = np.unwrap(np.angle(F[:, dom] * np.exp(1j * omega * dom * lag)))
        best = omega - float(np.polyfit(lag, phase, 1)[0]) / dom
    return min((spread(omega), omega), (spread(best), best))


def matched_samples(node_passage: float, dt: float) -> int:
    """S = round(τ/Δt), at least 1 (module doc)."""
    if not (node_passage > 0.0 and dt > 0.0):
        raise ValueError(f"node passage {node_passage} s and dt {dt} s must be > 0")
    return max(1, int(round(node_passage / dt)))


def read_end_state(run_dir: Path, tolerance: float | None = None,
                   window: float | None = None) -> RunEndState:
    """The run's wave (k, ω, Δt, frame spread); ``NotRigidWave`` if it is not a rigid
    travelling wave, ``ValueError`` if the directory is not a finished run.

    The frame spread is measured over the last ``window`` seconds (default: the run's analysis
    window, its last third). A run continued well past its settling (a census's extended
    start) gives the census's own window, so that the spread does not reach back into the
    transient before it settled."""
    tolerance = RIGID_TOLERANCE if tolerance is None else tolerance
    run_dir = Path(run_dir)
    for name in ("samples.npz", "summary.json", "scene.toml"):
        if not (run_dir / name).is_file():
            raise ValueError(f"{run_dir}: no {name} (not a finished `stickslip run` directory)")
    run = load_run(run_dir)
    summ = run.summary
    if summ.get("status") not in (None, "completed"):
        raise NotRigidWave(f"{run_dir}: the run is {summ.get('status')} "
                           f"({summ.get('stop_reason', '')}), no settled end state")
    wave = analyse_run(run)
    if wave.angular_speed_rad_s == 0.0 or wave.regime == "steady-sliding":
        raise NotRigidWave(f"{run_dir}: the run ended in steady sliding (no travelling wave)")
    if window is None:
        window = float(summ.get("analysis_window_s") or (run.samples["t"][-1] / 3.0))
    scene = load_scene(str(run_dir / "scene.toml"))
    require_plane_strain(scene)  # SceneError, one line: the wave frame is the circle's
    spread, _ = frame_spread(run.samples, wave.angular_speed_rad_s, window,
                             int(scene.mesh.degree))
    if not spread < tolerance:
        raise NotRigidWave(
            f"{run_dir}: the end state is not a rigidly travelling wave: frame spread "
            f"{spread:.3f} over the last {window:.3g} s (rigid below {tolerance}); a modulated "
            "cycle has no wave-frame solution")
    dt = float(summ.get("dt_s") or 0.0)
    if dt <= 0.0:
        t = run.samples["probe_t"]
        dt = float(t[1] - t[0])
    return RunEndState(run_dir, scene, summ, run.samples, run, int(wave.mode),
                       float(wave.angular_speed_rad_s), dt, spread)


def scene_time_step(scene, problem=None) -> float:
    """The Δt that ``stickslip run`` uses for ``scene`` (``solver.schemes.time_step``)."""
    from mpi4py import MPI

    # dolfinx on first use: `stickslip travel` imports it first, without numba
    from stickslip.solver.problem import build_problem, omega_max

    return time_step(scene, omega_max(problem or build_problem(scene, MPI.COMM_SELF)))[0]


def _setup(end: RunEndState, samples: int):
    return D.setup(end.scene, float(end.scene.damping.tau), rate="bdf1", inertia="shift",
                   samples=samples, time_scheme="central")


def solve_matched(end: RunEndState, samples: int | None = None, max_iter: int = 40):
    """(Setup, TravelSolution, start) of the central-scheme wave at S = ``samples`` (default:
    the matched S) from the run (module doc: probe history, then last sample).
    Raises ``newton.NotConverged`` when both starts fail."""
    s = samples or matched_samples(end.node_passage, end.dt)
    st = _setup(end, s)
    W_hist, om0, info = D.start_from_run(end.path, st, end.data)
    starts = [(W_hist, info["start"])]
    if info["start"] == "run (probe history)":
        s_ = end.samples
        o = np.argsort(s_["theta"])
        W_last = np.concatenate([s_["u_r"][-1][o], s_["u_theta"][-1][o]])
        starts.append((D.prolong(W_last, st.ops.n) if s > 1 else W_last,
                       "run (last sample)"))
    first: NotConverged | None = None
    for W0, how in starts:
        try:
            return st, D.solve_free(st, end.k, W0, om0, max_iter=max_iter), how
        except NotConverged as err:
            first = first or err
    try:  # the fixed-ω wave nearest the run's speed, then free ω from it
        fixed = D.solve_scene(st, end.k, starts[0][0], om0, free_omega=False, max_iter=max_iter)
        sol = D.solve_free(st, end.k, np.r_[fixed.W_r, fixed.W_t], fixed.omega,
                           max_iter=max_iter)
        return st, sol, starts[0][1] + ", via the fixed-speed wave"
    except NotConverged:
        raise first from None


def _values(summary: dict) -> dict:
    """The compared keys of a run's or a wave's summary."""
    return {"k": summary.get("mode"), "direction": summary.get("direction"),
            "regime": summary.get("regime"), "celerity_m_s": summary.get("celerity_m_s"),
            "frequency_hz": summary.get("frequency_hz"),
            "fractions": summary.get("fractions"), "psi1": summary.get("psi1"),
            "psi2": summary.get("psi2"), "amplitude_m": summary.get("amplitude_m")}


def difference(wave: dict, run: dict, steps_per_period: float | None = None) -> dict:
    """Celerity and amplitude relative, fractions and ψ absolute (largest over the keys);
    with ``steps_per_period`` (N·S/k, the wave's time steps per period) also the fractions
    in steps (``fractions_steps``): a node's status changes only at a step, so the fractions
    of the run and of the discrete wave are resolved to one step of the period."""
    fr = max(abs(wave["fractions"][z] - run["fractions"][z])
             for z in ("separation", "stick", "slip"))
    psi = max(abs(wave[p] - run[p]) for p in ("psi1", "psi2")
              if wave.get(p) is not None and run.get(p) is not None) if (
        wave.get("psi1") is not None and run.get("psi1") is not None) else None
    return {"celerity_rel": wave["celerity_m_s"] / run["celerity_m_s"] - 1.0,
            "fractions_abs": fr, "psi_abs": psi,
            "fractions_steps": None if steps_per_period is None else fr * steps_per_period,
            "amplitude_rel": wave["amplitude_m"] / run["amplitude_m"] - 1.0}


def wave_from_run(run_dir: Path, *, dt_limit: bool = False, window: float | None = None) -> dict:
    """The transient's own discrete wave at the run's step, from a finished run (module doc).

    Returns a dict: converged, message, residual, k, direction, regime, celerity_m_s,
    frequency_hz, fractions, psi1, psi2, amplitude_m, node_passage_s, dt_s, samples (S),
    frame_spread, run (the run's values of the same keys), difference (``difference``),
    cpu_s; with ``dt_limit``, ``dt_limit`` (the Δt → 0 wave, ``dt_limit_wave``; None, with
    ``dt_limit_message``, where a finer level has no wave: the free-ω Newton stagnates with an
    inequality violated, and the wave at the run's step stands). ``window``: the end state's
    window, as in ``read_end_state``. Raises ``NotRigidWave`` when the run's end state is not
    a rigidly travelling wave, ``ValueError`` when the directory is not a finished run."""
    t0 = time.process_time()
    end = read_end_state(Path(run_dir), window=window)
    s = matched_samples(end.node_passage, end.dt)
    out: dict = {"k": end.k, "node_passage_s": end.node_passage, "dt_s": end.dt,
                 "samples": s, "frame_spread": end.spread, "run": _values(end.summary)}
    try:
        st, sol, start = solve_matched(end, s)
    except NotConverged as err:
        out.update(converged=False, residual=err.info.get("residual"),
                   message=f"no wave at S = {s} from {end.path}: {err}",
                   cpu_s=time.process_time() - t0)
        return out
    summary, _ = D.measure(st, sol, end.k)
    out.update(_values(summary), converged=True, residual=sol.residual, start=start,
               psi1_subnode=summary["psi1_subnode"], psi2_subnode=summary["psi2_subnode"],
               **compare_with_run(end, st, sol, summary))
    if dt_limit:
        try:
            out["dt_limit"] = dt_limit_wave(end, s, np.r_[sol.W_r, sol.W_t], sol.omega)
        except NotConverged as err:  # no wave at 2S or 4S: the wave at S stands without it
            out["dt_limit"] = None
            out["dt_limit_message"] = f"NotConverged: {err}"
    out["cpu_s"] = time.process_time() - t0
    return out


def compare_with_run(end: RunEndState, st, sol, summary: dict) -> dict:
    """The wave (``driver.measure``'s ``summary``) against the run: run (its values),
    difference, step_s, and a one-line message; where τ < Δt the message also gives the
    change of the wave when h is halved (the size of the run's own Δt error)."""
    run = _values(end.summary)
    h, s = st.ops.step(sol.omega), st.ops.samples
    d = difference(_values(summary), run, st.ops.n / end.k)
    out = {"run": run, "difference": d, "step_s": h, "node_passage_s": end.node_passage,
           "dt_s": end.dt, "samples": s, "frame_spread": end.spread}
    text = (f"k = {end.k} wave at S = {s} (h = {h:.3g} s, run dt = {end.dt:.3g} s): "
            f"celerity {d['celerity_rel']:+.2%}, amplitude {d['amplitude_rel']:+.2%}, "
            f"fractions {d['fractions_abs']:.3f} ({d['fractions_steps']:.1f} steps of the "
            "period) from the run")
    if end.node_passage < end.dt:
        half = _halved_step_change(end, st, sol)
        out["halved_step_celerity_rel"] = half
        text += (f"; the wave crosses {end.dt / end.node_passage:.2f} nodes per step (node "
                 f"passage {end.node_passage:.3g} s < dt {end.dt:.3g} s), so the run is far "
                 "from converged in dt: halving the step moves the wave by "
                 + (f"{half:+.2%}" if half is not None else "(no wave at 2S)")
                 + " in celerity; the dt -> 0 wave: --dt-limit")
    out["message"] = text
    return out


def _halved_step_change(end: RunEndState, st, sol) -> float | None:
    """Relative celerity change of the wave from S = 1 to S = 2 (h halved), or None."""
    fine = _setup(end, 2 * st.ops.samples)
    try:
        w2 = D.solve_free(fine, end.k, D.prolong(np.r_[sol.W_r, sol.W_t], fine.ops.n),
                          sol.omega, max_iter=40)
    except NotConverged:
        return None
    return sol.omega / w2.omega - 1.0


def dt_limit_wave(end: RunEndState, s: int, W: np.ndarray, omega: float) -> dict:
    """The Δt → 0 wave on the run's mesh from its wave at S (``_extrapolate``) and the run's
    celerity relative to it (``run_dt_error``: the run's own Δt error)."""
    lim = _extrapolate(lambda ss: _setup(end, ss), end.k, s, W, omega)
    lim["run_dt_error"] = end.summary["celerity_m_s"] / lim["celerity_m_s"] - 1.0
    return lim


def dt_limit_scene(st, k: int, W: np.ndarray, omega: float) -> dict:
    """The Δt → 0 wave of the setup ``st`` (central scheme, S points per node) from its wave
    (W, ω) (``_extrapolate``); ``run_dt_error`` None (no run)."""
    def setup(ss: int):
        return D.setup(st.scene, st.ops.tau, rate="bdf1", inertia="shift", samples=ss,
                       time_scheme="central", problem=st.ops.problem)

    return _extrapolate(setup, k, st.ops.samples, W, omega) | {"run_dt_error": None}


def _extrapolate(setup, k: int, s: int, W: np.ndarray, omega: float) -> dict:
    """Waves at S, 2S, 4S (h halved twice, each started from the last one prolonged: nested),
    extrapolated in h with the observed order p = log₂((c_S − c_2S)/(c_2S − c_4S)):
    x₀ = x_4S + (x_4S − x_2S)/(2ᵖ − 1) for the celerity, amplitude and sub-node ψ. Without an
    asymptotic range (ratio ≤ 1) the finest level is returned and ``order`` is None.
    ``setup(S)`` builds the central-scheme frame with S points per node."""
    levels = []
    for j, ss in enumerate((s, 2 * s, 4 * s)):
        st = setup(ss)
        if j:
            W = D.prolong(W, st.ops.n)
        sol = D.solve_free(st, k, W, omega, max_iter=40)
        W, omega = np.r_[sol.W_r, sol.W_t], sol.omega
        summ, _ = D.measure(st, sol, k)
        levels.append({"samples": ss, "celerity_m_s": summ["celerity_m_s"],
                       "amplitude_m": summ["amplitude_m"], "psi1": summ["psi1_subnode"],
                       "psi2": summ["psi2_subnode"]})
    c = [lv["celerity_m_s"] for lv in levels]
    ratio = (c[0] - c[1]) / (c[1] - c[2]) if c[1] != c[2] else 0.0
    order = math.log2(ratio) if ratio > 1.0 else None
    factor = 1.0 / (2.0**order - 1.0) if order else 0.0

    def extrapolate(key: str) -> float:
        return levels[2][key] + factor * (levels[2][key] - levels[1][key])

    lim = {key: extrapolate(key) for key in ("celerity_m_s", "amplitude_m", "psi1", "psi2")}
    lim.update(order=order, levels=levels)
    return lim


def wave_stability(run_dir: Path, *, end_time: float = 0.05, eps: float = 0.02,
                   window: float | None = None) -> dict:
    """Is the run's wave an attractor of the transient? ``transient_next_to`` the wave of
    ``wave_from_run`` (the matched step h = τ/S, S = round(τ/Δt)). Where that h exceeds the
    run's Δt_crit (S rounds down: h up to 1.5 Δt) a transient at h is unstable as a scheme,
    so the neighbouring discrete wave at S' = ceil(τ/Δt) (h ≤ Δt) is tested instead; the
    answer names it (``samples``); ``window`` as in ``read_end_state``."""
    end = read_end_state(Path(run_dir), window=window)
    s = matched_samples(end.node_passage, end.dt)
    st, sol, _ = solve_matched(end, s)
    if st.ops.step(sol.omega) > float(end.summary.get("dt_crit_s") or end.dt):
        s = math.ceil(end.node_passage / end.dt)
        st, sol, _ = solve_matched(end, s)
    return {**transient_next_to(st, sol, end.k, end_time=end_time, eps=eps), "samples": s}


def transient_next_to(st, sol, k: int, *, end_time: float = 0.05, eps: float = 0.02) -> dict:
    """The transient of ``st.scene`` started next to the central-scheme wave ``sol``: its
    whole-mesh state (``FrameOperators.shift_state``, a periodic orbit of the transient at
    dt = h) plus a radial bump eps·d·mean_m cos(mθ + 2πm/12), m = 1 … 12, run for
    ``end_time`` at dt = h; its last quarter (at least 8 samples) is analysed like a run.
    ``stable``: same k, celerity within 0.1 % and amplitude within 5 % of the wave (a wave
    the transient leaves drifts by more within a few periods); ``drift``: the last window's
    celerity and amplitude relative to the wave."""
    from mpi4py import MPI

    scene, ops = st.scene, st.ops
    d, R = scene.geometry.d, scene.geometry.R
    u, v, a = ops.shift_state(np.r_[sol.W_r, sol.W_t], sol.omega)
    modes = np.arange(1, 13)
    u = u + ops.problem.radial_field(
        lambda th: eps * d * np.cos(np.outer(th, modes) + 2.0 * math.pi * modes / 12.0).mean(1))
    h = float(ops.step(sol.omega))
    sample = min(scene.output.sample_interval, end_time / 32.0)
    run = scene.with_overrides(f"time.dt={h!r}", f"time.end_time={end_time!r}",
                               "time.dt_fraction=0.9", f"output.sample_interval={sample!r}",
                               "output.progress=false")
    sim = Simulation(run, MPI.COMM_SELF, initial_state=(u, v, a))
    if sim.proceed() == "diverged":  # a blow-up is no wave of the run
        raise Diverged(sim.message)
    rec = sim.recorder.arrays()
    t = rec["t"]
    window = max(end_time / 4.0, 8 * sample)
    sel = t >= t[-1] - window
    w = analyse(t[sel], rec["theta"], rec["u_r"][sel], rec["u_theta"][sel], rec["status"][sel],
                d=d, radius=R, window=window)
    summ, _ = D.measure(st, sol, k)
    drift = {"celerity_rel": (w.celerity_m_s / (sol.omega * R) - 1.0) if w.celerity_m_s
             else None,
             "amplitude_rel": w.amplitude_m / summ["amplitude_m"] - 1.0}
    stable = bool(sim.stop_reason == "end_time" and w.mode == k
                  and drift["celerity_rel"] is not None and abs(drift["celerity_rel"]) < 1e-3
                  and abs(drift["amplitude_rel"]) < 0.05)
    return {"stable": stable, "drift": drift, "k": k, "end_k": w.mode,
            "celerity_m_s": sol.omega * R, "end_celerity_m_s": w.celerity_m_s,
            "amplitude_m": summ["amplitude_m"], "end_amplitude_m": w.amplitude_m,
            "dt_s": h, "end_time_s": end_time, "eps": eps, "status": sim.stop_reason}
