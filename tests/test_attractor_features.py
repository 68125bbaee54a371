"""Features of end states (studies/attractors/features.py): travelling components recovered
from synthetic space-time fields with known components, harmonics and aliases; the matching
rule (grouping, stationarity); names; and one small real census."""

from __future__ import annotations

import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from stickslip.studies.attractors.classify import classify_features, group_members
from stickslip.studies.attractors.features import (
    Component,
    Features,
    describe,
    differences,
    match,
    member_key,
    settle_verdict,
    share_drift,
    stationary,
    travelling_components,
    window_features,
)

REPO = Path(__file__).resolve().parents[1]
N = 132  # contact nodes
DT_S = 1.0378e-4  # sample interval of the damped scenes: Nyquist 4818 Hz
STEPS_PER_SAMPLE = 4  # the every-step probe's oversampling
D = 8e-4  # mismatch (m), the radial offset of u_r


def _field(components, t, theta):
    """Σ A cos(k(θ − c t) + φ) over (k, c in m/s at R = 1, A) on the grid t x θ."""
    u = np.zeros((t.size, theta.size))
    for i, (k, c, a) in enumerate(components):
        u += a * np.cos(k * (theta[None, :] - c * t[:, None]) + 0.3 * i)
    return u


# k = 12 at −900 m/s with k = 13 at −862 m/s (amplitude 0.21 of k = 12's), the harmonic
# k = 24 travelling with k = 12 (0.15), the harmonic k = 36 whose frequency 36·900/2π = 5157 Hz
# is above the Nyquist frequency (0.10), and k = 30 at −1100 m/s, 5252 Hz, also above it
# (0.15), which the samples show folded to +4384 Hz, i.e. as a wave with the rotation.
A12 = 1e-3
TRUE = [(12, -900.0, A12), (13, -862.0, 0.21 * A12), (24, -900.0, 0.15 * A12),
        (36, -900.0, 0.10 * A12), (30, -1100.0, 0.15 * A12)]


def _samples(components=TRUE, span=0.5, probes=True):
    theta = 2 * np.pi * np.arange(N) / N
    t = np.arange(int(span / DT_S)) * DT_S
    u_theta = _field(components, t, theta)
    u_r = D + 0.3 * u_theta  # the same components in u_r, a third of the size
    out = {"t": t, "theta": theta, "u_r": u_r, "u_theta": u_theta}
    if probes:  # every step at θ = 0
        tp = np.arange(t.size * STEPS_PER_SAMPLE) * (DT_S / STEPS_PER_SAMPLE)
        up = _field(components, tp, np.zeros(1))[:, 0]
        out.update(probe_t=tp, probe_data=np.stack([D + 0.3 * up, up], axis=1)[None])
    return out


def _components(samples):
    return travelling_components(samples["t"], samples["theta"], samples["u_r"],
                                 samples["u_theta"], 1.0, probe_t=samples.get("probe_t"),
                                 probe=samples["probe_data"][0] if "probe_data" in samples
                                 else None)


def test_components_celerities_shares_harmonics_and_aliases():
    comps = _components(_samples())
    listed = {c.k: c for c in comps if not c.weak}
    assert sorted(listed) == [12, 13, 30]
    top, second, folded = listed[12], listed[13], listed[30]
    assert comps[0] is top and top.direction == second.direction == "opposite"
    # Clean tones: the refined peak of the Hann-windowed transform is the tone's frequency
    # up to the bounded search's 1e-7 bin, so the celerities are exact to ~1e-9.
    assert top.celerity_m_s == pytest.approx(-900.0, rel=1e-6)
    assert second.celerity_m_s == pytest.approx(-862.0, rel=1e-6)
    assert top.frequency_hz == pytest.approx(-12 * 900 / (2 * np.pi), rel=1e-6)
    # k = 24 and 36 travel with k = 12: its harmonics, not components; 36 is aliased.
    assert [(h["k"], h["of"], h["aliased"]) for h in top.harmonics] == [
        (24, "×2", False), (36, "×3", True)]
    # Shares: amplitude over the dominant's, the dominant with its harmonics
    # sqrt(1 + 0.15² + 0.10²); at the exact peak the window's gain cancels (1e-6: the
    # sidelobes of the other tones of the same k, none here, and round-off).
    total = math.sqrt(1 + 0.15**2 + 0.10**2)
    assert second.share == pytest.approx(0.21 / total, rel=1e-6)
    assert folded.share == pytest.approx(0.15 / total, rel=1e-6)
    assert top.amplitude_m == pytest.approx(A12 * total * math.sqrt(1 + 0.3**2), rel=1e-6)
    # k = 30 above the Nyquist frequency: the every-step probe holds nothing at the folded
    # frequency, so it is flagged and has no speed.
    assert folded.aliased and math.isnan(folded.celerity_m_s)
    assert math.isnan(folded.frequency_hz)
    assert describe(comps) == ("k = 12 against the rotation, with k = 13 (21 %) and "
                               "k = 30 (15 %, aliased)")
    # attractors.json keeps them as they are (plain JSON types, the flags included)
    text = json.dumps(Features(comps).to_dict())
    assert json.dumps(Features.from_dict(json.loads(text)).to_dict()) == text


def test_without_probes_only_harmonics_and_the_nyquist_edge_are_flagged():
    """Without every-step probes a component folded from above f_s/2 looks like one below
    (documented): k = 30 is then listed with its folded speed; a component within a bin of
    f_s/2 is flagged."""
    comps = {c.k: c for c in _components(_samples(probes=False))}
    assert not comps[30].aliased and comps[30].direction == "rotation"
    f_nyq = 0.5 / DT_S
    edge = [(12, -900.0, A12), (20, 2 * np.pi * f_nyq / 20, 0.5 * A12)]
    comps = {c.k: c for c in _components(_samples(edge, probes=False))}
    assert comps[20].aliased and math.isnan(comps[20].celerity_m_s)


def test_window_features_fractions_and_rms():
    s = _samples([(12, -900.0, A12), (13, -862.0, 0.21 * A12)])
    s["status"] = np.zeros(s["u_r"].shape, dtype=np.int8)  # 0: separation everywhere
    f = window_features(s, 1.0, 0.25, 0.5)
    assert f.window == (0.25, 0.5) and f.nyquist_hz == pytest.approx(0.5 / DT_S)
    assert len(f.listed) == 2 and not f.rigid
    # RMS of the travelling part: sqrt((1 + 0.3²)(1 + 0.21²) A² / 2), exact on the full grid
    # up to the window's partial periods (1e-3).
    rms = A12 * math.sqrt((1 + 0.3**2) * (1 + 0.21**2) / 2)
    assert f.rms_amplitude_m == pytest.approx(rms, rel=1e-3)
    assert sum(f.fractions.values()) == pytest.approx(1.0)


def _features(shares, celerity=-900.0, fractions=None, aliased=()):
    comps = [Component(k=k, direction="opposite", share=s, amplitude_m=s * 1e-3,
                       frequency_hz=k * celerity / (2 * np.pi), celerity_m_s=celerity,
                       aliased=k in aliased, weak=s < 0.1) for k, s in shares.items()]
    comps.sort(key=lambda c: -c.share)
    return Features(tuple(comps), fractions or {"separation": 0.7, "stick": 0.14,
                                                "slip": 0.16})


def test_match_rule_and_its_tolerances():
    a = _features({12: 1.0, 13: 0.21, 11: 0.20})
    assert match(a, _features({12: 1.0, 13: 0.215, 11: 0.19}))  # 1 point apart (≤ 2)
    assert match(a, _features({12: 1.0, 13: 0.21, 11: 0.20}, celerity=-900 * 1.019))
    assert not match(a, _features({12: 1.0, 13: 0.21, 11: 0.20}, celerity=-900 * 1.021))
    assert differences(a, _features({12: 1.0, 13: 0.30, 11: 0.20})) == [
        "k = 13 against the rotation share 21 vs 30 %"]
    # A companion listed in one and weak (5 – 10 %) in the other still matches; absent, not.
    assert match(_features({12: 1.0, 13: 0.105}), _features({12: 1.0, 13: 0.095}))
    assert differences(a, _features({12: 1.0, 13: 0.21})) == [
        "k = 11 against the rotation in one only"]
    assert not match(a, _features({12: 1.0, 13: 0.21, 11: 0.20},
                                  fractions={"separation": 0.75, "stick": 0.1, "slip": 0.15}))
    # k = 6 at f₅ + f₁ is a sum tone: attached to k = 5 in one end state (its amplitude just
    # below both parents') and listed in the other (just above one of them): the same peak
    listed = _features({13: 1.0, 5: 0.15, 1: 0.16, 6: 0.13})
    five = next(c for c in listed.components if c.k == 5)
    attached = _features({13: 1.0, 5: 0.15, 1: 0.16})
    attached = Features(tuple(replace(c, harmonics=({"k": 6, "share": 0.12, "aliased": False,
                                                     "of": "5+1", "direction": "opposite"},))
                              if c.k == five.k else c for c in attached.components),
                        attached.fractions)
    assert match(listed, attached)


def test_stationarity_and_classes():
    """A decaying companion (21 % then 15 %) is unsettled; a stationary one settled; one
    component is a rigid wave."""
    sss = {"regime": "stick-slip-separation"}
    earlier, later = _features({12: 1.0, 13: 0.21}), _features({12: 1.0, 13: 0.15})
    assert stationary(earlier, later) == ["k = 13 against the rotation share 21 vs 15 %"]
    assert classify_features("completed", sss, earlier, later)[0] == "unsettled"
    assert classify_features("completed", sss, earlier, earlier) == ("multi-wave", [])
    rigid = _features({12: 1.0, 13: 0.06})
    assert classify_features("completed", sss, rigid, rigid) == ("wave", [])
    # one listed component, but weak companions that leave a frame spread above 10 %: not a
    # rigid wave (the direct solver would refuse it), named with its weak companions
    assert classify_features("completed", sss, rigid, rigid, spread=0.13) == ("multi-wave", [])
    assert describe(rigid.named(False), with_weak=True) == (
        "k = 12 against the rotation, with k = 13 (6 %)")
    # weak companions still decaying: the frame spread moves 0.30 -> 0.20 (33 % > 10 %) while
    # the listed components stay; below the rigid threshold (0.08 -> 0.066) it no longer counts
    def spread(f, x):
        return replace(f, frame_spread=x)

    assert stationary(spread(earlier, 0.30), spread(earlier, 0.20)) == [
        "frame spread 0.300 vs 0.200"]
    assert stationary(spread(rigid, 0.08), spread(rigid, 0.066)) == []
    grown = Features(rigid.components, rigid.fractions, rms_amplitude_m=1.1e-3)
    assert stationary(Features(rigid.components, rigid.fractions, 1.0e-3), grown) == [
        "RMS amplitude 0.001 vs 0.0011 m"]


def _leg(shares_of_t, t_end, window=0.1):
    """Synthetic features of the windows tiling the last leg back from ``t_end`` (window
    W, the leg [t_end / 1.5, t_end], at least two windows): k = 11 dominant, k = 10 with the
    share ``shares_of_t(window centre)``."""
    n = max(2, int(math.floor(max(2 * window, t_end / 3) / window + 1e-3)))
    out = []
    for j in range(n - 1, -1, -1):
        t1 = t_end - j * window
        share = shares_of_t(t1 - 0.5 * window)  # below 5 %: not found (as features do)
        f = _features({11: 1.0, **({10: share} if share >= 0.05 else {})})
        out.append(replace(f, window=(t1 - window, t1)))
    return out


def test_share_drift_over_the_last_leg():
    """A companion decaying as the N = 264 k = 11 state's k = 10 did (5 points/s, 21 -> 11 %
    over 2 s) passes two consecutive windows (0.5 points apart, tolerance 2) but its trend
    over the leg to 1.1 s, extrapolated over the next leg (0.55 s: 2.75 points), does not;
    a constant share and one jittering by up to 0.6 points per window pass."""
    horizon = 0.5 * 1.1  # the next leg, 1.1 -> 1.65 s
    decaying = _leg(lambda t: 0.21 - 0.05 * t, 1.1)
    assert len(decaying) == 3  # the leg 0.73 - 1.1 s: three windows of 0.1 s
    assert stationary(decaying[-2], decaying[-1]) == []
    assert share_drift(decaying, horizon) == [
        "k = 10 against the rotation share drifts -5.0 points/s (16 % now, 13 % in 0.55 s)"]
    assert share_drift(_leg(lambda t: 0.13, 1.1), horizon) == []
    # jitter (in points) of a settled start, at most 1.2 points between windows (the
    # measured settled starts: within 0.66 of the 2-point tolerance): slope 0.66 points/s,
    # 0.66 points over a 1 s horizon, within 2
    jitter = dict(zip(range(6), (0.6, -0.6, 0.4, -0.5, 0.6, -0.4), strict=True))
    noisy = _leg(lambda t: 0.13 + 0.01 * jitter[int(round((t - 1.45) / 0.1))], 2.0)
    assert len(noisy) == 6 and share_drift(noisy, 1.0) == []
    # a companion that died out within the leg (27 % -> 3 % at 0.1 per 0.1 s, gone below
    # 5 %): its line ends below the 10 % listing threshold, it names nothing
    died = _leg(lambda t: 0.27 * math.exp(-(t - 1.05) / 0.1), 1.6)
    assert 10 not in {c.k for c in died[-1].components}
    assert share_drift(died, 0.8) == []
    # the first leg of a census (t_end = 3W): the two windows, their change × 1.5 against
    # 10 % of the share (about 2.5 points here)
    assert len(_leg(lambda t: 0.2, 0.3)) == 2
    assert share_drift(_leg(lambda t: 0.20 + 0.12 * t, 0.3), 0.15) == []  # 1.8 points
    assert share_drift(_leg(lambda t: 0.20 + 0.20 * t, 0.3), 0.15) != []  # 3.0 points


def _two_waves(companion):
    """k = 7 at −300 rad/s with k = 9 at −250 rad/s of share ``companion(t)``, 36 nodes,
    samples every 1e-4 s to 0.6 s."""
    theta = np.linspace(0.0, 2.0 * np.pi, 36, endpoint=False)
    t = np.arange(0.0, 0.6 + 5e-5, 1e-4)
    share = companion(t)[:, None]
    p7 = 7 * (theta[None, :] + 300.0 * t[:, None])
    p9 = 9 * (theta[None, :] + 250.0 * t[:, None])
    u_r = 1e-3 * (np.cos(p7) + share * np.cos(p9))
    u_theta = 3e-4 * (np.sin(p7) + share * np.sin(p9))
    return {"t": t, "theta": theta, "u_r": u_r, "u_theta": u_theta}


def test_a_slowly_decaying_companion_is_unsettled():
    """Time series: a companion decaying 10 points/s (0.5 points per window of 0.05 s, two
    windows pass) is unsettled over the last leg (0.4 - 0.6 s, next leg 0.3 s: 3 points >
    2); a constant one settles at the first pair."""
    window = 0.05
    decaying = settle_verdict(_two_waves(lambda t: 0.25 - 0.1 * t), 1.0, window)
    assert stationary(decaying.earlier, decaying.later) == []
    assert math.isnan(decaying.settle_time)
    assert len(decaying.drift) == 1 and decaying.drift[0].startswith(
        "k = 9 against the rotation share drifts -10.0 points/s")
    steady = settle_verdict(_two_waves(lambda t: np.full_like(t, 0.22)), 1.0, window)
    assert steady.drift == () and steady.settle_time == pytest.approx(0.1, abs=1.1e-4)
    assert [c.k for c in steady.later.listed] == [7, 9]
    sss = {"regime": "stick-slip-separation"}
    assert classify_features("completed", sss, decaying.earlier, decaying.later,
                             drift=decaying.drift) == ("unsettled", list(decaying.drift))


def test_grouping_and_names():
    def row(seed, feats, cls="multi-wave"):
        return {"id": f"s{seed}", "seed": seed, "class": cls, "k": 12, "direction": "opposite",
                "regime": "stick-slip-separation", "celerity_m_s": -900.0,
                "features": feats.to_dict()}

    rows = [row(1, _features({12: 1.0, 13: 0.21, 11: 0.20})),
            row(2, _features({12: 1.0, 13: 0.22, 11: 0.20})),
            row(3, _features({12: 1.0, 13: 0.06}), "wave"),
            row(4, _features({12: 1.0, 13: 0.40, 11: 0.20}))]
    group_members(rows)
    assert [r["member"] for r in rows] == ["k12-opposite-SSS+k13+k11"] * 2 + [
        "k12-opposite-SSS", "k12-opposite-SSS+k13+k11#2"]
    assert describe(_features({12: 1.0, 13: 0.21, 11: 0.20}).components) == (
        "k = 12 against the rotation, with k = 13 (21 %) and k = 11 (20 %)")
    assert member_key(_features({8: 1.0}).components, "stick-slip") == "k8-opposite-SS"
    back = Features.from_dict(json.loads(json.dumps(rows[0]["features"])))
    assert match(back, Features.from_dict(rows[0]["features"]))


def test_small_census_counts_multi_wave_attractors(tmp_path):
    """A real census (smoke mesh, 2 starts, 0.1 s): every start featurised, the headline
    counts every settled member, each member has a readable name and a certificate line."""
    pytest.importorskip("dolfinx")
    import subprocess

    from test_sweep import _env

    out = tmp_path / "census"
    cmd = [sys.executable, "-m", "stickslip.cli.main", "attractors", str(REPO / "scenes" / "smoke.toml"),
           "--starts", "2", "--meshes", "36", "--end-time", "0.1", "--set", "loading.omega=20",
           "--set", "geometry.delta=0.005", "-o", str(out), "--no-certify", "--json"]
    res = subprocess.run(cmd, cwd=REPO, env=_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    answer = json.loads(res.stdout)
    for r in answer["starts"]:
        assert r["class"] in ("wave", "multi-wave", "unsettled", "steady-sliding")
        if r["class"] in ("wave", "multi-wave"):
            assert r["features"]["components"] and r["name"].startswith(f"k = {r['k']} ")
            assert (r["class"] == "wave") == (r["n_components"] == 1)
    members = answer["members"]["36"]
    settled = [m for m in members if m["class"] in ("wave", "multi-wave")]
    assert f"{len(settled)} attractor" in answer["text"]
    assert sum(m["count"] for m in members) == 2
    # every featurised start is kept in features.json: reading the census again reads no
    # samples and gives the same rows
    from stickslip.studies.attractors.census import collect

    cached = json.loads((out / "features.json").read_text())
    assert len(cached) == sum(1 for r in answer["starts"] if r["features"])
    (out / "starts" / "runs" / answer["starts"][0]["id"] / "samples.npz").unlink()
    again = collect(out)
    assert [(r["class"], r["components"]) for r in again["starts"]] == [
        (r["class"], r["components"]) for r in answer["starts"]]


def test_parse_along():
    from stickslip.studies.attractors.along import parse_along

    assert parse_along("loading.omega=30:100:8") == (
        "loading.omega", [30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0])
    assert parse_along("loading.f=0.5,0.6") == ("loading.f", [0.5, 0.6])
    for bad in ("omega=30:100:8", "loading.omega=30:100:1", "loading.omega=1,1", "x"):
        with pytest.raises(ValueError, match="--along"):
            parse_along(bad)
    # refused before the list is made (10^5 values, each a census to check, took minutes)
    with pytest.raises(ValueError, match="M = 100000 values, each a whole census; give M <= "):
        parse_along("loading.omega=30:100:100000")
    with pytest.raises(ValueError, match="finite"):
        parse_along("loading.omega=nan,30")


def test_along_matches_neighbouring_points_by_features():
    """An attractor whose celerity moves 5 % and a companion's share 10 points between two
    points is one chain; one that appears at the second point is marked."""
    from stickslip.studies.attractors.along import ALONG_TOLERANCES
    from stickslip.studies.attractors.features import Tolerances
    from stickslip.studies.attractors.statistics import align, member_components

    def member(name, feats):
        e = {"member": name, "class": "multi-wave", "fraction_separation": 0.7,
             "fraction_stick": 0.14, "fraction_slip": 0.16}
        e.update(member_components([{"features": feats.to_dict()}]))
        return e

    first = [member("k12-opposite-SSS+k13", _features({12: 1.0, 13: 0.21}))]
    second = [member("k12-opposite-SSS+k13", _features({12: 1.0, 13: 0.31}, celerity=-945.0)),
              member("k8-opposite-SSS", _features({8: 1.0}))]
    per = {0: first, 1: second}
    align(per, Tolerances(**ALONG_TOLERANCES))
    assert second[0]["ladder_id"] == first[0]["ladder_id"] == "k12-opposite-SSS+k13"
    assert second[1]["ladder_id"] == "k8-opposite-SSS"
    # one that vanishes at the middle point and comes back is the same chain (lookback)
    gone = {0: [dict(first[0])], 1: [dict(second[1])], 2: [dict(second[0])]}
    align(gone, Tolerances(**ALONG_TOLERANCES), lookback=True)
    assert gone[2][0]["ladder_id"] == gone[0][0]["ladder_id"]
    # with the mesh ladder's tolerances (celerity within 5 %) a 6 % move is another attractor
    per = {0: [dict(first[0])], 1: [member("x", _features({12: 1.0, 13: 0.21},
                                                           celerity=-900 * 1.06))]}
    align(per)
    assert per[1][0]["ladder_id"] == "x"


def test_along_runs_a_census_per_point_and_resumes(tmp_path, capsys):
    """``--along loading.omega=20,30``: one census per value, along.json with both points;
    a rerun runs no start again."""
    pytest.importorskip("dolfinx")
    from test_sweep import _starts

    from stickslip.cli.main import main

    out = tmp_path / "along"
    cmd = ["attractors", str(REPO / "scenes" / "smoke.toml"), "--starts", "1", "--meshes",
           "36", "--end-time", "0.1", "--set", "geometry.delta=0.005", "--along",
           "loading.omega=20,30", "-o", str(out), "--no-certify", "--plot"]
    assert main(cmd) == 0
    table = json.loads((out / "along.json").read_text())
    assert table["values"] == [20.0, 30.0] and len(table["points"]) == 2
    assert (out / "along.png").stat().st_size > 10_000  # a drawn figure, not a stub
    runs = {p.name: _starts(p / "starts") for p in (out / "points").iterdir()}
    assert sorted(runs) == ["omega-20", "omega-30"]
    assert "attractors along loading.omega = 20, 30" in capsys.readouterr().out
    assert main(cmd) == 0
    assert {p.name: _starts(p / "starts") for p in (out / "points").iterdir()} == runs


def test_certificates_reproducibility_persistence_and_an_unstable_wave(tmp_path, monkeypatch):
    """A multi-wave member: reproduced by its 2 starts, persistent, with the spreads; a rigid
    wave that the direct solver calls unstable is a transient, not an attractor."""
    import stickslip.studies.attractors.certify as certify_module
    from stickslip.studies.attractors.census import answer_of

    def row(seed, feats, before, cls):
        run = tmp_path / f"s{seed}"
        run.mkdir()
        (run / "summary.json").write_text("{}")
        return {"id": f"s{seed}", "n_inner": 132, "start": "random", "seed": seed,
                "start_mode": None, "class": cls, "k": feats.dominant.k,
                "direction": "opposite", "regime": "stick-slip-separation",
                "celerity_m_s": feats.dominant.celerity_m_s, "run_dir": str(run),
                "features": feats.to_dict(), "features_before": before.to_dict(),
                **{k: 0.5 for k in ("frequency_hz", "fraction_separation", "fraction_stick",
                                    "fraction_slip", "psi1", "psi2", "amplitude_m",
                                    "rms_amplitude_m", "frame_spread")}}

    multi = _features({12: 1.0, 13: 0.21, 11: 0.20})
    rigid = _features({8: 1.0}, celerity=-1000.0)
    rows = [row(1, multi, _features({12: 1.0, 13: 0.22, 11: 0.20}), "multi-wave"),
            row(2, _features({12: 1.0, 13: 0.23, 11: 0.20}), multi, "multi-wave"),
            row(3, rigid, rigid, "wave")]
    monkeypatch.setattr(certify_module, "certify", lambda run_dir, *, dt_limit=False, window=None: {
        "available": True, "at_dt": {"converged": True}, "stable": False})
    meta = {"celerity_tol": 0.02, "spread_tol": 0.1, "scene_file": "x", "overrides": [],
            "meshes": [132], "definition": {"scene": {"name": "x"}},
            "distribution": {"starts": 3, "seed": 1, "n_modes": 16, "amplitude": 0.1}}
    answer = answer_of(meta, rows, tmp_path, timing={"sweep_s": 10.0, "features_s": 1.0})
    certs = answer["certificates"]
    multi_cert = certs["132:k12-opposite-SSS+k13+k11"]
    assert multi_cert["reproduced"] and multi_cert["starts"] == 2
    # shares 0.21 and 0.23 across the starts (2 points); 0.22 -> 0.21, 0.21 -> 0.23 between
    # the windows of each start (the larger, 2 points, is reported)
    assert multi_cert["spread_between_starts"]["share"] == pytest.approx(0.02)
    assert multi_cert["change_between_windows"]["share"] == pytest.approx(0.02)
    assert certs["132:k8-opposite-SSS"]["stable"] is False
    classes = {m["member"]: m["class"] for m in answer["members"]["132"]}
    assert classes == {"k12-opposite-SSS+k13+k11": "multi-wave",
                       "k8-opposite-SSS": "transient"}
    assert "N = 132 (3 random starts): 1 attractor (0 rigid, 1 multi-wave)" in answer["text"]
    assert "certificates" in answer["text"].splitlines()[-1]  # the time shares are printed


def test_cea_mode_shares_and_who_wins():
    """The starts whose attractor holds an unstable mode's (k, direction) as dominant or
    companion; the fastest mode wins only when it dominates more starts than any other."""
    from stickslip.studies.attractors.cea import cea_lines, mode_shares

    def row(feats, cls="multi-wave"):
        return {"class": cls, "features": feats.to_dict()}

    rows = [row(_features({12: 1.0, 13: 0.21, 11: 0.20})),
            row(_features({12: 1.0, 11: 0.30})), row(_features({13: 1.0}), "wave"),
            row(_features({13: 1.0}), "unsettled")]  # unsettled: no attractor, not counted
    modes = [{"k": 13, "direction": "opposite", "growth_rate_per_s": 900.0, "zeta": -0.07,
              "frequency_hz": 1900.0, "phase_speed_m_s": -900.0},
             {"k": 12, "direction": "opposite", "growth_rate_per_s": 800.0, "zeta": -0.07,
              "frequency_hz": 1800.0, "phase_speed_m_s": -900.0}]
    t = mode_shares(modes, rows)
    assert [(m["dominant"], m["companion"], m["starts"]) for m in t["modes"]] == [
        (1, 1, 4), (2, 0, 4)]
    assert not t["fastest_wins"] and t["most_reached"] == {"k": 12, "direction": "opposite"}
    assert cea_lines({"132": t})[-1] == ("  the fastest-growing mode (k = 13 against Ω) does "
                                         "not win: k = 12 against Ω is the dominant "
                                         "component of the most starts")
    assert mode_shares(modes[1:], rows)["fastest_wins"]
