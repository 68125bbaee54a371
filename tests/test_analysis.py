"""Wave analysis (solver/analysis.py) on synthetic travelling waves with known k, c and zones.

Pure numpy: no dolfinx. The synthetic waves are exact travelling waves u(s), s the time-ordered
co-moving coordinate of paper eq. [3], sampled on N nodes and at discrete times like the FE
recorder, so every recovered number has only a discretisation error, bounded below.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from stickslip.postprocess.analysis import (
    analyse,
    analyse_run,
    angular_speed,
    comoving_coordinate,
    comoving_profile,
    load_run,
    mode_phase,
    phase_diagram,
    probe_frequency,
    run_profile,
    zone_layout,
)
from stickslip.solver.contact import SEPARATION, SLIP, STICK

D = 4e-4  # mismatch (m), R = 1 m


def synthetic(k: int, c: float, zones: list[tuple[int, float]], n: int = 132,
              dt: float = 1e-4, t_end: float = 0.1, amp_r: float = 2e-3,
              amp_t: float = 1e-3) -> dict[str, np.ndarray]:
    """Exact travelling wave with zones [(status, end/T), ...] in time order (s from 0).

    s = -sign(c) (theta - c t) mod T grows in time at a node (semianalytic.waves convention).
    u_r - d is a half-sine bump over each separation zone, 0 in contact; u_theta = amp_t cos.
    """
    theta = np.arange(n) * 2 * np.pi / n
    t = np.arange(0.0, t_end, dt)
    T = 2 * np.pi / k
    sig = -1.0 if c > 0 else 1.0
    s = np.mod(sig * (theta[None, :] - c * t[:, None]), T) / T  # in [0, 1)
    status = np.empty(s.shape, dtype=np.int8)
    u_r = np.full(s.shape, D)
    start = 0.0
    for code, end in zones:
        m = (s >= start) & (s < end)
        status[m] = code
        if code == SEPARATION:
            u_r[m] += amp_r * np.sin(np.pi * (s[m] - start) / (end - start))
        start = end
    u_t = amp_t * np.cos(2 * np.pi * s)
    ds_dt = abs(c) / T  # in periods per second
    v_r = np.gradient(u_r, dt, axis=0)
    v_t = -amp_t * 2 * np.pi * ds_dt * np.sin(2 * np.pi * s)
    return {"t": t, "theta": theta, "u_r": u_r, "u_theta": u_t, "v_r": v_r, "v_theta": v_t,
            "status": status}


PAPER = [(SEPARATION, 0.716), (STICK, 0.784), (SLIP, 1.0)]  # paper Figure 1 psi1, psi2


@pytest.mark.parametrize("c", [-2500.0, 1700.0])
@pytest.mark.parametrize("k", [2, 4])
def test_stick_slip_separation_recovered(k: int, c: float) -> None:
    w = synthetic(k, c, PAPER)
    res = analyse(w["t"], w["theta"], w["u_r"], w["u_theta"], w["status"], d=D, radius=1.0,
                  window=0.1)
    assert res.regime == "stick-slip-separation"
    assert res.mode == k
    # The profile is an exact translate, so the mode-k phase is exactly linear in t except
    # for the jitter of a discontinuous profile sampled on 132 nodes: 1e-3 relative is ample.
    assert res.angular_speed_rad_s == pytest.approx(c, rel=1e-3)
    assert res.celerity_m_s == pytest.approx(c, rel=1e-3)  # R = 1 m
    assert res.frequency_hz == pytest.approx(k * abs(c) / (2 * np.pi), rel=1e-3)
    assert res.direction == ("rotation" if c > 0 else "opposite")
    # Zone boundaries fall between nodes: N/k = 33..66 nodes a period, and the many sample
    # times place the boundaries everywhere in between, so the bias is < one node a boundary
    # and averages out; 0.01 (= 2 bins of 200) bounds it.
    assert res.psi1 == pytest.approx(0.716, abs=0.01)
    assert res.psi2 == pytest.approx(0.784, abs=0.01)
    assert res.fractions["separation"] == pytest.approx(0.716, abs=0.01)
    assert res.fractions["stick"] == pytest.approx(0.068, abs=0.01)
    assert res.zone_order == "separation->stick->slip"
    assert res.paper_order
    z, a, b = res.layout[0]
    assert z == "separation" and a == 0.0 and b == pytest.approx(0.716, abs=0.01)
    assert res.amplitude_r_m == pytest.approx(2e-3, rel=1e-2)  # bump peak on a node grid
    assert res.limit_cycle


def test_swapped_zone_order_is_reported_not_relabelled() -> None:
    """FE-like order separation -> slip -> stick -> slip: psi from fractions, order flagged."""
    zones = [(SEPARATION, 0.69), (SLIP, 0.76), (STICK, 0.92), (SLIP, 1.0)]
    w = synthetic(4, -2500.0, zones)
    res = analyse(w["t"], w["theta"], w["u_r"], w["u_theta"], w["status"], d=D, radius=1.0)
    assert res.zone_order == "separation->slip->stick->slip"
    assert not res.paper_order
    assert res.psi1 == pytest.approx(0.69, abs=0.01)
    assert res.psi2 - res.psi1 == pytest.approx(0.16, abs=0.01)  # stick fraction
    bounds = [b for _, _, b in res.layout]
    assert np.allclose(bounds, [0.69, 0.76, 0.92, 1.0], atol=0.01)


@pytest.mark.parametrize("c", [-1670.0, 1500.0])
def test_stick_slip_uses_tangential_field(c: float) -> None:
    """No separation: the mode and phase come from u_theta (U = delta in a stick-slip wave)."""
    w = synthetic(4, c, [(STICK, 0.086), (SLIP, 1.0)])
    res = analyse(w["t"], w["theta"], w["u_r"], w["u_theta"], w["status"], d=D, radius=2.0)
    assert res.regime == "stick-slip"
    assert res.mode == 4
    assert res.angular_speed_rad_s == pytest.approx(c, rel=1e-6)  # smooth cosine: exact
    assert res.celerity_m_s == pytest.approx(2.0 * c, rel=1e-6)  # c R with R = 2 m
    assert res.psi1 == 0.0
    assert res.psi2 == pytest.approx(0.086, abs=0.01)
    assert res.zone_order == "stick->slip" and res.paper_order
    assert res.amplitude_theta_m == pytest.approx(1e-3, rel=1e-3)
    assert res.amplitude_r_m == 0.0


def test_aliased_sampling_needs_and_uses_the_frequency_hint() -> None:
    """k |c| dt_s > pi: the phase unwrap alone aliases; the probe frequency fixes it."""
    k, c, dts = 4, -2500.0, 4e-4  # 1592 Hz sampled at 2500 Hz: 0.64 cycles per sample
    w = synthetic(k, c, PAPER, dt=dts, t_end=0.2)
    naive = angular_speed(w["t"], w["u_r"] - D, w["theta"], k)
    assert abs(naive - c) > 100.0  # aliased: wrong speed (and here the wrong sign)
    f_true = k * abs(c) / (2 * np.pi)
    fixed = angular_speed(w["t"], w["u_r"] - D, w["theta"], k, frequency_hz=f_true * 1.001)
    # the hint only picks the alias branch; the speed itself comes from the phase data
    assert fixed == pytest.approx(c, rel=1e-3)


def test_probe_frequency_of_a_sampled_sine() -> None:
    t = np.arange(0, 0.05, 2.5e-5)
    f0 = 1595.9
    # Parabolic peak interpolation on a Hann window: error well below the bin width 20 Hz.
    assert probe_frequency(t, np.sin(2 * np.pi * f0 * t) + 0.3) == pytest.approx(f0, abs=2.0)


def test_comoving_profile_recovers_the_wave_shape() -> None:
    k, c = 4, -2500.0
    w = synthetic(k, c, PAPER)
    phase = mode_phase(w["u_r"] - D, w["theta"], k)
    s = comoving_coordinate(w["theta"], phase, k, c)
    prof = comoving_profile(s, {"u_r": w["u_r"] - D}, w["status"], k, nbins=100)
    layout = zone_layout(prof)
    assert [z for z, _, _ in layout] == ["separation", "stick", "slip"]
    # bump of 2 mm over 71.6 % of the period, 0 in contact: bin means within 3 % of the peak
    # (a bin is 1 % of the period wide; the bump's slope is at most pi * 2 mm / 0.716)
    T = 2 * np.pi / k
    x = np.mod(prof["s"] / T - layout[0][1], 1.0)
    exact = np.where(x < 0.716, 2e-3 * np.sin(np.pi * x / 0.716), 0.0)
    assert np.max(np.abs(_align(prof["u_r"], exact))) < 0.03 * 2e-3


def _align(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a - b after the circular shift that matches them best."""
    shifts = [np.max(np.abs(np.roll(a, -i) - b)) for i in range(a.size)]
    i = int(np.argmin(shifts))
    return np.roll(a, -i) - b


def test_run_directory_round_trip(tmp_path) -> None:
    """analyse_run / run_profile / phase_diagram read a run directory like the FE writes."""
    k, c = 4, -2500.0
    w = synthetic(k, c, PAPER, t_end=0.12)
    pt = np.arange(0.0, 0.12, 2.5e-5)
    th0 = 0.0
    sig = 1.0
    s0 = np.mod(sig * (th0 - c * pt), 2 * np.pi / k) / (2 * np.pi / k)
    probe = np.zeros((1, pt.size, 4))
    probe[0, :, 0] = D + np.where(s0 < 0.716, 2e-3 * np.sin(np.pi * s0 / 0.716), 0.0)
    probe[0, :, 2] = np.gradient(probe[0, :, 0], pt)
    np.savez(tmp_path / "samples.npz", **w, probe_t=pt, probe_data=probe,
             probe_deg=np.array([0.0]), energies=np.zeros((w["t"].size, 5)))
    (tmp_path / "scene.toml").write_text(
        'name = "synthetic"\n[geometry]\nR = 1.0\nxi = 1.25\ndelta = 0.0004\n'
        '[loading]\nomega = 50.0\nf = 0.7\n[output]\nprobes_deg = [0.0]\n')
    (tmp_path / "summary.json").write_text(json.dumps({"status": "completed"}))
    res = analyse_run(tmp_path)
    assert res.mode == k and res.celerity_m_s == pytest.approx(c, rel=1e-3)
    assert res.psi1 == pytest.approx(0.716, abs=0.01)
    run = load_run(tmp_path)
    prof = run_profile(run, res)
    assert prof["frac_separation"][:5].min() > 0.5  # rotated: separation starts at s = 0
    pd = phase_diagram(run)
    assert pd["u_r"].max() == pytest.approx(2e-3, rel=0.02)
    assert pd["theta_deg"] == 0.0
