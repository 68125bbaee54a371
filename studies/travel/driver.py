"""One travelling wave of a scene on its FE mesh: start, solve, measure (``stickslip travel``).

Starts (``start``):

* ``run``: a transient run directory (``--from``): the last inner-circle sample is the wave
  (in polar components it is W(θ − ωt_end), a rotation of the same wave) and the measured
  angular speed of ``postprocess.analysis`` is ω₀;
* ``reduced``: the reduced model's travelling wave at the scene's ν, ξ, f, δ, Ω and k
  (``semianalytic.waves.find_waves``, admissible first), W = R(U, V)(θ), ω₀ = cΩ;
* ``guess``: built in: ``reduced`` if the reduced model has any wave at k, otherwise a
  mode-k stick-slip guess W_θ = 0.2 d cos kθ at the reduced flutter phase speed.

The measured summary uses ``postprocess.analysis.analyse`` on the exact space-time record of
the discrete wave (the nodal values shifted by one node every Δφ/|ω|), so every key means
what it means for ``stickslip run``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stickslip.postprocess.analysis import analyse, analyse_run, load_run
from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.flutter import flutter_modes
from stickslip.semianalytic.waves import find_waves
from stickslip.solver.scene import Scene
from stickslip.studies.reduced_transient import wave_fields
from stickslip.studies.travel.newton import (
    CircleProblem,
    NotConverged,
    TravelSolution,
    check_rate,
    fold_state,
    material_rate,
    nearest_wave,
    solve_wave,
    unfold,
    wave_band,
    zone_lengths,
)

__all__ = ["Setup", "band", "setup", "start_from_run", "start_from_reduced",
           "reduced_start",
           "probe_history", "prolong", "folded", "solve_free", "solve_scene", "measure",
           "member_amplitude"]

Array = NDArray[np.float64]


@dataclass
class Setup:
    """Scene, FE problem in the wave frame and the condensed contact problem."""

    scene: Scene
    ops: Any  # studies.travel.frame.FrameOperators
    prob: CircleProblem



def setup(scene: Scene, damping: float = 0.0, lumped: bool = False,
          rate: str = "bdf2", inertia: str = "rotation", samples: int = 1,
          time_scheme: str = "exact", problem=None) -> Setup:
    """Mesh, stiffness (``solver.problem``; or ``problem``, already built for ``scene``),
    travelling inertia (``lumped``: vertex rule,
    ``frame.frame_operators``; ``inertia="shift"``: the transient's own travelling operator,
    lumped M per discrete harmonic; ``samples``: contact points per node, ``time_scheme``:
    exact or central in time, both "shift" only) and the condensed problem (``rate``: the
    material-derivative scheme, ``newton.RATES``)."""
    from mpi4py import MPI

    # dolfinx on first use: `stickslip travel` imports it first, without numba
    from stickslip.solver.problem import build_problem

    # dolfinx on first use: `stickslip travel` imports it first, without numba
    from stickslip.studies.travel.frame import circle_problem, frame_operators

    check_rate(rate)
    # the wave-frame solver runs on one rank: its own mesh (a census calls it on rank 0 only)
    ops = frame_operators(problem or build_problem(scene, MPI.COMM_SELF), damping, lumped,
                          inertia, samples, time_scheme)
    return Setup(scene, ops, circle_problem(ops, rate=rate))


def retarget(st: Setup, scene: Scene) -> Setup:
    """Same mesh and material, new loading / mismatch (continuation in Ω, f, δ): no rebuild."""
    # dolfinx on first use: `stickslip travel` imports it first, without numba
    from stickslip.studies.travel.frame import circle_problem

    return Setup(scene, st.ops, circle_problem(st.ops, scene, rate=st.prob.rate))


def start_from_run(run_dir: Path, st: Setup, run=None) -> tuple[Array, float, dict]:
    """(W0, ω0, info) from a transient run directory's last sample (module doc); with sub-node
    samples, from its probe's every-step history (``probe_history``) where it has one.
    ``run``: the directory's ``postprocess.analysis.RunData`` if already loaded."""
    run = run if run is not None else load_run(run_dir)
    s = run.samples
    order = np.argsort(s["theta"])
    ops = st.ops
    nodes = ops.theta[:: ops.samples]
    if s["theta"].size != ops.mesh_n or not np.allclose(s["theta"][order], nodes):
        raise ValueError(f"--from {run_dir}: its contact nodes differ from the scene's mesh "
                         f"({s['theta'].size} vs {ops.mesh_n}); use the run's own scene")
    wave = analyse_run(run)
    if wave.angular_speed_rad_s == 0.0:
        raise ValueError(f"--from {run_dir}: the run ended in steady sliding (no wave to start "
                         "from); start from the reduced model instead")
    W0 = np.concatenate([s["u_r"][-1][order], s["u_theta"][-1][order]])
    omega = float(wave.angular_speed_rad_s)
    info = {"start": "run", "from": str(run_dir), "start_celerity_m_s": wave.celerity_m_s,
            "start_mode": wave.mode}
    if ops.samples > 1:
        history = probe_history(s, omega, wave.mode, ops.n)
        if history is not None:
            W0, info["start"] = history, "run (probe history)"
        else:  # node values to the sub-node points (linear in θ)
            W0, info["start"] = prolong(W0, ops.n), "run (last sample, prolonged)"
    return W0, omega, info


def probe_history(samples: dict, omega: float, k: int, points: int) -> Array | None:
    """W on ``points`` uniform points from the every-step history of the run's first probe
    over its last wave period 2π/(k|ω|), or None if the run has no probe or too short a
    history. A wave W(θ − ωt) passes a fixed node as W(θ_p − ωt), so the history read
    against the frame angle −ω(t − t_end) is the profile (turned by θ_p − ωt_end), sampled
    every |ω|Δt: finer than the nodes (``studies.travel.frame``, "Samples").
    Linear interpolation, periodic over one wavelength (the wave is k-periodic)."""
    if "probe_data" not in samples or samples["probe_data"].shape[0] == 0:
        return None
    t, x = samples["probe_t"], samples["probe_data"][0]
    length = 2.0 * math.pi / k
    if t.size < 8 or t[-1] - t[0] < length / abs(omega):
        return None
    sel = t >= t[-1] - 1.02 * length / abs(omega)
    if np.count_nonzero(sel) < 8:
        return None
    phase = np.mod(-omega * (t[sel] - t[-1]), length)
    at = np.mod(np.arange(points) * (2.0 * math.pi / points), length)
    return np.concatenate([np.interp(at, phase, x[sel, c], period=length) for c in (0, 1)])


def reduced_start(scene: Scene, k: int):
    """(the reduced model's first wave at k or None, ω0): the start of ``start_from_reduced``
    (module doc), before the frame is built (its speed sets the matched step)."""
    R, om = scene.geometry.R, scene.loading.omega
    co = coefficients(scene.material.nu, scene.geometry.xi,
                      gamma_from_physical(scene.material.wave_speed, R, om))
    waves = find_waves(co, scene.loading.f, k, scene.geometry.delta)
    if waves:
        return waves[0], waves[0].c * om
    return None, flutter_modes(co, scene.loading.f, kmax=k, kmin=k)[0].phase_speed * om


def start_from_reduced(st: Setup, k: int, start=None) -> tuple[Array, float, dict]:
    """(W0, ω0, info) from the reduced model's wave at k (module doc); ``start``: the result
    of ``reduced_start`` if already computed."""
    sc = st.scene
    R = sc.geometry.R
    w, om0 = start if start is not None else reduced_start(sc, k)
    theta = st.ops.theta
    if w is not None:
        ev = wave_fields(w, theta)
        W0 = R * np.concatenate([ev["U"], ev["V"]])
        return W0, om0, {"start": "reduced", "start_celerity_m_s": om0 * R,
                         "start_regime": w.regime, "start_admissible": w.admissible}
    d = sc.geometry.d
    W0 = np.concatenate([np.full(theta.size, d), 0.2 * d * np.cos(k * theta)])
    return W0, om0, {"start": "flutter", "start_celerity_m_s": om0 * R}


def prolong(W: Array, n_fine: int, how: str = "linear") -> Array:
    """A wave's contact-circle state W = (W_r, W_θ) on N uniform nodes θ_j = 2πj/N, carried
    to ``n_fine`` nodes (nested iteration: the converged wave of a coarse mesh starts the fine
    one; the Newton's unknown is W alone, the forces follow as λ = S(ω)W).

    Both components are periodic in φ. ``linear``: piecewise-linear interpolation on the
    circle (for n_fine = 2N the coarse values are kept and each midpoint is the mean of its
    neighbours; W_r ≥ d is preserved, the zone boundaries stay sharp). ``fourier``:
    trigonometric interpolation (zero-padded spectrum; Gibbs wiggles at the kinks of W_r at
    take-off and landing, so W_r may dip below d).
    """
    W = np.asarray(W, dtype=float)
    n = W.size // 2
    if W.size != 2 * n or n_fine < 2:
        raise ValueError(f"prolong: W has {W.size} values, need 2N (W_r, W_θ), n_fine ≥ 2")
    parts = W.reshape(2, n)
    if how == "fourier":
        from scipy.signal import resample

        return resample(parts, n_fine, axis=1).reshape(-1)
    if how != "linear":
        raise ValueError(f"prolong: how = {how!r}; use 'linear' or 'fourier'")
    x = np.arange(n_fine) * (n / n_fine)  # fine node positions in coarse node spacings
    j = np.floor(x).astype(np.intp)
    a = x - j
    return ((1.0 - a) * parts[:, j % n] + a * parts[:, (j + 1) % n]).reshape(-1)


def folded(st: Setup, k: int) -> Setup:
    """``st`` on one wavelength when k > 1 divides its contact points (the k-periodic waves,
    ``newton`` "Folding": S_k from the harmonics m ∈ kℤ), else ``st`` itself."""
    # dolfinx on first use: `stickslip travel` imports it first, without numba
    from stickslip.studies.travel.frame import circle_problem

    if k <= 1 or st.prob.period != 1 or st.prob.n % (k * st.prob.tracks):
        return st
    return Setup(st.scene, st.ops, circle_problem(st.ops, st.scene, st.prob.rate, period=k))


def solve_free(st: Setup, k: int, W0: Array, omega0: float, *, fold: bool = True,
               **kw) -> TravelSolution:
    """The free-ω Newton (``newton.solve_wave``, phase condition) from (W0, ω0), on one
    wavelength when ``fold`` and k divides the points (``folded``); the wave on the whole
    circle. Raises ``newton.NotConverged``."""
    prob = (folded(st, k) if fold else st).prob
    sol = solve_wave(prob, fold_state(W0, prob.period), omega0, k, **kw)
    sol.how = "free omega (phase condition)"
    return unfold(sol, prob.period)


def solve_scene(st: Setup, k: int, W0: Array, omega0: float, *, free_omega: bool = True,
                max_iter: int = 60, scan: float = 0.05, rel_step: float = 0.0025,
                fold: bool = True, **kw) -> TravelSolution:
    """Newton for (W, ω) with the phase condition; if it fails, the fixed-ω wave nearest to
    ω0 (``newton.nearest_wave``: ω0(1 ± j·rel_step) up to ±``scan``). ``sol.how`` says which.
    ``fold``: seek a k-periodic wave on one wavelength (``folded``; the start is the mean of
    its k copies), returned on the whole circle.

    The step is 0.25 %: at N = 132 the admissible bands of a wave family are ~0.5 % of the
    speed wide (docs/travelling_waves.md), so steps of 1 % jump over them."""
    first: NotConverged | None = None
    if free_omega:
        try:
            return solve_free(st, k, W0, omega0, fold=fold, max_iter=max_iter, **kw)
        except NotConverged as err:
            first = err
    prob = (folded(st, k) if fold else st).prob
    try:
        sol = nearest_wave(prob, fold_state(W0, prob.period), omega0, k, rel_step=rel_step,
                           max_steps=max(0, int(round(scan / rel_step))),
                           max_iter=min(max_iter, 30), **kw)
    except NotConverged as err:
        if first is not None:
            raise NotConverged(f"{first}; then {err}", err.info) from None
        raise
    sol.how = "fixed omega (nearest admissible speed to the start)"
    return unfold(sol, prob.period)


def measure(st: Setup, sol: TravelSolution, k: int) -> tuple[dict, dict[str, Array]]:
    """``stickslip run``-style summary (``postprocess.analysis.analyse``) and profiles."""
    sc, ops = st.scene, st.ops
    n, R, d = ops.n, sc.geometry.R, sc.geometry.d
    theta = ops.theta
    # one point per dt: the wave's exact space-time record (tracks interleaved points per
    # step on a P2 circle: each point is a further dt/tracks)
    dt = ops.step(sol.omega) / ops.tracks
    sign = 1 if sol.omega > 0 else -1
    shifts = np.arange(n)  # one full turn; at t_m the wave has moved m nodes
    idx = (np.arange(n)[None, :] - sign * shifts[:, None]) % n
    t = shifts * dt
    wave = analyse(t, theta, sol.W_r[idx], sol.W_t[idx], sol.status[idx], d=d, radius=R)
    z = zone_lengths(st.prob, sol)
    v_t = material_rate(sol.W_t, sol.omega, st.prob.rate, tracks=st.prob.tracks)
    v_r = material_rate(sol.W_r, sol.omega, st.prob.rate, tracks=st.prob.tracks)
    summary = {
        "status": "converged",
        "method": "travel (wave frame, semismooth Newton)",
        "regime": wave.regime, "mode": wave.mode, "k": k,
        "celerity_m_s": sol.omega * R, "angular_speed_rad_s": sol.omega,
        "celerity_measured_m_s": wave.celerity_m_s,
        "frequency_hz": abs(sol.omega) * k / (2.0 * math.pi),
        "fractions": wave.fractions, "amplitude_m": wave.amplitude_m,
        "amplitude_r_m": wave.amplitude_r_m, "amplitude_theta_m": wave.amplitude_theta_m,
        "psi1": wave.psi1, "psi2": wave.psi2,
        "psi1_subnode": z["separation"], "psi2_subnode": z["separation"] + z["stick"],
        "zone_order": wave.zone_order, "direction": wave.direction,
        "limit_cycle": True,
        "residual": sol.residual, "iterations": sol.iterations,
        "solve": getattr(sol, "how", ""),
        "residual_history": sol.residual_history,
        "inequalities": {"margins": sol.margins, "violated": sol.violated,
                         "all_satisfied": sol.violated is None},
        "contact_nodes": ops.mesh_n, "samples_per_node": ops.samples,
        "time_scheme": ops.time_scheme,
        "time_step_s": ops.step(sol.omega) if ops.time_scheme == "central" else None,
        "dofs": int(ops.problem.n_global_dofs),
        "rate": st.prob.rate,
    }
    ds = ops.ds_weight
    T = 2.0 * math.pi / k
    per = theta < T - 1e-12
    profiles = {
        "phi": theta[per], "U": (sol.W_r - d)[per], "V": sol.W_t[per],
        "U_dot": v_r[per], "V_dot": v_t[per], "P": (sol.p / ds)[per], "Q": (sol.q / ds)[per],
        "status": sol.status[per],
        "W_r": sol.W_r, "W_t": sol.W_t, "p_node": sol.p, "q_node": sol.q, "theta": theta,
        "status_all": sol.status, "omega": np.array(sol.omega),
    }
    return summary, profiles


def member_amplitude(st: Setup, sol: TravelSolution) -> float:
    """A band member's amplitude (m): the larger of the peak lift-off W_r − d and half the
    peak-to-peak tangential displacement W_θ (the band tables' measure; cheaper than
    ``measure``, which analyses the wave like ``stickslip run``)."""
    return float(max(sol.W_r.max() - st.prob.d, 0.5 * np.ptp(sol.W_t)))


def band(st: Setup, sol: TravelSolution, k: int) -> dict:
    """Speeds (m/s) over which the wave's family stays admissible, with ψ and amplitude ranges
    (``studies.travel.newton.wave_band``; the discrete waves are not isolated in ω)."""
    why: list = []
    lo, hi, members = wave_band(st.prob, sol, k, rel_step=0.002, max_steps=40, max_iter=30,
                                edge_reasons=why)
    R = st.scene.geometry.R
    zs = [zone_lengths(st.prob, m) for m in members]
    p1 = [z["separation"] for z in zs]
    p2 = [z["separation"] + z["stick"] for z in zs]
    amp = [member_amplitude(st, m) for m in members]
    # members in order of celerity (m/s): the selection question is where on this list the
    # transient's wave sits (archive/travel/travelling_waves_history.md, "selection")
    table = sorted(zip([m.omega * R for m in members], amp, p1, p2, strict=True))
    return {"celerity_m_s": [min(lo * R, hi * R), max(lo * R, hi * R)],
            "members": len(members),
            "psi1": [min(p1), max(p1)], "psi2": [min(p2), max(p2)],
            "amplitude_m": [min(amp), max(amp)],
            "edge_violated": why,  # [lower c edge, upper c edge]
            "member_table": [[round(v, 6) for v in row] for row in table]}
