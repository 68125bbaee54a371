"""Where a two-wave state is born: a rigid wave's sideband followed along a scene parameter.

A two-generator state k₁ + k₂ near a rigid wave k₁ is, in the frame of k₁, a small
oscillation of wavenumber content k₂ (and k₂ − k₁, k₂ + k₁, ...). Linearised about the rigid
wave it is one complex pair λ = σ ± iω of the wave's operator: the sideband's complex
amplitude a_{k₂}(t) = (1/N) Σ_j u_r(θ_j, t) e^{−i k₂ θ_j} behaves as e^{σt} e^{∓iω_lab t},
with ω_lab the k₂ line's lab frequency; in the frame of k₁ it turns at
f_frame = f_{k₂} − (k₂/k₁) f_{k₁}. If σ crosses 0 as a parameter p moves, the rigid wave
loses its stability there (a Hopf bifurcation in its frame) and, past the crossing, the
sideband grows to a finite amplitude: the two-wave state, a relative periodic orbit of the
continuum (docs/theory/rpo.md). Supercritical, its saturated share A ∝ √(p − p_c) and its
frame frequency tends to ω/2π of the pair at p_c (the normal form dA/dt = σA − ℓA³).

``sideband_scan`` follows it by transients (natural-parameter continuation): the first value
starts from a given state (a run's checkpoint, ``checkpoint_state``), each next value from
the end state (u, v~) of the one before, with ``key`` set to the value; ``along`` is that
scan from a census start, as ``stickslip rpo --along`` and ``stickslip.rpo_along`` run it.
Per value it measures ``sideband_fit``'s σ and frequency from the tail of log|a_{k₂}(t)|
(the last ``fit_fraction`` of the run) and the shares |a_{k₂}|/|a_{k₁}|. σ < 0 with the
share decaying to 0: the rigid wave is the attractor (σ its eigenvalue's real part); a
share that levels off (σ → 0 over the tail) is a two-wave state. Nothing of the run is
changed or written.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from stickslip.solver.run import Simulation
from stickslip.studies.rundir.continuation import checkpoint_plan

#: A sideband at or below this fraction of the wave's amplitude is round-off, not a mode.
ROUND_OFF = 1e-12

__all__ = ["MAX_LEG", "MAX_VALUES", "SEEDED_BELOW", "SidebandFit", "along",
           "census_generators", "checkpoint_state", "mode_series", "restart", "scan_line",
           "sideband_fit", "sideband_row", "sideband_scan"]

#: With a seeded sideband, σ is fitted where it is below this share of the wave (its linear
#: range; a seed of 10⁻² d is a share of about 10⁻⁴ on the paper's waves).
SEEDED_BELOW = 0.01
#: ``along``: each value's run at most (s; a census's cap is 4 s), and at most this many values.
MAX_LEG, MAX_VALUES = 100.0, 200


def mode_series(samples: dict, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(t, a_k(t)): the complex amplitude (1/N) Σ_j u_r(θ_j, t) e^{−i k θ_j} of wavenumber k
    at every sample (``samples.npz``'s t, theta, u_r)."""
    phase = np.exp(-1j * k * np.asarray(samples["theta"]))
    u_r = np.asarray(samples["u_r"])
    return np.asarray(samples["t"]), (u_r @ phase) / phase.size


@dataclass(frozen=True)
class SidebandFit:
    """``sideband_fit``'s result: σ (1/s), the sideband's signed lab frequency (Hz, + with the
    rotation: a_k ∝ e^{−i 2π f t}), the fit window (s), the RMS misfit of log|a| (how far
    from one exponential), and the share |a_k|/|a_{k₁}| at the window's start and end."""

    sigma: float
    frequency_hz: float
    t0: float
    t1: float
    misfit: float
    share_start: float
    share_end: float


def sideband_fit(samples: dict, k: int, k_wave: int, fit_fraction: float = 0.5,
                 below: float | None = None) -> SidebandFit:
    """σ and the lab frequency of wavenumber ``k`` over the last ``fit_fraction`` of the
    samples: least squares of log|a_k| = σ t + c, and of the unwrapped phase of a_k,
    arg a_k = −2π f t + c; the shares against the wave ``k_wave``'s mean |a|. With
    ``below``, only the samples whose share is below it (the linear range of a sideband
    that grows from a seed, or has decayed into it)."""
    t, a = mode_series(samples, k)
    _, wave = mode_series(samples, k_wave)
    sel = t >= t[-1] - fit_fraction * (t[-1] - t[0])
    ref = float(np.mean(np.abs(wave[sel])))  # |a_k₁|: constant on a rigid wave
    if below is not None:
        sel &= np.abs(a) < below * ref
    ts, amp = t[sel], np.abs(a[sel])
    if ts.size < 4 or not np.all(amp > ROUND_OFF * ref):
        raise ValueError(f"sideband k = {k}: {ts.size} samples in the fit window, or at "
                         f"round-off (|a| <= {ROUND_OFF:g} of the wave k = {k_wave}'s)")
    A = np.vstack([ts, np.ones_like(ts)]).T
    (sigma, c), *_ = np.linalg.lstsq(A, np.log(amp), rcond=None)
    misfit = float(np.sqrt(np.mean((np.log(amp) - (sigma * ts + c)) ** 2)))
    (slope, _), *_ = np.linalg.lstsq(A, np.unwrap(np.angle(a[sel])), rcond=None)
    # the shares over the first and last twentieth of the window
    edge = max(1, ts.size // 20)
    return SidebandFit(float(sigma), float(-slope / (2.0 * math.pi)), float(ts[0]),
                       float(ts[-1]), misfit, float(np.mean(amp[:edge]) / ref),
                       float(np.mean(amp[-edge:]) / ref))


def checkpoint_state(run_dir: str | Path) -> tuple[object, tuple[np.ndarray, np.ndarray]]:
    """(scene, (u, v~)): ``run_dir``'s scene and the state its checkpoint stands at."""
    plan = checkpoint_plan(run_dir)
    ck = plan.checkpoint.states[0]
    return plan.scene, (np.array(ck["stepper/u"]), np.array(ck["stepper/v_pred"]))


def restart(scene, state: tuple[np.ndarray, np.ndarray], key: str, value: float,
            duration: float, seed: tuple[int, float] | None = None
            ) -> tuple[dict, float, tuple[np.ndarray, np.ndarray]]:
    """``scene`` with ``key`` = ``value`` run for ``duration`` s from (u, v~) on this rank:
    (its samples, its step, its end state (u, v~)). ``seed`` = (k, ε) adds the radial bump
    ε d cos kθ (eq. [1] through the thickness) to u first: a sideband to measure where the
    state has none above round-off."""
    from mpi4py import MPI  # MPI starts where a run does (the module imports without it)

    run = scene.with_overrides(f"{key}={value!r}", f"time.end_time={duration!r}",
                               "time.max_steps=0", "output.progress=false")
    sim = Simulation(run, MPI.COMM_SELF, initial_state=(state[0], state[1], None))
    if seed is not None:
        k, eps = seed
        d = run.geometry.delta * run.geometry.R
        du = sim.problem.radial_field(lambda theta: eps * d * np.cos(k * theta))
        sim.columns.perturb(0, du, np.zeros_like(du))
    sim.proceed()
    if sim.status != "completed":
        raise ValueError(f"{key} = {value}: the run ended {sim.status}")
    stepper = sim.integrator
    return (sim.recorder.arrays(), float(sim.dt),
            (np.array(stepper.u), np.array(stepper.v_pred)))


def sideband_row(samples: dict, value: float, dt: float, k_wave: int, k_side: int,
                 fit_fraction: float = 0.5, below: float | None = None) -> dict:
    """One scan row: {"value", "dt_s", "duration_s", **SidebandFit, "wave_hz",
    "frame_hz"} of ``samples`` at the parameter ``value`` (``sideband_fit``'s options)."""
    fit = sideband_fit(samples, k_side, k_wave, fit_fraction, below)
    wave = sideband_fit(samples, k_wave, k_wave, fit_fraction).frequency_hz
    t = samples["t"]
    return {"value": float(value), "dt_s": dt, "duration_s": float(t[-1] - t[0]),
            **asdict(fit), "wave_hz": wave,
            "frame_hz": fit.frequency_hz - k_side / k_wave * wave}


def sideband_scan(scene, state: tuple[np.ndarray, np.ndarray], key: str,
                  values: list[float], k_wave: int, k_side: int, duration: float,
                  fit_fraction: float = 0.5, seed: tuple[int, float] | None = None,
                  below: float | None = None, report=None  # noqa: ANN001 - report(row)
                  ) -> tuple[list[dict], tuple[np.ndarray, np.ndarray]]:
    """Follow ``state`` of ``scene`` along ``key`` = ``values``, each value ``duration`` s
    from the end of the one before (module docstring), ``seed`` added at each start
    (``restart``): the rows (``sideband_row``, ``below`` its linear range) and the last end
    state; ``report(row)`` as each row is done."""
    rows = []
    for value in values:
        samples, dt, state = restart(scene, state, key, float(value), duration, seed)
        rows.append(sideband_row(samples, value, dt, k_wave, k_side, fit_fraction, below))
        if report is not None:
            report(rows[-1])
    return rows, state


def census_generators(run_dir: str | Path) -> tuple[list[dict], list[dict]]:
    """(generators, components) of the census member that ``run_dir`` (a start) belongs to,
    from the nearest attractors.json above it; ([], []) where there is none."""
    run_dir = Path(run_dir)
    for parent in list(run_dir.parents)[:4]:
        path = parent / "attractors.json"
        if not path.is_file():
            continue
        data = json.loads(path.read_text())
        row = next((r for r in data.get("starts", []) if r.get("id") == run_dir.name), None)
        if row is None:
            continue
        for members in data.get("members", {}).values():
            for m in members:
                if m.get("member") == row.get("member"):
                    return list(m.get("generators") or []), list(m.get("components") or [])
    return [], []


def along(run_dir: str | Path, key: str, values: list[float], *, leg: float = 1.0,
          wave: int | None = None, sideband: int | None = None, seed: float | None = None,
          report=None) -> dict:  # noqa: ANN001 - report(row) or None
    """The sideband scan of a start (module docstring) as ``stickslip rpo --along`` runs it:
    the wavenumbers ``wave`` and ``sideband`` (default: the census member's two generators,
    ``census_generators``), ``leg`` s per value, a seed ε = ``seed`` (× d) at each start
    fitted below ``SEEDED_BELOW``. Returns {"key", "k_wave", "k_side", "rows"}; ValueError
    naming the fix for a missing wavenumber, a bad key, a run that did not complete or a
    sideband at round-off."""
    if not (math.isfinite(leg) and 0.0 < leg <= MAX_LEG):
        raise ValueError(f"leg = {leg}: give a positive number of seconds up to {MAX_LEG:g}")
    if not 0 < len(values) <= MAX_VALUES:
        raise ValueError(f"{len(values)} values: give 1 to {MAX_VALUES}")
    if seed is not None and not (math.isfinite(seed) and seed > 0.0):
        raise ValueError(f"seed = {seed}: give a positive fraction of d, e.g. 1e-2")
    generators, _ = census_generators(run_dir)
    k_wave = wave or (abs(int(generators[0]["k"])) if generators else None)
    k_side = sideband or (abs(int(generators[1]["k"])) if len(generators) > 1 else None)
    if k_wave is None or k_side is None or k_wave == k_side:
        raise ValueError(f"{run_dir}: give --wave K and --sideband K2 (two wavenumbers; no "
                         "census member with two generators above it names them)")
    scene, state = checkpoint_state(run_dir)
    for value in values:  # the key and every value, before any run: SceneError naming it
        scene.with_overrides(f"{key}={float(value)!r}")
    try:
        rows, _ = sideband_scan(scene, state, key, values, k_wave, k_side, leg,
                                seed=None if seed is None else (k_side, seed),
                                below=None if seed is None else SEEDED_BELOW, report=report)
    except ValueError as err:  # a run that did not complete, a sideband at round-off
        raise ValueError(f"{run_dir}: {err}" + ("" if seed else "; a state without the "
                                                "sideband needs a seed (e.g. 1e-2)")) from None
    return {"key": key, "k_wave": k_wave, "k_side": k_side, "rows": rows}


def scan_line(row: dict, key: str) -> str:
    """One line of a ``sideband_scan`` row."""
    return (f"{key} = {row['value']:g}: sigma = {row['sigma']:+.3f} 1/s (misfit "
            f"{row['misfit']:.2g}), share {row['share_start']:.4f} -> {row['share_end']:.4f} "
            f"over {row['t0']:.2f}-{row['t1']:.2f} s; sideband {row['frequency_hz']:+.2f} Hz, "
            f"wave {row['wave_hz']:+.2f} Hz, frame {row['frame_hz']:+.2f} Hz")
