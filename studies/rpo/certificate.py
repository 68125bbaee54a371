"""The RPO certificate of a two-generator state: ``rpo_certificate(run_dir, generators)``.

From a census start (or any run with a checkpoint) and the generators of its frequency
lattice (``studies.attractors.lattice``: k₁, f₁ the dominant, k₂, f₂ the moving one), the
start's guess is

    T = 1/|f₂'|,  f₂' = f₂ − (k₂/k₁) f₁   (the period in the frame of the first wave),
    s = 2π f₁ T / k₁                       (that frame's turn over T),

and the state where the checkpoint stands. ``OrbitProblem`` + ``newton_krylov_hookstep``
solve G = R₋ₛ F_T(x) − x = 0; ``floquet_multipliers`` give the leading multipliers.

**Components of the orbit.** Over one period (p steps of h, every level sampled) the
contact circle's u_r, u_θ give per wavenumber k the coefficient a_k(t) = (2/N) Σ_j u(θ_j, t)
e^{−ikθ_j}. On an RPO a_k(t + T) = a_k(t) e^{−iks}, so b_k(t) = a_k(t) e^{iks t/T} is
T-periodic; its Fourier coefficient n is the component (k, f) with f = k s/(2πT) − n/T
(the convention of ``studies.attractors.features``: f > 0 with the rotation). Exact lines,
no window: the orbit's own spectrum. Each given component is matched to the orbit's line
of the same k nearest in frequency.

**An orbit, not only a root.** Newton's root x solves R₋ₛ F_T(x) = x to its tolerance; it is
an orbit of the scheme when one more period keeps it: ‖R₋₂ₛ F_{2T}(x) − x‖ within
``ORBIT_CHECK_FACTOR`` times its one-period residual. A root that is no orbit (on a torus
of the map the equation has roots the map does not repeat) is ``converged: false``, with
both residuals.

**Commutation defect.** ‖F_T(R_{Δφ/2} ξ) − R_{Δφ/2} F_T(ξ)‖ at the start: how far the
half-node Fourier shift is from a symmetry of the scheme on this state (0 for a field of
wavenumbers well below N/2, round-off for whole-node shifts): the size of the
non-equivariance that a sub-node shift brings into the problem (docs/theory/rpo.md).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from stickslip.studies.rpo.floquet import floquet_multipliers
from stickslip.studies.rpo.newton import newton_krylov_hookstep
from stickslip.studies.rpo.orbit import Guess, OrbitProblem, Start, start_from_run

__all__ = ["period_and_shift", "orbit_guess", "rpo_certificate", "rpo_screen",
           "orbit_samples", "orbit_components", "solve_orbit"]

SHARE_LISTED = 0.10  #: an orbit line is listed from this share of the largest
#: Newton's root is an orbit when its residual over two periods is at most this many times
#: its one-period residual (or the tolerance): an orbit's error grows over the second period
#: by its multipliers (e^{growth T}, a few on the census's orbits), while a root that is no
#: orbit jumps to the size of the commutation defect (from 6e-11 to 0.079 on the two-wave
#: state of P at N = 132, seed 4: docs/theory/rpo.md)
ORBIT_CHECK_FACTOR = 1e3


def period_and_shift(generators: list[dict]) -> tuple[float, float]:
    """(T s, s rad) of an RPO from its two generators (module docstring)."""
    if len(generators) < 2:
        raise ValueError(f"{len(generators)} generator(s): an RPO has two")
    g1, g2 = generators[0], generators[1]
    f1, f2 = float(g1["frequency_hz"]), float(g2["frequency_hz"])
    f_frame = f2 - g2["k"] / g1["k"] * f1
    if not (math.isfinite(f_frame) and abs(f_frame) > 0.0):
        raise ValueError("the second generator does not move in the first one's frame")
    period = 1.0 / abs(f_frame)
    return period, 2.0 * math.pi * f1 * period / g1["k"]


def orbit_guess(generators: list[dict], period: float | None = None,
                shift: float | None = None) -> tuple[float, float]:
    """(T s, s rad) to start Newton from: ``period`` and ``shift`` where given, the rest
    from the two ``generators`` (``period_and_shift``). With both given the generators are
    not read: a rigid wave (one generator) is an RPO for any T with s = ωT."""
    if period is not None and shift is not None:
        return period, shift
    guess_t, guess_s = period_and_shift(generators)
    return (period or guess_t), (guess_s if shift is None else shift)


def orbit_samples(problem: OrbitProblem, guess: Guess) -> dict[str, np.ndarray]:
    """One period of the orbit at every step (levels 0 … p − 1 at t = j h), in a run's
    samples.npz layout (t, theta, u_r, u_theta, v_r, v_theta, status, r_r, r_theta, ds)."""
    bp = problem.start.batched
    cx = np.asarray(bp.cx, dtype=np.int64)
    c, s = np.cos(bp.theta), np.sin(bp.theta)
    rows: dict[str, list] = {k: [] for k in ("u_r", "u_theta", "v_r", "v_theta", "status",
                                              "r_r", "r_theta")}

    def observe(k: int, st) -> None:  # level k − 1: u_n = u_prev; v_n, status, r at level n
        for name, field in (("u", st.u_prev), ("v", st.v)):
            x, y = field[cx, 0], field[cx + 1, 0]
            rows[f"{name}_r"].append(c * x + s * y)
            rows[f"{name}_theta"].append(-s * x + c * y)
        rows["status"].append(np.array(st.status[:, 0]))
        rows["r_r"].append(np.array(st.r_r[:, 0]))
        rows["r_theta"].append(np.array(st.r_t[:, 0]))

    u, v = problem.physical(guess.xi[:, None])
    h = problem.step_of(guess.period)
    problem.map.advance(u, v, problem.steps, h, observe=observe)
    out = {k: np.array(rows[k]) for k in rows}
    out.update(t=np.arange(problem.steps) * h, theta=np.asarray(bp.theta),
               ds=np.asarray(problem.start.problem.nodes.ds_weight))
    return out


def orbit_components(samples: dict, period: float, shift: float) -> list[dict]:
    """The orbit's lines (k, f, amplitude, share), share ≥ ``SHARE_LISTED`` of the largest
    (module docstring), largest first."""
    theta, t = samples["theta"], samples["t"]
    N, p = theta.size, t.size
    ks = np.arange(1, N // 2 + 1)
    phase = np.exp(-1j * np.outer(theta, ks))
    power = 0.0
    for name in ("u_r", "u_theta"):
        u = samples[name] - samples[name].mean(axis=1, keepdims=True)
        a = (2.0 / N) * (u @ phase)  # (p, K)
        b = a * np.exp(1j * np.outer(t, ks) * shift / period)
        power = power + np.abs(np.fft.fft(b, axis=0) / p) ** 2
    amp = np.sqrt(power)
    n = np.fft.fftfreq(p, 1.0 / p)
    lines = []
    top = float(amp.max())
    for j, k in enumerate(ks):
        for i in np.flatnonzero(amp[:, j] >= SHARE_LISTED * top):
            f = k * shift / (2.0 * math.pi * period) - n[i] / period
            lines.append({"k": int(k), "direction": "rotation" if f > 0 else "opposite",
                          "frequency_hz": float(f), "amplitude_m": float(amp[i, j]),
                          "share": float(amp[i, j] / top)})
    return sorted(lines, key=lambda d: -d["share"])


def _differences(lines: list[dict], given: list[dict]) -> list[dict]:
    """Each given component against the orbit's line of the same k nearest in frequency."""
    out = []
    for g in given:
        f = g.get("frequency_hz")
        same = [x for x in lines if x["k"] == g["k"]]
        if f is None or not same:
            out.append({"k": g["k"], "frequency_hz": f, "orbit_frequency_hz": None})
            continue
        best = min(same, key=lambda x: abs(x["frequency_hz"] - f))
        out.append({"k": g["k"], "frequency_hz": f, "orbit_frequency_hz": best["frequency_hz"],
                    "difference_hz": best["frequency_hz"] - f,
                    "relative": (best["frequency_hz"] - f) / abs(f),
                    "share": g.get("share"), "orbit_share": best["share"]})
    return out


def guess_norms(problem: OrbitProblem, guess: Guess) -> tuple[float, float]:
    """(‖R₋ₛ F_T(ξ) − ξ‖, the commutation defect ‖F_T(R_{Δφ/2} ξ) − R_{Δφ/2} F_T(ξ)‖) at
    ``guess`` (module docstring): two flows of T, F_T(ξ) shared."""
    flowed = problem.flow(guess.xi, guess.period)
    residual = problem.rotate(flowed, -guess.shift) - guess.xi
    half = math.pi / problem.rotation.count
    a = problem.flow(problem.rotate(guess.xi, half), guess.period)
    return float(np.linalg.norm(residual)), float(np.linalg.norm(a - problem.rotate(flowed,
                                                                                      half)))


def two_period_residual(problem: OrbitProblem, orbit: Guess) -> float:
    """‖R₋₂ₛ F_{2T}(ξ) − ξ‖ of a root (module docstring), 2p steps of the root's h."""
    x2 = problem.flow(orbit.xi, orbit.period, steps=2 * problem.steps)
    return float(np.linalg.norm(problem.rotate(x2, -2.0 * orbit.shift) - orbit.xi))


def orbit_verdict(result, r2: float, tol: float, defect: float) -> tuple[bool, str]:
    """(converged, message): Newton converged and its root is an orbit (``r2``, its
    residual over two periods, within ``ORBIT_CHECK_FACTOR`` of the one-period one)."""
    if not result.converged:
        return False, result.message
    if r2 <= ORBIT_CHECK_FACTOR * max(result.residual, tol):
        return True, result.message
    return False, (f"Newton's root (residual {result.residual:.2g}) is no orbit of the scheme: "
                   f"over two periods its residual is {r2:.2g} (commutation defect "
                   f"{defect:.2g}): an invariant torus of the map, not a periodic orbit")


def rpo_screen(run_dir: str | Path, generators: list[dict]) -> dict:
    """What a two-generator census member is on the mesh, cheaply (four periods of flow,
    no Newton): at the state where ``run_dir``'s checkpoint stands, the generators' guess T, s
    (``period_and_shift``), the residuals ‖R₋ₛ F_T x − x‖ and ‖R₋₂ₛ F_{2T} x − x‖ (relative
    RMS of the state, as ``rpo_certificate``'s) and the half-node commutation defect
    (``guess_norms``).
    A defect well above round-off makes the state an invariant torus of the scheme's map,
    not an exact RPO: Newton's roots of R₋ₛ F_T x = x then fail the two-period check by
    about the defect (docs/theory/rpo.md). Never raises: ``message`` says why it is
    missing."""
    try:
        start = start_from_run(run_dir)
        period, shift = period_and_shift(generators)
        problem = OrbitProblem(start, period, shift)
        residual, defect = guess_norms(problem, problem.guess)
        return {"period_s": period, "shift_rad": shift, "steps": problem.steps,
                "residual": residual,
                "residual_two_periods": two_period_residual(problem, problem.guess),
                "commutation_defect": defect}
    except Exception as err:  # noqa: BLE001 - a screen that cannot run is reported
        return {"message": f"{type(err).__name__}: {err}"}


def solve_orbit(problem: OrbitProblem, *, tol: float = 1e-10, max_iter: int = 20,
                max_krylov: int = 80, log=None):
    """Newton–Krylov–hookstep from the problem's guess: (NewtonResult, final Guess)."""
    result = newton_krylov_hookstep(problem.extended_residual, problem.linearise,
                                    problem.pack(problem.guess), tol=tol, max_iter=max_iter,
                                    max_krylov=max_krylov, log=log)
    return result, problem.unpack(result.X)


def rpo_certificate(run_dir: str | Path, generators: list[dict], *,
                    components: list[dict] | None = None, period: float | None = None,
                    shift: float | None = None, tol: float = 1e-10, max_iter: int = 20,
                    floquet: int = 12, orbit_dir: str | Path | None = None,
                    log=None, nodes: int | None = None, krylov: int = 60,
                    krylov_max: int | None = None, start: Start | None = None) -> dict:
    """The RPO of the state where ``run_dir``'s checkpoint stands, started from the
    ``generators`` (dicts with k, frequency_hz; ``period``/``shift`` override the guess, and
    with both given the generators may be one: a rigid wave as an RPO).
    Returns {converged (Newton's and an orbit: module docstring), residual,
    residual_two_periods, iterations, period_s, shift_rad, floquet (leading moduli),
    stable, components (the orbit's lines), differences (each of ``components``, default
    the generators, against the orbit's line), history, guess, defect, wall_s, ...}.
    ``orbit_dir``: one period of samples written there as samples.npz (a run's layout).
    ``nodes``: s held at that many node passages, + with the rotation (``OrbitProblem``'s
    ``hold_shift``: the mesh's own symmetry; a rigid wave, with ``period`` its guess of T);
    ``krylov``: the Arnoldi vectors of the multipliers, doubled while their verdict is
    open up to ``krylov_max`` (``floquet_multipliers``); ``start``: the run's state where
    already read (``orbit.start_from_run``)."""
    t0 = time.perf_counter()
    start = start or start_from_run(run_dir)
    if nodes is not None:
        shift = 2.0 * math.pi * nodes / start.scene.mesh.n_inner
    guess_t, guess_s = orbit_guess(generators, period, shift)
    problem = OrbitProblem(start, guess_t, guess_s, hold_shift=nodes is not None)
    r0, defect = guess_norms(problem, problem.guess)
    result, orbit = solve_orbit(problem, tol=tol, max_iter=max_iter, log=log)
    r2 = two_period_residual(problem, orbit)
    converged, message = orbit_verdict(result, r2, tol, defect)
    # multipliers of a point that is no orbit certify nothing: not computed
    flo = floquet_multipliers(problem, orbit, count=floquet, krylov=krylov,
                              krylov_max=krylov_max) if floquet and converged else None
    samples = orbit_samples(problem, orbit)
    lines = orbit_components(samples, orbit.period, orbit.shift)
    if orbit_dir is not None:
        Path(orbit_dir).mkdir(parents=True, exist_ok=True)
        np.savez(Path(orbit_dir) / "samples.npz", **samples)
    flips = np.array(problem.jvp_flips or [0])
    return {"converged": converged, "residual": result.residual,
            "residual_two_periods": r2, "newton_converged": bool(result.converged),
            "iterations": result.iterations, "message": message,
            "period_s": orbit.period, "shift_rad": orbit.shift,
            "shift_deg": math.degrees(orbit.shift), "steps": problem.steps,
            "step_s": problem.step_of(orbit.period), "run_step_s": problem.start.dt,
            "guess": {"period_s": guess_t, "shift_rad": guess_s, "residual": r0},
            "commutation_defect": defect, "held_shift": nodes is not None,
            "floquet": None if flo is None else [float(m) for m in flo.moduli],
            "floquet_detail": None if flo is None else flo.to_dict(),
            "stable": None if flo is None or not converged else flo.stable,
            "components": lines,
            "differences": _differences(lines, components or generators),
            "history": [it.to_dict() for it in result.history],
            "jvp_status_changes": {"products": int(len(problem.jvp_flips)),
                                   "with_changes": int(np.count_nonzero(flips)),
                                   "max": int(flips.max())},
            "wall_s": time.perf_counter() - t0}
