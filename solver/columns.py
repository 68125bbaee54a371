"""What every column of a run shares, whichever columns hold it.

A run (``solver.run.Simulation``) advances B ≥ 1 scenes, its columns. Two kinds of columns
hold them: one scene with its dofs distributed over MPI ranks, any scheme
(``solver.scene_column.SceneColumn``, B = 1), or B scenes as one (n, B) explicit batch on one
rank (``solver.ensemble_run.BatchColumns``). Both build each column's start the same way
(``initial_perturbation``), count the steps the same way (``planned_steps``), and give each
scene a ``SceneRun``: its status, its records and its facts, which a run directory writes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from stickslip.solver import __version__
from stickslip.solver.observers import ContinuedRecords
from stickslip.solver.scene import Scene

__all__ = ["KICK_MODES", "Profile", "SceneRecords", "SceneRun", "energy_balance",
           "initial_perturbation", "kick_fields", "planned_steps", "random_bump",
           "restore_run_state", "run_facts", "run_state"]


class Profile:
    """Wall time per phase (mesh, assembly, steady state, time loop, contact, I/O)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    @contextmanager
    def phase(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0


@dataclass
class SceneRecords:
    """What one scene's column records, as its scheme's kernel records it
    (``solver.schemes.select.SchemeParts.scene_records``): the ``sampler`` the time loop
    asks at each level (``every``, ``due(level)``, ``observe(stepper)`` -> {0: message} of
    the energy guard, ``guard``), the ``samples`` and ``probes`` a run directory writes
    (``arrays()``, ``n``; the samples also ``n_nodes`` and ``recent_status(last)``), and
    ``parts``: the observers besides the stepper and the contact step whose ``state()`` a
    checkpoint keeps, by name."""

    sampler: Any
    samples: Any
    probes: Any
    parts: dict[str, Any]


class SceneRun:
    """One column of a run: its scene, status and records, and what a run directory needs of
    it (``facts()``, ``recorder.arrays()``, ``probes.arrays()``, ``final_field()``, the
    checkpoint ``state``).

    While the column is stepped, its steps, time and scheme facts are the stepper's; ``finish``
    freezes them (a masked, diverged column stops there, as it would alone; a scene whose set-up
    failed is frozen at step 0)."""

    def __init__(self, scene: Scene, columns, problem, dofs: int, ranks: int,
                 index: int = 0) -> None:
        self.scene, self.columns, self.problem = scene, columns, problem
        self.index = index  # its place in the run's ``runs``
        self.comm = columns.comm
        self.dt, self.dt_crit, self.omega_max = columns.dt, columns.dt_crit, columns.omega_max
        self.dofs, self.ranks = dofs, ranks
        self.status, self.stop_reason, self.message = "running", "", ""
        self.steady = None
        self.steady_mean_pressure = float("nan")
        #: what the outputs read: this scene's records (with the earlier ones in front when
        #: continued, ``solver.observers.ContinuedRecords``)
        self.recorder = None
        self.probes = None
        self.kick: dict | None = None  # the kick a continuation started with (its facts)
        #: this scene's checkpoint when it finished at a whole level (``finish``), else None
        self.state: dict[str, np.ndarray] | None = None
        self.frozen: tuple[int, float, dict] | None = None  # steps, time, scheme facts

    @property
    def steps(self) -> int:
        return self.frozen[0] if self.frozen else self.columns.stepper.step_count

    @property
    def sim_time(self) -> float:
        return self.frozen[1] if self.frozen else self.columns.stepper.time

    def facts(self) -> dict:
        """What the run of this scene did: ``run_facts`` with its scheme's facts."""
        scheme = self.frozen[2] if self.frozen else self.columns.stepper.facts()
        return run_facts(self, scheme)

    def final_field(self) -> dict[str, np.ndarray] | None:
        """The final field of this scene (rank 0; ``solver.field_output.gather_final_field``),
        or None where its columns hold no dolfinx problem."""
        return self.columns.final_field(self)

    def fail(self, status: str = "failed") -> None:
        """The scene never stepped (its set-up failed): frozen at step 0."""
        self.status, self.frozen = status, (0, 0.0, {})

    def finish(self, status: str, stop: str = "") -> None:
        """Freeze this scene's facts at the stepper's current level."""
        st = self.columns.stepper
        self.status, self.stop_reason = status, stop
        self.frozen = (st.step_count, st.time, st.facts())


def run_state(guard, b: int, run: SceneRun) -> dict[str, np.ndarray]:
    """The ``run/`` part of column b's checkpoint, the same for every kind of columns: the
    energy guard's E(0) and bound (``solver.errors.EnergyGuard``), the steady pressure and
    the counts of samples and probe steps taken (those before a continuation included). The
    cadences need nothing: they are fixed levels and the step count is the stepper's; the
    records themselves are the run's samples.npz (``restore_run_state``'s ``before``)."""
    return {"run/initial_energy": np.float64(guard.initial[b]),
            "run/energy_bound": np.float64(guard.bound[b]),
            "run/steady_pressure": np.float64(run.steady_mean_pressure),
            "run/samples": np.int64(run.recorder.n),
            "run/probe_steps": np.int64(run.probes.n)}


def restore_run_state(guard, b: int, run: SceneRun, state: dict[str, np.ndarray],
                      before: dict[str, np.ndarray] | None, samples, probes) -> None:
    """Column b continues from ``run_state``'s part of ``state``: its guard and steady
    pressure, and its live records ``samples`` and ``probes`` with the earlier ones
    ``before`` (samples.npz, on rank 0; None elsewhere) in front
    (``solver.observers.ContinuedRecords``)."""
    guard.initial[b] = float(state["run/initial_energy"])
    guard.bound[b] = float(state["run/energy_bound"])
    run.steady_mean_pressure = float(state["run/steady_pressure"])
    run.recorder = ContinuedRecords(samples, before, state["run/samples"])
    run.probes = ContinuedRecords(probes, before, state["run/probe_steps"])


def planned_steps(scene: Scene, dt: float) -> int:
    """Steps to ``time.end_time`` at step dt, capped by ``time.max_steps``."""
    n = int(math.ceil(scene.time.end_time / dt - 1e-9))
    if scene.time.max_steps:
        n = min(n, scene.time.max_steps)
    return n


def initial_perturbation(problem, scene: Scene) -> np.ndarray:
    """Initial radial bump (scene ``[initial]``), amplitude x d, shaped by X(r) (eq. [1]).

    "mode": A (1 + cos k theta) / 2; "random": sum_k w_k (1 + cos(k theta + phi_k)) / 2 over
    k = 1 .. n_modes, weights w_k uniform and normalised to sum 1, phases uniform in
    [0, 2 pi), from ``initial.seed`` (the same numbers on every rank: partition-free).
    """
    ini, d = scene.initial, scene.geometry.d
    if ini.perturbation == "none" or ini.amplitude == 0.0:
        return np.zeros(problem.n_owned)
    amp = ini.amplitude * d
    if ini.perturbation == "mode":
        k = ini.mode
        return problem.radial_field(lambda th: amp * 0.5 * (1.0 + np.cos(k * th)))
    return problem.radial_field(random_bump(ini.seed, ini.n_modes, amp))


#: The random modes of a kick's bumps (``kick_fields``).
KICK_MODES = 16


def kick_fields(problem, u: np.ndarray, v: np.ndarray, fraction: float, seed: int,
                rms: Callable[[np.ndarray], float]) -> tuple[np.ndarray, np.ndarray, dict]:
    """(δu, δv, facts) of a kick of the state (u, v~) where a scene stands, as a start is
    perturbed: δu = ε ‖u‖ φ₁/‖φ₁‖ and δv = ε ‖v~‖ φ₂/‖φ₂‖, ε = ``fraction``, ‖·‖ = ``rms``
    (over the dofs), φ_i the random start's radial bump A(θ) X(r) e_r of ``problem``
    (``random_bump`` with ``KICK_MODES`` modes, seeds ``seed`` and ``seed + 1``; clamped
    outside, smooth, the contact circle's shape spread through the thickness by eq. [1]).
    The facts are the RMS sizes of u, v~, δu and δv."""
    kicks = []
    for x, s in ((u, seed), (v, seed + 1)):
        shape = problem.radial_field(random_bump(s, KICK_MODES, 1.0))
        kicks.append(fraction * rms(x) / rms(shape) * shape)
    return kicks[0], kicks[1], {
        "fraction": fraction, "seed": seed, "u_rms_m": rms(u), "v_rms_m_s": rms(v),
        "du_rms_m": rms(kicks[0]), "dv_rms_m_s": rms(kicks[1])}


def random_bump(seed: int, n_modes: int, amplitude: float) -> Callable[[np.ndarray],
                                                                         np.ndarray]:
    """The random start's shape A(θ) = amplitude Σ_k w_k (1 + cos(kθ + φ_k)) / 2, k = 1 ..
    n_modes, w_k ~ U(0, 1) normalised to sum 1, φ_k ~ U(0, 2π) from
    ``numpy.random.default_rng(seed)`` (``initial_perturbation``; a kick's field)."""
    rng = np.random.default_rng(seed)
    ks = np.arange(1, n_modes + 1)
    weights = rng.uniform(0.0, 1.0, ks.size)
    phases = rng.uniform(0.0, 2 * np.pi, ks.size)
    weights /= weights.sum()

    def shape(th: np.ndarray) -> np.ndarray:
        s = np.zeros_like(th)
        for k, w, ph in zip(ks, weights, phases, strict=True):
            s += w * 0.5 * (1.0 + np.cos(k * th + ph))
        return amplitude * s

    return shape


def run_facts(run: SceneRun, scheme: dict) -> dict:
    """The facts of one scene's run: status, steps, dt, dofs, ranks, the scheme's ``facts()``,
    and the energy balance of its samples."""
    out: dict = {
        "stickslip_version": __version__,
        "scene": run.scene.name,
        "status": run.status,
        "stop_reason": run.stop_reason,
        "steps": run.steps,
        "sim_time_s": run.sim_time,
        "dt_s": run.dt,
        "dt_crit_s": run.dt_crit,
        "omega_max_rad_s": run.omega_max,
        "dofs": run.dofs,
        "contact_nodes": int(run.recorder.n_nodes),
        "ranks": run.ranks,
        "samples": int(run.recorder.n),
        "steady_pressure_pa": run.steady_mean_pressure,
        "scheme": scheme,
    }
    unit = "J_per_m"  # plane strain: per unit length of the tube
    surface = getattr(run.problem, "surface", None)  # a batch's shared problem has none
    if surface is not None:
        out["tube_3d"] = tube_3d_facts(run.problem)
        unit = "J"  # the finite tube's whole energy
    data = run.recorder.arrays()
    if data["t"].size >= 4:  # as many samples as the wave analysis needs
        out["energy"] = energy_balance(data["energies"], unit)
    return out


def tube_3d_facts(problem) -> dict:
    """What a 3D tube's summary says of it: its length, layers and ends, the contact
    surface's nodes, and the axial level of the ring that the samples record."""
    tube = problem.tube  # no collective here: rank 0 alone writes the summary
    return {"length_m": tube.length, "n_axial": tube.n_axial,
            "ends": problem.scene.boundary.ends,
            "surface_nodes": int(problem.surface.n_global),
            "ring_z_m": float(tube.levels[tube.n_axial // 2])}


def energy_balance(e: np.ndarray, unit: str = "J_per_m") -> dict[str, float]:
    """The energy terms at the last sample and the residual of the balance
    E(t) - E(0) = W_contact - W_damping (columns of ``solver.observers.ENERGY_FIELDS``), in
    ``unit`` (the keys' suffix: J per m of a plane-strain tube, J of a finite one)."""
    wd = e[:, 5] if e.shape[1] > 5 else np.zeros(e.shape[0])
    terms = {
        "initial": float(e[0, 0] + e[0, 1]),
        "final": float(e[-1, 0] + e[-1, 1]),
        "work_contact": float(e[-1, 2]),
        "work_cylinder": float(e[-1, 3]),
        "friction_dissipation": float(e[-1, 4]),
        "damping_dissipation": float(wd[-1]),
        "balance_residual": float(e[-1, 0] + e[-1, 1] - e[0, 0] - e[0, 1]
                                  - (e[-1, 2] - e[0, 2]) + (wd[-1] - wd[0])),
    }
    return {f"{name}_{unit}": value for name, value in terms.items()}
