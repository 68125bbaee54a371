"""The kick test of a census's members (studies/attractors/certify.py ``kick_members``):
one start per member perturbed by 1 % where it stands, run on for two windows through the
batch continuation, must return to its own features; the census's starts are never
touched, the kicks are part of the certificates' time."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from test_attractors import SMOKE


@pytest.fixture(scope="module")
def census(tmp_path_factory):
    """Stick-slip on the smoke mesh (as test_census_settle): 3 starts at N = 36, a first leg
    of 0.05 s (W = 1/60 s), cap 0.1 s, without certificates; then certified with kicks."""
    pytest.importorskip("dolfinx")
    from stickslip.studies.attractors.census import Census, collect, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    out = tmp_path_factory.mktemp("kick") / "census"
    spec = Census(SMOKE, (36,), StartDistribution(starts=3),
                  ("loading.omega=20", "geometry.delta=0.005", "time.end_time=0.05"),
                  max_time=0.1)
    assert run_census(spec, out, certify=False, stream=io.StringIO()) == 0
    starts = {p: p.read_bytes() for p in (out / "starts" / "runs").glob("*/*") if p.is_file()}
    answer = collect(out, certify="run", sweep_s=1.0)
    return out, starts, answer


def test_every_member_is_kicked_and_returns(census):
    out, starts, answer = census
    certs = answer["certificates"]
    assert certs, answer["text"]
    window = json.loads((out / "census.json").read_text())["window_s"]
    rigid = 0
    for cert in certs.values():
        kick = cert["kick"]
        assert kick["returned"] and kick["differences"] == [], kick
        # 1 % of the state's RMS displacement and velocity (the bumps are rescaled exactly)
        assert kick["du_rms_m"] == pytest.approx(0.01 * kick["u_rms_m"], rel=1e-12)
        assert kick["dv_rms_m_s"] == pytest.approx(0.01 * kick["v_rms_m_s"], rel=1e-12)
        # run on two census windows from where the start stood (to one step, 1e-4 s)
        assert kick["until_s"] - kick["kicked_at_s"] == pytest.approx(2 * window, abs=1e-4)
        assert f"kicked by 1 % at {kick['kicked_at_s']:.2f} s" in answer["text"]
        assert Path(kick["run"]).parent == out / "kicks"
        # a rigid member's stability: λ₁ of its start at the run's own step, the twin run
        # over 2W renormalised every W/20, unstable only when > 1 1/s beyond 3 errors
        direct = cert.get("direct") or {}
        if cert["rigid"] and direct.get("at_dt", {}).get("converged"):
            lyap = direct["lyapunov"]
            assert direct["stability_test"] == "lyapunov", direct
            # τ is a whole number of steps: W/20 is about 11 steps here, so within 10 %
            assert lyap["tau_s"] == pytest.approx(window / 20, rel=0.1)
            assert lyap["intervals"] == 40
            growing = lyap["lambda1_per_s"] - 3 * lyap["lambda1_error_per_s"] > 1.0
            assert cert["stable"] is (not growing)
            rigid += 1
    assert rigid >= 1  # seed 2 ends on the rigid k = 6 against the rotation
    # the starts themselves are untouched: every file of theirs has its bytes
    assert {p: p.read_bytes() for p in starts} == starts
    timing = answer["timing"]
    assert 0.0 < timing["kick_s"] <= timing["certification_s"]
    assert "of which kicks" in answer["text"]


def test_the_kick_enters_and_the_kicked_run_starts_at_the_kick(census):
    """The kicked run is a new experiment from t_k on: its samples are the levels after the
    kick only (the history stays in the start: a kick at N = 528 and t = 4 s would copy
    1 GB), at the times of the start's own continuation (no kick), from which its contact
    circle differs by about the kick's size (≤ 5 % of the RMS of u_r: the bump is 1 % of
    the RMS over all dofs, X(R) = 1 at the circle) and not by round-off (> 1e-6 of it). The
    kicked run is a run directory in itself: its checkpoint agrees with its samples, so it
    can be continued."""
    from stickslip.studies.rundir import continue_batch

    out, _, answer = census
    kick = next(iter(answer["certificates"].values()))["kick"]
    start = out / "starts" / "runs" / kick["start"]
    plain = out.parent / "plain"
    window = json.loads((out / "census.json").read_text())["window_s"]
    continue_batch([start], kick["kicked_at_s"] + 2 * window, [plain], stream=io.StringIO())
    with np.load(start / "samples.npz") as a, np.load(Path(kick["run"]) / "samples.npz") as b, \
            np.load(plain / "samples.npz") as c:
        n = a["t"].size
        assert b["t"][0] >= kick["kicked_at_s"] and np.array_equal(b["t"], c["t"][n:])
        diff = np.sqrt(np.mean((b["u_r"][0] - c["u_r"][n]) ** 2))
        size = np.sqrt(np.mean(c["u_r"][n] ** 2))
    assert 1e-6 * size < diff < 0.05 * size
    on = continue_batch([Path(kick["run"])], kick["until_s"] + window, stream=io.StringIO())
    assert on[0]["status"] == "completed"


def test_a_kick_that_lands_elsewhere_is_reported(census):
    """The same kick compared with a reference 5 % faster (beyond the 2 % celerity
    tolerance): not returned, the celerity named."""
    from stickslip.studies.attractors.certify import kick_line, kick_members

    out, _, answer = census
    rows = [r for r in answer["starts"] if r.get("features")]  # any end state kicked
    row = dict(rows[0])
    features = json.loads(json.dumps(row["features"]))
    for c in features["components"]:
        c["celerity_m_s"] *= 1.05
    row["features"] = features
    window = json.loads((out / "census.json").read_text())["window_s"]
    result = kick_members(out, {"36:shifted": [row]}, window)
    kick = result["36:shifted"]
    assert kick["returned"] is False
    assert any("celerity" in d for d in kick["differences"]), kick
    assert "not returned" in kick_line(kick)


def test_a_kick_is_never_in_place(census):
    from stickslip.studies.rundir import continue_batch

    out, _, answer = census
    kick = next(iter(answer["certificates"].values()))["kick"]
    with pytest.raises(ValueError, match="never in place"):
        continue_batch([out / "starts" / "runs" / kick["start"]], kick["until_s"] + 0.01,
                       kick=0.01)


def test_the_half_step_test_restarts_each_member_at_half_the_step(census):
    """``step_check.half_step_members`` (``--half-step``; the census runs it on its
    multi-wave members, here on every member): each member's first start restarted from its
    checkpoint's (u, v~) at half its step for 4 windows, its last window against the start's
    own. The smoke mesh is coarse (N = 36, Δt = 7.7e-5 s): its rigid k = 6 wave against the
    rotation moves from −1921.1 to −1836.2 m/s at Δt/2 (measured), 4.4 %, beyond the
    census's 2 % tolerance, so the test says "moved" and names the celerity; the step is
    half the start's to round-off; the starts' files are untouched."""
    from stickslip.studies.attractors.census import settled_members
    from stickslip.studies.attractors.certify import member_line
    from stickslip.studies.attractors.features import DEFAULT_TOLERANCES
    from stickslip.studies.attractors.step_check import half_step_members

    out, starts, answer = census
    window = json.loads((out / "census.json").read_text())["window_s"]
    groups = {f"{n}:{m}": rows for (n, m), rows in settled_members(answer["starts"]).items()}
    found = half_step_members(groups, window, DEFAULT_TOLERANCES)
    wave = found["36:k6-opposite-SS"]
    assert wave["kept"] is False
    assert any(d.startswith("k = 6 against the rotation celerity") for d in wave["differences"])
    assert wave["components"].startswith("k6- 1.00 -18")
    for key, result in found.items():
        assert result["dt_s"] == pytest.approx(0.5 * groups[key][0]["dt_s"], rel=1e-12)
    assert "moved at Δt/2" in member_line({"starts": 1, "half_step": wave})
    assert {p: p.read_bytes() for p in starts} == starts


def test_half_step_is_a_census_option_kept_in_census_json(tmp_path):
    """``--half-step`` (``Census.half_step``) is kept in census.json, where the
    certificates read it; a census without it says False."""
    pytest.importorskip("dolfinx")
    from stickslip.studies.attractors.census import Census, prepare, read_meta
    from stickslip.studies.attractors.starts import StartDistribution

    for flag in (True, False):
        spec = Census(SMOKE, (36,), StartDistribution(starts=1), ("time.end_time=0.05",),
                      max_time=0.1, half_step=flag)
        claim = prepare(spec, tmp_path / str(flag), False)
        claim.release()
        assert read_meta(tmp_path / str(flag))["half_step"] is flag
