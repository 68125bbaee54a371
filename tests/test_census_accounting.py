"""Every start accounted for: an end state is an attractor only when it passes every
certificate it gets, a start on a state that fails one is continued from its own
checkpoint like an unsettled one, and each mesh's headline says where every start is.

* Synthetic rows through ``census.answer_of`` (no FE run, well under a second): a rigid
  wave the direct solver calls unstable and a multi-wave state not returned after its kick
  are ``transient`` at the cap with their reasons, never counted among the attractors;
  below the cap they are ``settling`` (a leg is due) and the answer is not finished.
* One real census (the smoke mesh, 3 starts at N = 36, a first leg of 0.05 s capped at
  0.1 s: legs to 0.075 and 0.1 s; a few seconds on one core, 10 s with the first
  compilation) with the kick verdict replaced: every member fails its kick below the cap,
  so every start that settles early is continued to the cap, its samples before its old
  end kept bit for bit (continued from its own checkpoint, unperturbed); at the cap the
  state of seed 2 still fails and is ``transient``, any other passes and is an attractor.
  The direct solver is left out (its verdict is not the one under test).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from test_attractor_features import _features
from test_attractors import SMOKE

import stickslip.studies.attractors.census as census_module
import stickslip.studies.attractors.certify as certify_module
from stickslip.studies.attractors.census import answer_of, certificate_key
from stickslip.studies.attractors.certify import failures

SSS = "stick-slip-separation"
CAP = 0.3


def _row(tmp: Path, seed: int, feats, cls: str, t: float = CAP) -> dict:
    run = tmp / f"s{seed}"
    run.mkdir()
    (run / "summary.json").write_text("{}")
    dom = feats.dominant if feats is not None else None
    return {"id": f"s{seed}", "n_inner": 132, "start": "random", "seed": seed,
            "start_mode": None, "class": cls, "status": "completed" if cls != "failed"
            else "failed", "sim_time_s": t, "k": dom.k if dom else None,
            "direction": "opposite" if dom else None, "regime": SSS if dom else None,
            "celerity_m_s": dom.celerity_m_s if dom else None, "run_dir": str(run),
            "features": feats.to_dict() if feats else None,
            "features_before": feats.to_dict() if feats else None,
            **{k: 0.5 for k in ("frequency_hz", "fraction_separation", "fraction_stick",
                                "fraction_slip", "psi1", "psi2", "amplitude_m",
                                "rms_amplitude_m", "frame_spread")}}


def _meta(starts: int) -> dict:
    return {"celerity_tol": 0.02, "spread_tol": 0.1, "scene_file": "x", "overrides": [],
            "meshes": [132], "definition": {"scene": {"name": "x"}}, "max_time_s": CAP,
            "distribution": {"starts": starts, "seed": 1, "n_modes": 16, "amplitude": 0.1}}


def _certified(tmp: Path, rows: list[dict], verdicts: dict[str, dict]) -> None:
    """certificates.json holding ``verdicts`` (by the seeds' dominant k: its certificate)
    for the member each row set forms, as a census would have cached them."""
    from stickslip.studies.attractors.census import grouped

    grouped(_meta(len(rows)), rows)
    groups: dict[str, list[dict]] = {}
    for r in rows:
        if r["class"] in ("wave", "multi-wave"):
            groups.setdefault(r["member"], []).append(r)
    cache = {certificate_key(g, False): {"starts": len(g), "reproduced": len(g) > 1,
                                         "rigid": g[0]["class"] == "wave",
                                         **verdicts[g[0]["k"]]} for g in groups.values()}
    (tmp / "certificates.json").write_text(json.dumps(cache))


PASSED = {"kick": {"returned": True, "differences": [], "start": "s", "kicked_at_s": 0.2,
                   "until_s": 0.3}}
UNSTABLE = {"stable": False, "direct": {"available": True, "at_dt": {"converged": True},
                                        "stable": False}, **PASSED}
KICKED_AWAY = {"kick": {"returned": False, "differences": ["k = 9 share 54 vs 67 %"],
                        "start": "s", "kicked_at_s": 0.2, "until_s": 0.3}}


def _census_rows(tmp: Path, t_failing: float) -> list[dict]:
    """8 starts: 2 on a passing multi-wave k = 12, 1 on a passing rigid k = 14, 2 on the
    rigid k = 8 that the direct solver calls unstable, 1 on a multi-wave k = 10 not
    returned after its kick (these 3 at ``t_failing``), 1 unsettled at the cap, 1 failed."""
    multi = _features({12: 1.0, 13: 0.21, 11: 0.20})
    return [_row(tmp, 1, multi, "multi-wave"), _row(tmp, 2, multi, "multi-wave"),
            _row(tmp, 3, _features({14: 1.0}, celerity=-850.0), "wave"),
            _row(tmp, 4, _features({8: 1.0}, celerity=-1000.0), "wave", t_failing),
            _row(tmp, 5, _features({8: 1.0}, celerity=-1000.0), "wave", t_failing),
            _row(tmp, 6, _features({10: 1.0, 9: 0.54}, celerity=-970.0), "multi-wave",
                 t_failing),
            _row(tmp, 7, _features({3: 1.0, 4: 0.8}, celerity=-3300.0), "unsettled"),
            _row(tmp, 8, None, "failed")]


VERDICTS = {12: PASSED, 14: PASSED, 8: UNSTABLE, 10: KICKED_AWAY}


def test_failures_are_verdicts_against_not_certificates_missing():
    assert failures(None) == [] and failures({}) == []
    assert failures({"stable": None, "kick": "not run"}) == []  # unknown is no verdict
    assert failures({"kick": {"message": "not run: no batch member"}}) == []
    assert failures({"reproduced": False, "starts": 1, **PASSED}) == []  # one start
    assert failures(UNSTABLE) == ["unstable in the direct solver"]
    assert failures({**UNSTABLE, **KICKED_AWAY}) == ["unstable in the direct solver",
                                                     "not returned after a 1 % kick"]


def test_a_state_failing_a_certificate_is_no_attractor_and_the_headline_says_where(
        tmp_path):
    rows = _census_rows(tmp_path, CAP)
    _certified(tmp_path, rows, VERDICTS)
    answer = answer_of(_meta(8), rows, tmp_path, compute=False)
    assert answer["finished"]  # every start at an end state: the failing ones at the cap
    by_seed = {r["seed"]: r for r in answer["starts"]}
    assert [by_seed[s]["class"] for s in range(1, 9)] == [
        "multi-wave", "multi-wave", "wave", "transient", "transient", "transient",
        "unsettled", "failed"]
    assert by_seed[4]["rejected_because"] == "unstable in the direct solver"
    assert by_seed[6]["rejected_because"] == "not returned after a 1 % kick"
    assert answer["accounting"]["132"]["attractors"] == 2
    assert answer["accounting"]["132"]["reached"] == 3
    assert list(answer["ladder"]["sets"].values()) == [sorted(
        m["member"] for m in answer["members"]["132"] if m["class"] in ("wave", "multi-wave"))]
    # the 8 starts: 3 reach an attractor; the other 5, each where it is
    head = next(x for x in answer["text"].splitlines() if x.startswith("N = 132"))
    assert head == (
        "N = 132 (8 random starts): 2 attractors (1 rigid, 1 multi-wave), reached by 3 of 8 "
        "starts; 1 unsettled at the cap, 2 on a rigid wave k = 8 against the rotation, "
        "unstable in the direct solver, at the cap, 1 on a relative periodic orbit k = 10 "
        "against the rotation, not returned after a 1 % kick, at the cap, 1 failed:")
    assert "  not an attractor: not returned after a 1 % kick" in answer["text"]
    assert "k = 9 share 54 vs 67 %" in answer["text"]  # what the kick moved, shown
    # every random start is in exactly one place of the headline's count
    acc = answer["accounting"]["132"]
    assert acc["reached"] + sum(e["count"] for e in acc["elsewhere"]) == acc["starts"] == 8


def test_a_failing_state_below_the_cap_is_still_settling(tmp_path):
    rows = _census_rows(tmp_path, 0.1)  # the failing starts' leg ended before the cap
    _certified(tmp_path, rows, VERDICTS)
    answer = answer_of(_meta(8), rows, tmp_path, compute=False)
    assert not answer["finished"]  # a leg is due: no end state, no answer yet
    settling = sorted(r["seed"] for r in answer["starts"] if r["class"] == "settling")
    assert settling == [4, 5, 6]
    assert answer["counts"]["settling"] == 3 and "transient" not in answer["counts"]
    assert answer["accounting"]["132"]["starts"] == 5  # settling starts are not counted yet
    assert answer["text"].splitlines()[2].startswith("NOT FINISHED")


# ------------------------------------------------------------------ a real census


def _fake_kicks(cap: float, stubborn: int, before: dict):
    """A kick verdict: every member fails below the cap; at the cap the members holding
    seed ``stubborn`` still fail, the others return. Each kicked member's samples are kept
    in ``before`` (start id: (t, u_r)) to check that its continuation changed nothing
    before its old end."""
    from stickslip.studies.attractors.classify import _samples

    def kick(out_dir, groups, window, tol=None, stream=None):  # noqa: ANN001, ARG001
        out = {}
        for key, rows in groups.items():
            t = max(float(r["sim_time_s"]) for r in rows)
            fails = t < cap * (1 - 1e-9) or any(r["seed"] == stubborn for r in rows)
            for r in rows:
                if r["id"] not in before:
                    s = _samples(Path(r["run_dir"]))
                    before[r["id"]] = (float(r["sim_time_s"]), s["t"].copy(),
                                       s["u_r"].copy())
            out[key] = {"returned": not fails, "differences": ["moved"] if fails else [],
                        "start": rows[0]["id"], "kicked_at_s": t, "until_s": t + 2 * window}
        return out

    return kick


def test_a_census_continues_the_starts_of_failed_members_from_their_checkpoints(
        tmp_path, monkeypatch):
    pytest.importorskip("dolfinx")
    from stickslip.studies.attractors.census import Census, run_census
    from stickslip.studies.attractors.classify import _samples
    from stickslip.studies.attractors.starts import StartDistribution

    cap = 0.1
    before: dict = {}
    monkeypatch.setattr(census_module, "kick_members", _fake_kicks(cap, 2, before))
    monkeypatch.setattr(certify_module, "certify", lambda run_dir, **_: {
        "available": False, "message": "certification unavailable: left out here"})
    census = Census(SMOKE, (36,), StartDistribution(starts=3),
                    ("loading.omega=20", "geometry.delta=0.005", "time.end_time=0.05"),
                    max_time=cap)
    out = tmp_path / "census"
    stream = io.StringIO()
    rc = run_census(census, out, stream=stream, progress="lines")
    text = stream.getvalue()
    answer = json.loads((out / "attractors.json").read_text())
    assert rc == 0 and answer["finished"], text
    rows = {r["seed"]: r for r in answer["starts"]}
    kicked_early = {i for i, (t, _, _) in before.items() if t < cap * (1 - 1e-9)}
    assert kicked_early, text  # some start settled at the first leg and failed its kick
    assert "settle: continuing" in text
    # the silent phases say what they do, before they do it (progress on a long census)
    assert "certify: " in text and "member(s) (N = 36)" in text, text
    assert text.index("certify: ") < text.rindex("settle: continuing"), text
    for r in answer["starts"]:
        if r["id"] in kicked_early:  # continued to the cap, from its own checkpoint
            assert r["sim_time_s"] >= cap - 1e-9
            t_old, t, u_r = before[r["id"]]
            now = _samples(Path(r["run_dir"]))
            keep = t <= t_old + 1e-12
            n = int(keep.sum())
            np.testing.assert_array_equal(now["t"][:n], t[keep])
            np.testing.assert_array_equal(now["u_r"][:n], u_r[keep])  # bit for bit
        if r["class"] in ("wave", "multi-wave"):  # passed its kick: at the cap
            assert r["sim_time_s"] >= cap - 1e-9 and not r.get("rejected_because")
    # seed 2 settles at the second leg's end (0.075 s), fails its kick there, is continued
    # and fails again at the cap: a transient, with its reason, in the headline
    stubborn = rows[2]
    assert stubborn["id"] in kicked_early and stubborn["class"] == "transient", text
    assert stubborn["rejected_because"] == "not returned after a 1 % kick"
    # no start is counted as an attractor with a failed certificate, and the headline
    # accounts for every start
    acc = answer["accounting"]["36"]
    assert acc["reached"] + sum(e["count"] for e in acc["elsewhere"]) == acc["starts"] == 3
    head = next(x for x in answer["text"].splitlines() if x.startswith("N = 36"))
    assert f"reached by {acc['reached']} of 3 starts" in head
    assert ", not returned after a 1 % kick, at the cap" in head
    for seed, r in rows.items():
        member_cert = answer["certificates"].get(f"36:{r['member']}")
        if r["class"] in ("wave", "multi-wave"):
            assert member_cert and not failures(member_cert), seed
