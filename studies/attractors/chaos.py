"""Chaos told apart from a slow transient: a start still changing at the cap is tested for a
chaotic attractor by two measurements, both needed for the class ``chaotic``.

**Stationary statistics** (``stationarity``). The last leg [t/1.5, t] is tiled by K windows
W (``features.leg_window_ends``, at least two). Per scalar observable x(t) (the RMS of the
contact circle's radial deviation, the amplitude |a_k(t)| of the mode k dominant over the
leg, and each contact zone's fraction of the nodes) the window means m_i and standard
deviations s_i are taken. The observable is stationary when

* its trend is small: the least-squares line through (window centre, m_i), carried over the
  leg's length L, moves by at most ``DRIFT_TOL`` = 0.5 pooled standard deviations
  σ = √(mean s_i²) (plus 10⁻³ |mean| so that a constant signal passes). A transient that
  decays or grows moves its mean steadily, by a sizeable part of its own fluctuation,
  across a leg 1/3 of its age; window means of a stationary process scatter by
  σ √(2 τ_c / W) without a trend, small once W is many correlation times τ_c;
* its fluctuation keeps its size: max s_i / min s_i ≤ ``SPREAD_RATIO`` = 2 (a growing or
  dying oscillation changes its variance first).

A Kolmogorov–Smirnov test between the leg's halves is not used: its p-value assumes
independent samples, and samples 10⁻⁴ s apart of a kHz wave are strongly correlated, so it
rejects every finite record.

**Largest Lyapunov exponent** (``benettin``; Benettin et al. 1980). A twin trajectory
starts d₀ = 10⁻⁸ (relative) away and advances side by side with the reference; every τ
the separation d is measured and the twin pulled back along the separation to d₀; λ₁ is
the mean of ln(d/d₀)/τ after the first ``discard`` intervals (the twin's direction aligns
with the most unstable one), its error the standard error of the means over ``blocks``
blocks. λ₁ > 0 beyond its error means λ₁ > 3 standard errors. The function drives any
``Twin`` (advance, distance, rescale), so it is validated on Lorenz 63 (tests/test_chaos.py).

**The FE twin** (``BatchTwin``) is the second column of the same batched stepper: a batch
of two columns restored from the start's checkpoint (``BatchedExplicit.restore``), column 1
perturbed as the kick test perturbs a start (``BatchedExplicit.kick``, δu and δv along the
random start's radial bump, each 10⁻⁸ of the state's RMS displacement and velocity), both
stepped in lockstep by the one kernel. Its distance is √((‖δu‖²/U² + ‖δv~‖²/V²)/2) over
the dofs (U, V: the reference's RMS at the checkpoint), so the kick is d₀ exactly; the
pull-back moves every float array of column 1's checkpoint (u, u_n, v~, the contact state,
w = u + τ v~) to column 0's plus the factor times the difference and restores both
columns (``BatchedExplicit.state``, ``restore``: the batch's own checkpoint API). The
stepper is built without a recorder: nothing is written, the start's run is not touched.
A one-scene run (no batch member: a 3D tube's start) has ``SceneTwin``: one one-scene
Simulation steps the reference and the twin in turn, each a checkpoint it restores and takes
again (the continuation's, bit for bit), the twin kicked and pulled back as the batch's.
Where a census has a rank to spare, a batch member's two columns run on two ranks
(``SplitTwin``: a batch of one each, the reference's state sent to the twin's rank every
τ), with the same bits in half the time.

``classify_at_cap(run_dir, window)`` combines both for a start ``unsettled`` at the cap:
``chaotic`` with λ₁ when both hold, otherwise ``unsettled`` with the reason. The census
calls it for every start unsettled at its cap (``census.chaos_shared``, cached in
``chaos.json``); a ``chaotic`` start is an attractor of class ``chaotic``
(``classify.CLASSES``), grouped by these statistics and printed with λ₁.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from stickslip.solver.columns import random_bump
from stickslip.solver.contact import ContactLaw
from stickslip.solver.ensemble_run import BatchColumns, BatchOptions
from stickslip.solver.run import Profile, Simulation
from stickslip.studies.attractors.features import leg_window_ends
from stickslip.studies.rundir.continuation import checkpoint_plan
from stickslip.studies.rundir.signals import deferred_signals

D0 = 1e-8  # the twin's relative distance, kept by renormalisation
DRIFT_TOL = 0.5  # a stationary mean moves by at most this many pooled standard deviations
SPREAD_RATIO = 2.0  # a stationary fluctuation keeps its size within this factor
ERROR_SIGMAS = 3.0  # λ₁ > 0 beyond its error: λ₁ > 3 standard errors
TWIN_SEED = 7  # the twin's perturbation: the random bumps of seeds 7 and 8
BUMP_MODES = 16


# ---------------------------------------------------------------- stationary statistics


def stationarity(t: np.ndarray, series: dict[str, np.ndarray], window_ends: list[float],
                 window: float) -> dict:
    """Whether every observable of ``series`` (name: samples at times ``t``) is stationary
    across the windows [e − W, e] of ``window_ends`` (module docstring). Returns
    {"stationary", "windows", "observables": {name: {"means", "stds", "drift_sigmas",
    "spread_ratio", "stationary"}}, "why": [names failing, with their numbers]}."""
    if len(window_ends) < 2:
        raise ValueError(f"{len(window_ends)} window(s): stationarity needs at least two")
    centres = np.array([e - 0.5 * window for e in window_ends])
    span = float(window_ends[-1] - window_ends[0] + window)
    out: dict[str, dict] = {}
    why = []
    for name, x in series.items():
        means, stds = [], []
        for e in window_ends:
            sel = (t >= e - window) & (t <= e)
            if not np.any(sel):
                raise ValueError(f"no sample in the window [{e - window:g}, {e:g}] s")
            means.append(float(np.mean(x[sel])))
            stds.append(float(np.std(x[sel])))
        m, s = np.array(means), np.array(stds)
        sigma = math.sqrt(float(np.mean(s**2))) + 1e-3 * abs(float(np.mean(m)))
        slope = float(np.polyfit(centres, m, 1)[0])
        drift = abs(slope) * span / sigma if sigma > 0 else 0.0
        ratio = float(s.max() / s.min()) if s.min() > 0 else (1.0 if s.max() == 0 else math.inf)
        ok = drift <= DRIFT_TOL and ratio <= SPREAD_RATIO
        out[name] = {"means": means, "stds": stds, "drift_sigmas": drift,
                     "spread_ratio": ratio, "stationary": ok}
        if not ok:
            why.append(f"{name}: mean drifts {drift:.2f} sigma over the leg, "
                       f"std ratio {ratio:.2f}")
    return {"stationary": not why, "windows": [float(e) for e in window_ends],
            "observables": out, "why": why}


def fe_series(samples: dict) -> dict[str, np.ndarray]:
    """The scalar observables of a run's samples (t, u_r (n_t, N), status where present):
    the RMS of u_r's deviation from its circle mean, |a_k(t)| of the mode k with the largest
    mean amplitude, and each contact zone code's fraction of the nodes."""
    u = np.asarray(samples["u_r"], dtype=float)
    dev = u - u.mean(axis=1, keepdims=True)
    n = u.shape[1]
    a = np.abs(np.fft.rfft(dev, axis=1))[:, 1:n // 2 + 1] * (2.0 / n)
    k = int(np.argmax(a.mean(axis=0))) + 1
    out = {"rms_u_r": np.sqrt(np.mean(dev**2, axis=1)), f"|a_{k}|": a[:, k - 1]}
    status = samples.get("status")
    if status is not None and np.size(status):
        for code in np.unique(status):
            out[f"zone_{int(code)}"] = np.mean(status == code, axis=1)
    return out


# ---------------------------------------------------------------- Benettin's method


class Twin(Protocol):
    """A reference trajectory and its twin, advanced side by side."""

    def advance(self, duration: float) -> float:
        """Advance both by about ``duration``; return the time actually advanced."""

    def distance(self) -> float:
        """The twin's distance from the reference (the measure d₀ was set in)."""

    def rescale(self, factor: float) -> None:
        """Move the twin to reference + ``factor`` × (twin − reference)."""


class NoTwin(ValueError):
    """A run whose twin cannot be made: the implicit scheme's, which is not kicked."""


class NotABatchMember(NoTwin):
    """A one-scene run's checkpoint: the batch twin has no second column to run (its twin
    is ``SceneTwin``)."""


@dataclass(frozen=True)
class Lyapunov:
    """λ₁ (1/s) and its standard error over blocks; ``logs``: ln(d/d₀) of every interval."""

    exponent: float
    error: float
    tau: float
    intervals: int
    logs: tuple[float, ...]

    @property
    def positive(self) -> bool:
        """λ₁ > 0 beyond its error (``ERROR_SIGMAS`` standard errors)."""
        return self.exponent > ERROR_SIGMAS * self.error

    def to_dict(self) -> dict:
        return {"lambda1_per_s": self.exponent, "lambda1_error_per_s": self.error,
                "tau_s": self.tau, "intervals": self.intervals, "positive": self.positive}


def benettin(twin: Twin, tau: float, intervals: int, *, d0: float = D0, discard: int = 10,
             blocks: int = 10) -> Lyapunov:
    """The largest Lyapunov exponent of ``twin`` (already perturbed to distance ``d0``):
    ``intervals`` renormalisations every ``tau``, the first ``discard`` left out of the mean,
    the error the standard error of ``blocks`` block means (module docstring)."""
    if intervals - discard < 2 * blocks:
        raise ValueError(f"{intervals} intervals, {discard} discarded: too few for "
                         f"{blocks} blocks (give at least {discard + 2 * blocks})")
    logs, taus = [], []
    for _ in range(intervals):
        dt = twin.advance(tau)
        d = twin.distance()
        if not math.isfinite(d) or d <= 0.0:
            raise ValueError(f"the twin's distance became {d!r}: no exponent")
        logs.append(math.log(d / d0))
        taus.append(dt)
        twin.rescale(d0 / d)
    rates = np.array(logs[discard:]) / np.array(taus[discard:])
    used = len(rates) - len(rates) % blocks
    means = rates[:used].reshape(blocks, -1).mean(axis=1)
    lam = float(np.mean(rates))
    err = float(np.std(means, ddof=1) / math.sqrt(blocks))
    return Lyapunov(lam, err, float(np.mean(taus)), intervals, tuple(logs))


# ---------------------------------------------------------------- the FE twin


def restored_batch(run_dir: str | Path, width: int) -> tuple[BatchColumns, object]:
    """A census start's checkpoint restored into each of ``width`` columns of one batched
    stepper built without a recorder (nothing is written, the start's run is not touched),
    stepping without diagnostics (the state is the same bits): (its columns, the stepper).
    A one-scene run (not a batch member) is refused with ``NotABatchMember``."""
    plan = checkpoint_plan(run_dir)
    if plan.kind != "batch":
        raise NotABatchMember(f"{run_dir}: not a batch member's checkpoint (a census start)")
    scene = plan.scene
    cols = BatchColumns([scene] * width, Profile(), BatchOptions(build=False, resumed=True))
    law = ContactLaw.from_scene(scene, cols.dt)
    st = cols.scheme.build_batch(cols.layout.problem, [law] * width, "cpu",
                                 scene.damping.tau)
    st.full_state_at = lambda level: False
    n = cols.layout.problem.n
    st.set_state(np.zeros((n, width)), np.zeros((n, width)))
    head = "stepper/"
    state = {k[len(head):]: v for k, v in plan.checkpoint.states[0].items()
             if k.startswith(head)}
    st.restore([dict(state) for _ in range(width)])
    return cols, st


def run_steps(stepper, dt: float, duration: float) -> float:  # noqa: ANN001
    """``duration`` rounded to whole steps of ``dt`` (at least one), stepped; the time
    advanced."""
    steps = max(1, int(round(duration / dt)))
    for _ in range(steps):
        stepper.step()
    return steps * dt


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def twin_kick(cols: BatchColumns, U: float, V: float, d0: float, seed: int
              ) -> tuple[np.ndarray, np.ndarray]:
    """(δu, δv) of the twin: the random start's radial bumps of seeds ``seed`` and
    ``seed + 1``, scaled to ``d0`` × the reference's RMS displacement ``U`` and velocity
    ``V`` (module docstring)."""
    kicks = []
    for scale, s in ((U, seed), (V, seed + 1)):
        shape = cols.problem.radial_field(random_bump(s, BUMP_MODES, 1.0))
        kicks.append(d0 * scale / rms(shape) * shape)
    return kicks[0], kicks[1]


def twin_distance(ref: tuple[np.ndarray, np.ndarray], twin: tuple[np.ndarray, np.ndarray],
                  U: float, V: float) -> float:
    """√((‖δu‖²/U² + ‖δv~‖²/V²)/2) between (u, v~) of the twin and of the reference, ‖·‖ the
    RMS over the dofs."""
    du, dv = twin[0] - ref[0], twin[1] - ref[1]
    return math.sqrt(0.5 * (float(np.mean(du**2)) / U**2 + float(np.mean(dv**2)) / V**2))


def pulled_back(ref: dict[str, np.ndarray], twin: dict[str, np.ndarray], factor: float
                ) -> dict[str, np.ndarray]:
    """The twin's checkpoint moved to the reference's + ``factor`` × the difference in every
    float array (the clock and the kernel's name stay)."""
    out = dict(twin)
    for name, value in twin.items():
        if np.ndim(value) and np.issubdtype(np.asarray(value).dtype, np.floating):
            out[name] = ref[name] + factor * (value - ref[name])
    return out


class BatchTwin:
    """A start's checkpoint as a batch of two columns: the reference and its twin (module
    docstring). Built from a run directory that a batch wrote (a census start)."""

    def __init__(self, run_dir: str | Path, d0: float = D0, seed: int = TWIN_SEED) -> None:
        cols, st = restored_batch(run_dir, 2)
        self.stepper, self.dt, self.t0 = st, float(cols.dt), float(st.time)
        self.U = rms(st.host_column("u", 0))
        self.V = rms(st.host_column("v_pred", 0))
        st.kick(1, *twin_kick(cols, self.U, self.V, d0, seed))

    def advance(self, duration: float) -> float:
        return run_steps(self.stepper, self.dt, duration)

    def _column(self, b: int) -> tuple[np.ndarray, np.ndarray]:
        return self.stepper.host_column("u", b), self.stepper.host_column("v_pred", b)

    def distance(self) -> float:
        return twin_distance(self._column(0), self._column(1), self.U, self.V)

    def rescale(self, factor: float) -> None:
        """Column 1's checkpoint moved to column 0's + ``factor`` × the difference in every
        float array, and both restored (``BatchedExplicit.state`` / ``restore``)."""
        st = self.stepper
        host = st.host_state()
        ref = st.state(0, host)
        st.restore([ref, pulled_back(ref, st.state(1, host), factor)])


class SceneTwin:
    """A one-scene run's checkpoint (no batch member: a 3D tube's start, say) as the
    reference and its twin, stepped in turn by one one-scene ``Simulation`` on this rank:
    each trajectory is a checkpoint (``Simulation.checkpoint``) that ``advance`` restores,
    steps and takes again, bit for bit a continuation. The twin starts at distance ``d0``
    along ``BatchTwin``'s kick (``twin_kick``); ``rescale`` pulls every float array of its
    checkpoint back (``pulled_back``). A one-scene run of a batch member's scene steps the
    same bits, so the two twins give the same exponent (tests/test_chaos.py)."""

    def __init__(self, run_dir: str | Path, d0: float = D0, seed: int = TWIN_SEED) -> None:
        from mpi4py import MPI  # a census rank's own twin: no other rank takes part

        plan = checkpoint_plan(run_dir)
        self.sim = Simulation(plan.scene, MPI.COMM_SELF)
        self.sim.restore([plan.checkpoint.states[0]], [None])
        self.dt = float(self.sim.dt)
        self.ref = self.sim.checkpoint()
        try:  # the implicit scheme's state has no v~, and its stepper refuses a kick
            self.U = rms(self.ref["stepper/u"])
            self.V = rms(self.ref["stepper/v_pred"])
            self.sim.stepper.kick(0, *twin_kick(self.sim.columns, self.U, self.V, d0, seed))
        except (KeyError, ValueError):
            raise NoTwin(f"{run_dir}: the implicit scheme's runs are not kicked: no "
                         "twin") from None
        self.twin = self.sim.checkpoint()

    def advance(self, duration: float) -> float:
        for name in ("ref", "twin"):
            self.sim.restore([getattr(self, name)], [None])
            advanced = run_steps(self.sim.stepper, self.dt, duration)
            setattr(self, name, self.sim.checkpoint())
        return advanced

    def distance(self) -> float:
        return twin_distance((self.ref["stepper/u"], self.ref["stepper/v_pred"]),
                             (self.twin["stepper/u"], self.twin["stepper/v_pred"]),
                             self.U, self.V)

    def rescale(self, factor: float) -> None:
        self.twin = pulled_back(self.ref, self.twin, factor)


def batch_member(run_dir: str | Path) -> bool:
    """True when ``run_dir`` is a batch member's run (a census start that a batch stepped:
    ``BatchTwin``), False for a one-scene run's (``SceneTwin``): its summary's ``batch``
    entry, which a checkpoint's kind must agree with (``rundir.checkpoint``; the twin reads
    and checks the checkpoint itself)."""
    summary = json.loads((Path(run_dir) / "summary.json").read_text())
    return isinstance(summary.get("batch"), dict)


@dataclass(frozen=True)
class Pair:
    """Two ranks of ``comm`` that share one twin test (``SplitTwin``): this rank's
    ``role`` (0 steps the reference, 1 the twin) and its ``partner``'s rank."""

    comm: object
    partner: int
    role: int


class TwinStopped(ValueError):
    """A paired twin test ended early on both ranks: one of them failed (its reason)."""


class SplitTwin:
    """``BatchTwin``'s two columns on the two ranks of a ``Pair``, each a batch of one: the
    same bits (the one-column kernel sums in the batched kernels' order, tests/test_chaos.py),
    in about half the time. Every ``tau`` the reference's rank sends its checkpoint to the
    twin's (one exchange), which measures the distance, sends it back (a second) and pulls
    itself back. Both ranks meet at every exchange whatever happens: a rank whose step
    raised sends its reason instead and both raise ``TwinStopped``; a signal is recorded
    (``fe_lyapunov``), sent as a stop, and both raise KeyboardInterrupt. So neither rank
    waits for a partner that has left."""

    def __init__(self, run_dir: str | Path, pair: Pair, signals: list[int], d0: float = D0,
                 seed: int = TWIN_SEED) -> None:
        self.pair = pair
        self.signals = signals  # SIGINT/SIGTERM/SIGHUP that came, recorded (``fe_lyapunov``)
        self.failure = ""
        self.ref: dict[str, np.ndarray] | None = None
        try:
            cols, st = restored_batch(run_dir, 1)
            self.stepper, self.dt = st, float(cols.dt)
            self.U = rms(st.host_column("u", 0))
            self.V = rms(st.host_column("v_pred", 0))
            if pair.role == 1:
                st.kick(0, *twin_kick(cols, self.U, self.V, d0, seed))
        except Exception as err:  # noqa: BLE001 - said to the partner at once
            self.failure, self.dt = f"{type(err).__name__}: {err}", math.nan
        self._exchange(None)  # both built, or both stop here

    def advance(self, duration: float) -> float:
        if self.failure:
            return duration
        try:
            return run_steps(self.stepper, self.dt, duration)
        except Exception as err:  # noqa: BLE001 - said to the partner at the exchange
            self.failure = f"{type(err).__name__}: {err}"
            return duration

    def _exchange(self, payload: object) -> object:
        """``payload`` to the partner, the partner's back; both ranks stop together where
        either failed or received a signal."""
        mine = ("failed", self.failure) if self.failure else \
            ("interrupted", "") if self.signals else ("ok", payload)
        pair = self.pair
        kind, theirs = pair.comm.sendrecv(mine, dest=pair.partner, source=pair.partner)
        if "interrupted" in (mine[0], kind):
            raise KeyboardInterrupt
        for (what, why), rank in ((mine, pair.comm.rank), ((kind, theirs), pair.partner)):
            if what == "failed":
                raise TwinStopped(f"the twin test failed on rank {rank}: {why}")
        return theirs

    def distance(self) -> float:
        st, twin = self.stepper, self.pair.role == 1
        ref = self._exchange(None if twin else st.state(0))
        d = None
        if twin:
            self.ref = ref
            d = twin_distance((ref["u"], ref["v_pred"]),
                              (st.host_column("u", 0), st.host_column("v_pred", 0)),
                              self.U, self.V)
        back = self._exchange(d)
        return float(d if twin else back)

    def rescale(self, factor: float) -> None:
        """The twin's rank: its checkpoint moved to the reference's + ``factor`` × the
        difference (as ``BatchTwin.rescale``); the reference's rank: nothing."""
        if self.pair.role == 1:
            self.stepper.restore([pulled_back(self.ref, self.stepper.state(0), factor)])


def fe_lyapunov(run_dir: str | Path, duration: float, tau: float, *, discard: int = 10,
                blocks: int = 10, pair: Pair | None = None) -> Lyapunov:
    """λ₁ of a census start where its checkpoint stands, over ``duration`` s of twin steps
    renormalised every ``tau`` s: on this rank (``BatchTwin``), or with ``pair`` on two
    ranks (``SplitTwin``; both call it and get the same exponent, bitwise that of one rank).
    A paired test records SIGINT/SIGTERM/SIGHUP while it runs (``deferred_signals``) and
    both ranks stop at the next exchange with KeyboardInterrupt."""
    intervals = max(discard + 2 * blocks, int(round(duration / tau)))
    if not batch_member(run_dir):  # each rank of a pair the same twin: the same exponent
        return benettin(SceneTwin(run_dir), tau, intervals, discard=discard, blocks=blocks)
    if pair is None:
        return benettin(BatchTwin(run_dir), tau, intervals, discard=discard, blocks=blocks)
    with deferred_signals() as came:
        twin = SplitTwin(run_dir, pair, came)
        lyap = benettin(twin, tau, intervals, discard=discard, blocks=blocks)
        if came:  # a signal after the last exchange
            raise KeyboardInterrupt
    return lyap


def verdict_text(verdict: dict) -> str:
    """Why a start at the cap is not chaotic, in one short clause: the observables whose
    statistics drift, or λ₁ with its error, or the test's own error."""
    stat = verdict.get("stationarity") or {}
    if stat and not stat.get("stationary", True):
        drifting = [name for name, o in (stat.get("observables") or {}).items()
                    if not o.get("stationary", True)]
        return "its statistics drift over the last leg (" + ", ".join(drifting) + ")"
    lyap = verdict.get("lyapunov") or {}
    if lyap and not lyap.get("positive"):
        return (f"λ₁ = {lyap['lambda1_per_s']:.3g} ± {lyap['lambda1_error_per_s']:.2g} 1/s, "
                "not > 0 beyond 3 standard errors")
    return "; ".join(verdict.get("why") or ())


def statistics_verdict(run_dir: str | Path, window: float, *, t_first: float = 0.0
                       ) -> tuple[dict, int]:
    """The first half of ``classify_at_cap``: the stationarity of the start's statistics
    over the windows of its last leg, as its verdict {"class": "unsettled", "why",
    "stationarity", "lyapunov": None} (``why`` filled when they are not stationary), and
    the number of those windows."""
    run_dir = Path(run_dir)
    with np.load(run_dir / "samples.npz") as z:
        samples = {k: z[k] for k in ("t", "u_r", "status") if k in z.files}
    t = samples["t"]
    ends = leg_window_ends(float(t[-1]), max(t_first, float(t[0])), window)
    stat = stationarity(t, fe_series(samples), ends, window)
    out = {"class": "unsettled", "why": [], "stationarity": stat, "lyapunov": None}
    if not stat["stationary"]:
        out["why"] = ["statistics not stationary: " + "; ".join(stat["why"])]
    return out, len(ends)


def with_lyapunov(verdict: dict, run_dir: str | Path, window: float, windows: int, *,
                  duration: float | None = None, tau: float | None = None,
                  pair: Pair | None = None) -> dict:
    """The second half of ``classify_at_cap``: the ``verdict`` of a start with stationary
    statistics over ``windows`` windows completed by λ₁ (``fe_lyapunov``, with ``pair`` on
    two ranks): ``chaotic`` when λ₁ > 0 beyond its error, else ``unsettled`` and why."""
    out = dict(verdict)
    tau = window / 20.0 if tau is None else tau
    duration = max(30 * tau, windows * window) if duration is None else duration
    lyap = fe_lyapunov(run_dir, duration, tau, pair=pair)
    out["lyapunov"] = lyap.to_dict()
    if lyap.positive:
        out["class"] = "chaotic"
    else:
        out["why"] = [f"lambda1 = {lyap.exponent:.4g} +- {lyap.error:.2g} 1/s: not > 0 "
                      "beyond its error"]
    return out


def classify_at_cap(run_dir: str | Path, window: float, *, t_first: float = 0.0,
                    duration: float | None = None, tau: float | None = None) -> dict:
    """A start ``unsettled`` at the cap: ``chaotic`` when its statistics are stationary
    across the windows of its last leg and λ₁ > 0 beyond its error, else ``unsettled``
    (module docstring). ``duration`` of the twin run: default the leg's windows together
    (at least 30 τ); ``tau``: default W/20. Returns {"class", "why", "stationarity",
    "lyapunov"} (the exponent only when the statistics are stationary)."""
    verdict, windows = statistics_verdict(run_dir, window, t_first=t_first)
    if not verdict["stationarity"]["stationary"]:
        return verdict
    return with_lyapunov(verdict, run_dir, window, windows, duration=duration, tau=tau)
