"""Chaos told apart from a slow transient (studies/attractors/chaos.py): Benettin's λ₁
validated on Lorenz 63 (chaotic, λ₁ ≈ 0.906) and a damped linear oscillator (λ₁ = −ζω
exactly) through the same function the FE twin uses; the stationarity test on a stationary
and a decaying signal; the FE twin (a second column of the batch) on a settled stick-slip
wave of the smoke mesh, where λ₁ must not be positive beyond its error."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from test_attractors import SMOKE

from stickslip.studies.attractors.chaos import (
    D0,
    benettin,
    classify_at_cap,
    fe_lyapunov,
    stationarity,
)


class ODETwin:
    """Reference and twin of dx/dt = f(x), RK4 at step h, distance the Euclidean norm."""

    def __init__(self, f, x0: np.ndarray, h: float, d0: float = D0, seed: int = 0) -> None:
        self.f, self.h = f, h
        self.x = np.array(x0, dtype=float)
        e = np.random.default_rng(seed).normal(size=self.x.size)
        self.y = self.x + d0 * e / np.linalg.norm(e)

    def _rk4(self, x: np.ndarray) -> np.ndarray:
        h, f = self.h, self.f
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        return x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)

    def advance(self, duration: float) -> float:
        n = max(1, int(round(duration / self.h)))
        for _ in range(n):
            self.x, self.y = self._rk4(self.x), self._rk4(self.y)
        return n * self.h

    def distance(self) -> float:
        return float(np.linalg.norm(self.y - self.x))

    def rescale(self, factor: float) -> None:
        self.y = self.x + factor * (self.y - self.x)


def lorenz(x: np.ndarray) -> np.ndarray:
    return np.array([10.0 * (x[1] - x[0]), x[0] * (28.0 - x[2]) - x[1],
                     x[0] * x[1] - 8.0 / 3.0 * x[2]])


def _on_attractor() -> np.ndarray:
    """A Lorenz state after 20 time units from (1, 1, 1): on the attractor."""
    twin = ODETwin(lorenz, np.ones(3), 0.01)
    twin.advance(20.0)
    return twin.x


def test_lorenz_lambda1_is_0906_within_its_error():
    """Lorenz 63 (σ = 10, ρ = 28, β = 8/3), λ₁ = 0.9056 (Sprott 2003, to 4 digits). 600
    renormalisations every 0.5 time units (300 units, about 400 Lyapunov times): the block
    standard error is about 0.02; the estimate must lie within 4 errors of 0.9056 and be
    positive beyond its error (0.906 ≫ 3 × 0.02)."""
    lyap = benettin(ODETwin(lorenz, _on_attractor(), 0.01), 0.5, 600, discard=20,
                    blocks=10)
    assert 0.0 < lyap.error < 0.06
    assert abs(lyap.exponent - 0.9056) < max(4 * lyap.error, 0.05), lyap
    assert lyap.positive


def test_damped_oscillator_gives_minus_zeta_omega():
    """x'' + 2ζω x' + ω² x = 0, ω = 1, ζ = 0.05: every perturbation decays as e^{−ζωt}
    (times a bounded oscillation), so λ₁ = −0.05; over 200 units the oscillation's share of
    the mean is O(1/(200 ω)); it is not positive."""
    zeta = 0.05
    twin = ODETwin(lambda x: np.array([x[1], -2 * zeta * x[1] - x[0]]),
                   np.array([1.0, 0.0]), 0.01)
    lyap = benettin(twin, 1.0, 220, discard=20, blocks=10)
    assert lyap.exponent == pytest.approx(-zeta, abs=0.01)
    assert not lyap.positive


def test_too_few_intervals_is_refused():
    with pytest.raises(ValueError, match="too few"):
        benettin(ODETwin(lorenz, np.ones(3), 0.01), 0.1, 15, discard=10, blocks=10)


def test_stationarity_tells_a_chaotic_signal_from_a_transient():
    """Lorenz's x(t) over 4 windows of 25 units is stationary (its mean wanders by
    σ√(2τ_c/W), τ_c ≈ 1: about 0.3σ); a decaying oscillation e^{−t/50} sin(5t) over the
    same windows loses 86 % of its amplitude (std ratio 7): not stationary; a constant is."""
    twin = ODETwin(lorenz, _on_attractor(), 0.01)
    ts, xs = [], []
    for _ in range(10000):
        ts.append(twin.advance(0.01))
        xs.append(twin.x[0])
    t = np.cumsum(ts)
    ends = [25.0, 50.0, 75.0, 100.0]
    chaotic = stationarity(t, {"x": np.array(xs)}, ends, 25.0)
    assert chaotic["stationary"], chaotic["why"]
    decay = stationarity(t, {"x": np.exp(-t / 50) * np.sin(5 * t)}, ends, 25.0)
    assert not decay["stationary"]
    assert decay["observables"]["x"]["spread_ratio"] > 2.0
    assert "x:" in decay["why"][0]
    flat = stationarity(t, {"c": np.full(t.size, 3.0)}, ends, 25.0)
    assert flat["stationary"]


@pytest.fixture(scope="module")
def settled_start(tmp_path_factory):
    """One census start on the smoke mesh (N = 36, Ω = 20, δ = 5e-3: as test_attractor_kick,
    whose starts settle on a stick-slip wave that returns from a 1 % kick), run as a batch
    member to 0.05 s (W = 1/60 s)."""
    pytest.importorskip("dolfinx")
    import json

    from stickslip.studies.attractors.census import Census, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    out = tmp_path_factory.mktemp("chaos") / "census"
    spec = Census(SMOKE, (36,), StartDistribution(starts=2),
                  ("loading.omega=20", "geometry.delta=0.005", "time.end_time=0.05"),
                  max_time=0.05)
    assert run_census(spec, out, certify=False, stream=io.StringIO()) == 0
    run = next(p.parent for p in (out / "starts" / "runs").glob("*/summary.json"))
    window = json.loads((out / "census.json").read_text())["window_s"]
    return run, window


def test_fe_twin_on_a_settled_wave_is_not_chaotic(settled_start):
    """The twin column of a settled stick-slip wave (3 W = 0.05 s of twin steps,
    renormalised every W/20 = 0.83 ms): λ₁ is not positive beyond its error (a relative
    equilibrium has a neutral direction along the wave, the others damped; measured
    19 ± 9 1/s: the contact's stick/slip switches make each interval's ln(d/d₀) scatter by
    ±0.1), and it is small against the flutter growth rates of the unstable modes
    (600 – 1200 1/s at N = 132, docs/attractors.md): |λ₁| < 60 1/s. The start's own run is
    not touched."""
    run, window = settled_start
    before = {p: p.read_bytes() for p in run.iterdir() if p.is_file()}
    lyap = fe_lyapunov(run, duration=3 * window, tau=window / 20)
    assert math.isfinite(lyap.exponent) and lyap.error > 0
    assert not lyap.positive, lyap.to_dict()
    assert abs(lyap.exponent) < 60.0, lyap.to_dict()
    assert {p: p.read_bytes() for p in before} == before


def test_a_one_scene_run_has_the_batch_members_twin(settled_start, tmp_path):
    """The census start's scene run alone to the same time (``stickslip.run``: one scene,
    the kernel's batch of one, the same bits as the batch member): its twin
    (``SceneTwin``: one Simulation stepping the reference and the twin in turn, each a
    checkpoint) gives the batch member's exponent (``BatchTwin``: two columns of one
    stepper) bit for bit, every interval's ln(d/d0) equal. A 3D tube's start is such a
    one-scene run. The implicit scheme's run has no twin (it is not kicked): ``NoTwin``."""
    from stickslip import run as run_scene_api
    from stickslip.studies.attractors.chaos import NoTwin, SceneTwin, batch_member

    member, window = settled_start
    alone = tmp_path / "alone"
    summary = run_scene_api(member / "scene.toml", alone, force=True, quiet=True)
    assert summary["status"] == "completed"
    assert batch_member(member) and not batch_member(alone)
    a = np.load(member / "samples.npz")["u_r"]
    np.testing.assert_array_equal(np.load(alone / "samples.npz")["u_r"], a)
    tau = window / 20
    ours = fe_lyapunov(alone, duration=30 * tau, tau=tau)
    theirs = fe_lyapunov(member, duration=30 * tau, tau=tau)
    assert ours.logs == theirs.logs and ours.exponent == theirs.exponent, (ours, theirs)
    implicit = tmp_path / "implicit"
    run_scene_api(member / "scene.toml", implicit, overrides=["time.beta1=0.3"], force=True,
                  quiet=True)
    with pytest.raises(NoTwin, match="not kicked"):
        SceneTwin(implicit)


def test_classify_at_cap_of_a_settled_wave_is_unsettled_not_chaotic(settled_start):
    """Its statistics are stationary (a rigid wave's are constant) but λ₁ is not positive:
    ``unsettled`` with the reason, never ``chaotic``."""
    run, window = settled_start
    out = classify_at_cap(run, window, tau=window / 40)
    assert out["class"] == "unsettled"
    assert out["why"]
