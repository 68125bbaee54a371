"""The frequency lattice of an end state (studies/attractors/lattice.py): generators in the
documented order, combination tones with their coefficients, the type, the period and shift
of a relative periodic orbit; names that give the generators only; a settled test that does
not compare the tones' shares. Synthetic components and fields only (well under a second
each, no FE run)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stickslip.studies.attractors.classify import classify_features, readable_name
from stickslip.studies.attractors.features import (
    TONE_BINS,
    Component,
    Features,
    member_key,
    settle_verdict,
    share_drift,
    stationary,
)
from stickslip.studies.attractors.lattice import lattice_of, tone_text
from stickslip.studies.attractors.statistics import mesh_members

#: The census's window W = 0.1 s: resolution 1/W = 10 Hz, tones within 1 bin = 10 Hz.
RESOLUTION_HZ = 10.0
TOL_HZ = TONE_BINS * RESOLUTION_HZ
SSS = {"regime": "stick-slip-separation"}


def _c(k, f, share, *, aliased=False, radius=1.0):
    """A component (k, signed lab frequency f in Hz, share), its celerity 2πRf/k."""
    return Component(k=k, direction="rotation" if f > 0 else "opposite", share=share,
                     amplitude_m=1e-3 * share, frequency_hz=math.nan if aliased else f,
                     celerity_m_s=math.nan if aliased else 2 * math.pi * radius * f / k,
                     aliased=aliased, weak=share < 0.1)


def _features(comps, frame_spread=math.nan, window=(0.2, 0.3)):
    comps = tuple(sorted(comps, key=lambda c: -c.share))
    return Features(comps, {"separation": 0.7, "stick": 0.14, "slip": 0.16},
                    rms_amplitude_m=1e-3, window=window, resolution_hz=RESOLUTION_HZ,
                    frame_spread=frame_spread)


# The issue's state: k = 6 and k = 10 against the rotation; k = 4 at (10) − (6) and k = 2 at
# 2·(6) − (10), both at the 10 % listing threshold (one listed, one weak).
F6, F10 = -927.26, -990.96
ISSUE = [_c(6, F6, 1.0), _c(10, F10, 0.17), _c(2, 2 * F6 - F10, 0.100),
         _c(4, F10 - F6, 0.099)]


def test_the_issue_state_is_a_relative_periodic_orbit_of_two_generators():
    lat = lattice_of(ISSUE, TOL_HZ)
    assert [g.k for g in lat.generators] == [6, 10]
    tones = {t.component.k: t.coefficients for t in lat.tones}
    assert tones == {2: (2, -1), 4: (-1, 1)}
    assert [tone_text(t.coefficients, [6, 10]) for t in lat.tones] == ["2(6) − (10)",
                                                                       "−(6) + (10)"]
    assert lat.type == "relative periodic orbit"
    # f' = f₂ − (k₂/k₁) f₁ = −990.96 + (10/6)·927.26 = 554.4733 Hz, the issue's 554.47 Hz
    assert lat.frame_frequency(lat.generators[1]) == pytest.approx(554.4733, abs=1e-4)
    assert lat.period_s == pytest.approx(1 / 554.47333, rel=1e-6)
    assert lat.shift_deg == pytest.approx(360 * F6 * lat.period_s / 6, rel=1e-12)
    facts = lat.to_dict()
    assert [g["k"] for g in facts["generators"]] == [6, 10]
    assert facts["combinations"][0]["coefficients"] == [2, -1]
    assert facts["frame_frequency_hz"] == pytest.approx(554.4733, abs=1e-4)


def test_period_and_shift_reproduce_the_field():
    """The field Σ A cos(kθ − 2πft + φ) of the issue's components satisfies
    u(θ, t + T) = u(θ − s, t) with the lattice's T and s (to round-off), and at no
    shorter time with the dominant frame's turn: T is the period in that frame."""
    lat = lattice_of(ISSUE, TOL_HZ)
    theta = np.linspace(0, 2 * np.pi, 400, endpoint=False)

    def u(th, t):
        return sum(c.share * np.cos(c.k * th - 2 * np.pi * c.frequency_hz * t + 0.7 * i)
                   for i, c in enumerate(ISSUE))

    t0, T, s = 0.0123, lat.period_s, math.radians(lat.shift_deg)
    assert np.max(np.abs(u(theta, t0 + T) - u(theta - s, t0))) < 1e-9
    half = 0.5 * T  # half a period later the pattern in the frame differs by O(1)
    assert np.max(np.abs(u(theta, t0 + half) - u(theta - 0.5 * s, t0))) > 0.1


def test_k10_with_k1_carries_k9_as_a_tone_and_the_order_is_by_share():
    """"k = 10 with k = 1 (13 %)": k = 9 at f₁₀ − f₁ is the tone (10) − (1); where k = 9
    is the larger (24 %), it is the second generator and k = 1 the tone (10) − (9): the same
    lattice, the same period."""
    f10, f1 = -1550.7, -60.3
    small = lattice_of([_c(10, f10, 1.0), _c(1, f1, 0.13), _c(9, f10 - f1, 0.12)], TOL_HZ)
    assert [g.k for g in small.generators] == [10, 1]
    assert [(t.component.k, t.coefficients) for t in small.tones] == [(9, (1, -1))]
    large = lattice_of([_c(10, f10, 1.0), _c(9, f10 - f1, 0.24), _c(1, f1, 0.13)], TOL_HZ)
    assert [g.k for g in large.generators] == [10, 9]
    assert [(t.component.k, t.coefficients) for t in large.tones] == [(1, (1, -1))]
    assert small.type == large.type == "relative periodic orbit"
    assert small.period_s == pytest.approx(large.period_s, rel=1e-12)


def test_tolerance_bound_and_the_other_types():
    # 1 bin: a tone 9 Hz off is one, 11 Hz off is a third generator: a torus
    near = ISSUE[:3] + [_c(4, F10 - F6 + 9.0, 0.099)]
    far = ISSUE[:3] + [_c(4, F10 - F6 + 11.0, 0.12)]
    assert lattice_of(near, TOL_HZ).type == "relative periodic orbit"
    torus = lattice_of(far, TOL_HZ)
    assert [g.k for g in torus.generators] == [6, 10, 4] and torus.type == "torus"
    assert math.isnan(torus.period_s)
    # |n| ≤ 4: 5·(6) − 2·(10) is a generator, 4·(6) − 2·(10) a tone
    assert lattice_of(ISSUE[:2] + [_c(4, 4 * F6 - 2 * F10, 0.2)], TOL_HZ).tones
    assert not lattice_of(ISSUE[:2] + [_c(10, 5 * F6 - 2 * F10, 0.2)], TOL_HZ).tones
    # without a finite tolerance (no resolution) nothing is a tone
    assert len(lattice_of(ISSUE, math.nan).generators) == 3  # the weak k = 4 is "other"
    # one component: a rigid wave; k = 4 and 6 at one celerity: a rigid pattern of both
    rigid = lattice_of([_c(6, F6, 1.0)], TOL_HZ)
    assert rigid.type == "rigid wave" and math.isnan(rigid.period_s)
    pattern = lattice_of([_c(6, F6, 1.0), _c(4, 4 / 6 * F6, 0.3)], TOL_HZ)
    assert len(pattern.generators) == 2 and pattern.type == "rigid wave"
    # a weak independent component generates only where allowed (named with it)
    weak = [_c(6, F6, 1.0), _c(7, -700.0, 0.07)]
    assert [c.k for c in lattice_of(weak, TOL_HZ).others] == [7]
    assert lattice_of(weak, TOL_HZ, weak_generators=True).type == "relative periodic orbit"
    # an aliased component (frequency unknown) cannot be shown a tone: it generates
    aliased = lattice_of(ISSUE[:2] + [_c(30, 0.0, 0.15, aliased=True)], TOL_HZ)
    assert [g.k for g in aliased.generators] == [6, 10, 30] and aliased.type == "torus"
    # a member known by its summary only (no frequency): one generator, no tone searched
    bare = Component(k=11, direction="opposite", share=1.0, amplitude_m=math.nan,
                     frequency_hz=None, celerity_m_s=None)
    assert lattice_of([bare, _c(4, -60.0, 0.3)], TOL_HZ).type == "relative periodic orbit"


def test_names_and_ids_give_the_generators_whichever_side_of_the_threshold():
    """The tones at 10.0 % and 9.9 % never enter the name or the member id; with the
    tone k = 4 listed (10.1 %) or weak (9.9 %) the name is the same."""
    for share in (0.101, 0.099):
        feats = _features(ISSUE[:3] + [_c(4, F10 - F6, share)])
        named = feats.named(False)
        assert readable_name(named) == ("k = 6 against the rotation, carrying k = 10 against "
                                        "the rotation (17 %)")
        assert member_key(named, "stick-slip-separation", with_weak=True) == "k6-opposite-SSS+k10"


def test_member_rows_carry_type_generators_and_combinations():
    """A member of two starts (``statistics.mesh_members``) carries its type, generators
    (with k, direction, frequency, celerity, share) and tones with coefficients; T and s."""
    feats = _features(ISSUE)
    rows = [{"id": f"s{i}", "seed": i, "class": "multi-wave", "member": "k6-opposite-SSS+k10",
             "k": 6, "direction": "opposite", "regime": "stick-slip-separation",
             "celerity_m_s": ISSUE[0].celerity_m_s, "features": feats.to_dict(),
             **{k: 0.5 for k in ("frequency_hz", "fraction_separation", "fraction_stick",
                                 "fraction_slip", "psi1", "psi2", "amplitude_m",
                                 "rms_amplitude_m")}} for i in (1, 2)]
    (m,) = mesh_members(rows)
    assert m["type"] == "relative periodic orbit"
    assert [(g["k"], g["direction"]) for g in m["generators"]] == [(6, "opposite"),
                                                                  (10, "opposite")]
    assert {"frequency_hz", "celerity_m_s", "share"} <= set(m["generators"][1])
    assert [(c["k"], c["coefficients"]) for c in m["combinations"]] == [(2, [2, -1]),
                                                                       (4, [-1, 1])]
    assert m["period_s"] == pytest.approx(1 / 554.47333, rel=1e-6)
    assert m["name"] == ("k = 6 against the rotation, carrying k = 10 against the rotation "
                         "(17 %)")
    assert m["label"] == ("multi-wave k = 6 against the rotation carrying k = 10 against the "
                          "rotation")


def test_settled_whatever_the_window_tones_swing_generators_do_not():
    """Two windows of one two-frequency state: the tones' shares swing (16 and 5 %, then 5
    and 14 %) and with them the frame spread; the generators keep their frequencies and
    shares: stationary, a multi-wave attractor, no share drift. A generator's share that
    moves, or an independent companion's, still unsettles."""
    def window(s2, s4, spread, s10=0.17, t=0.3):
        return _features([_c(6, F6, 1.0), _c(10, F10, s10), _c(2, 2 * F6 - F10, s2),
                          _c(4, F10 - F6, s4)], spread, (t - 0.1, t))

    earlier, later = window(0.16, 0.05, 0.25, t=0.2), window(0.05, 0.14, 0.19, t=0.3)
    assert stationary(earlier, later) == []
    assert classify_features("completed", SSS, earlier, later) == ("multi-wave", [])
    leg = [window(0.16, 0.05, 0.25, t=0.1), earlier, later, window(0.04, 0.16, 0.2, t=0.4)]
    assert share_drift(leg, 0.3) == []
    moved = window(0.05, 0.14, 0.19, s10=0.25)
    assert stationary(earlier, moved) == ["k = 10 against the rotation share 17 vs 25 %"]
    other = [_c(6, F6, 1.0), _c(10, F10, 0.17), _c(3, -300.0, 0.3)]
    assert stationary(_features(other), _features(other[:2] + [_c(3, -300.0, 0.2)])) == [
        "k = 3 against the rotation share 30 vs 20 %"]


def test_samples_of_a_two_frequency_state_with_swinging_tones_settle():
    """The whole path from samples (``settle_verdict``): k = 6 and 10 at the issue's
    frequencies, constant, and the tones k = 2, 4 whose amplitudes swing by ± 50 % at 4 Hz
    (shares 5 – 15 % between windows of 0.05 s, the frame spread 0.19 – 0.27). The refined
    peaks place the tones within a bin (20 Hz here): a relative periodic orbit, settled at
    the first pair; with the tones' shares compared (no tolerance: resolution NaN, so no
    tones) the same windows are not stationary."""
    theta = np.linspace(0.0, 2 * np.pi, 36, endpoint=False)
    t = np.arange(0.0, 0.3 + 5e-5, 1e-4)
    swing = 1.0 + 0.5 * np.sin(2 * np.pi * 4.0 * t)[:, None]
    field = sum(a * np.cos(k * theta[None, :] - 2 * np.pi * f * t[:, None] + 0.4 * k)
                for k, f, a in ((6, F6, 1.0), (10, F10, 0.17)))
    field += swing * sum(a * np.cos(k * theta[None, :] - 2 * np.pi * f * t[:, None])
                         for k, f, a in ((2, 2 * F6 - F10, 0.1), (4, F10 - F6, 0.1)))
    samples = {"t": t, "theta": theta, "u_r": 1e-3 * field, "u_theta": 3e-4 * field}
    v = settle_verdict(samples, 1.0, 0.05)
    shares = {c.k: c.share for c in v.earlier.components}, {c.k: c.share
                                                            for c in v.later.components}
    assert abs(shares[0][4] - shares[1][4]) > 0.02  # the tone's share swings
    lat = v.later.lattice(False)
    assert [g.k for g in lat.generators] == [6, 10] and lat.type == "relative periodic orbit"
    assert lat.period_s == pytest.approx(1 / 554.47333, rel=1e-4)
    assert v.settle_time == pytest.approx(0.1, abs=1.1e-4) and v.drift == ()
    blind = [Features(f.components, f.fractions, f.rms_amplitude_m, f.window, f.nyquist_hz,
                      math.nan, f.frame_spread) for f in (v.earlier, v.later)]
    assert stationary(*blind)
