"""The census's last two judgements: the first rung of the ladder from which its answer stays
the same (``statistics.rung_steps``, ``settles_from``), and a start still changing at the
cap told chaotic or unsettled (``census.chaos_shared``, ``chaos.classify_at_cap``).

* The settle criterion on synthetic member tables (no FE, milliseconds): each of its four
  parts (the set, Fisher's test of the shares, the total variation of the dominant
  component's distribution below 0.1, the basin-weighted celerity within 1 %) can by itself
  stop a rung from qualifying.
* Chaos through ``answer_of`` on synthetic rows (a verdict as ``chaos.json`` holds it): a
  start unsettled at the cap with a chaotic verdict is ``chaotic``, an attractor with its
  λ₁; with a verdict that is not, it stays ``unsettled`` and says why; below the cap a
  verdict is not used (the start is still settling).
* One real census of the smoke mesh (2 starts at N = 36, no extension: the cap is the first
  leg's 0.05 s) with ``chaos_shared``: every start unsettled at the cap gets its verdict
  in ``chaos.json``, and the answer's classes follow the verdicts.
"""

from __future__ import annotations

import io
import json
import math

import pytest
from test_attractor_features import _features
from test_attractors import SMOKE
from test_census_accounting import CAP, _meta, _row

from stickslip.studies.attractors.census import answer_of
from stickslip.studies.attractors.report import settle_lines
from stickslip.studies.attractors.statistics import (
    SETTLE_CELERITY,
    SETTLE_TV,
    ladder,
    rung_steps,
    settles_from,
)


def _entry(member: str, count: int, starts: int, k: int, celerity: float,
           cls: str = "wave") -> dict:
    """One member table entry as ``mesh_members`` gives it, without features (matched
    across rungs by its dominant k and celerity)."""
    return {"member": member, "class": cls, "k": k, "direction": "opposite",
            "regime": "stick-slip-separation", "count": count, "starts": starts,
            "share": count / starts, "celerity_m_s": celerity, "frequency_hz": 1.0,
            "psi1": 0.1, "psi2": 0.1, "rms_amplitude_m": 1e-6, "components": [
                {"k": k, "direction": "opposite", "share": 1.0, "amplitude_m": 1e-6,
                 "frequency_hz": k * celerity / 6.283, "celerity_m_s": celerity,
                 "aliased": False, "weak": False}]}


def _rungs(fine_celerity: float = -900.0, fine_split: tuple[int, int] = (12, 4)) -> dict:
    """Three rungs of 16 starts: 132 on k = 8 only; 264 and 528 on k = 13 (12) and k = 12
    (4) at the same celerities, except the finest k = 13 at ``fine_celerity`` and split
    ``fine_split``."""
    a, b = fine_split
    return {"132": [_entry("k8", 16, 16, 8, -1000.0)],
            "264": [_entry("k13", 12, 16, 13, -900.0), _entry("k12", 4, 16, 12, -950.0)],
            "528": [_entry("k13", a, 16, 13, fine_celerity),
                    _entry("k12", b, 16, 12, -950.0)]}


def test_the_answer_settles_from_the_first_rung_after_which_every_step_holds():
    lad = ladder(_rungs())
    first, second = lad["steps"]
    assert not first["holds"] and not first["same_set"]
    assert first["dominant_tv"] == pytest.approx(1.0)  # all of k = 8 moved to k = 13, 12
    assert second["holds"] and second["same_set"] and second["dominant_tv"] == 0.0
    assert second["celerity_change"] == pytest.approx(0.0)
    assert lad["settles_from"] == "264"
    text = settle_lines(lad["steps"], lad["settles_from"])
    assert text[0].startswith("answer settled from N = 264 on (same attractors")
    assert text[2].endswith("(holds)")


def test_each_part_of_the_criterion_can_stop_a_rung():
    # the basin-weighted celerity: (12·c + 4·(−950))/16 moves by 2 % of its value when
    # the k = 13 wave's celerity moves by 2 · 912.5/12 · ... : take c = −900 · 1.027
    # (k = 13 within the 5 % ladder tolerance, so the set is the same)
    lad = ladder(_rungs(fine_celerity=-900.0 * 1.027))
    step = lad["steps"][1]
    assert step["same_set"] and step["dominant_tv"] == 0.0
    assert step["celerity_change"] > SETTLE_CELERITY
    assert lad["settles_from"] is None
    # the dominant distribution: 12/4 → 9/7 moves it by TV = 3/16 ≥ 0.1 (Fisher: p = 0.47,
    # consistent; the set is the same)
    lad = ladder(_rungs(fine_split=(9, 7)))
    step = lad["steps"][1]
    assert step["same_set"] and step["shares_consistent"]
    assert step["dominant_tv"] == pytest.approx(3 / 16) and step["dominant_tv"] >= SETTLE_TV
    assert lad["settles_from"] is None
    assert settle_lines(lad["steps"], None)[0].startswith(
        "no rung from which the answer stays the same")
    # Fisher: 16/0 → 2/14 (p ≈ 2e-7) is a change of the shares
    lad = ladder({"264": [_entry("k13", 16, 16, 13, -900.0)],
                  "528": [_entry("k13", 2, 16, 13, -900.0), _entry("k12", 14, 16, 12, -950.0)]})
    step = lad["steps"][0]
    assert not step["shares_consistent"] and step["fisher_min_p"] < 1e-5
    # the set: a member added at the finer rung
    assert step["added"] == ["k12"] and not step["same_set"]


def test_rung_steps_with_no_travelling_member_anywhere():
    coarse = {"dominant_k_distance": [0.0],
              "weighted_celerity_m_s": {"values": [math.nan, math.nan]}}
    steps = rung_steps(["132", "264"], {"132": [], "264": []}, [], coarse)
    assert steps[0]["holds"] and steps[0]["celerity_change"] == 0.0
    assert settles_from(["132", "264"], steps) == "132"


CHAOTIC = {"class": "chaotic", "why": [], "stationarity": {"stationary": True,
           "windows": [0.1, 0.2, 0.3, 0.4]},
           "lyapunov": {"lambda1_per_s": 42.0, "lambda1_error_per_s": 5.0, "tau_s": 0.005,
                        "intervals": 100, "positive": True}}
DRIFTING = {"class": "unsettled", "why": ["statistics not stationary: rms_u_r: mean drifts "
                                          "1.30 sigma over the leg, std ratio 1.10"],
            "stationarity": {"stationary": False, "observables": {
                "rms_u_r": {"stationary": False}, "zone_0": {"stationary": True}}},
            "lyapunov": None}


def test_a_chaotic_verdict_at_the_cap_makes_an_attractor_with_its_exponent(tmp_path):
    rows = [_row(tmp_path, 1, _features({3: 1.0, 4: 0.8}, celerity=-3300.0), "unsettled"),
            _row(tmp_path, 2, _features({3: 1.0, 4: 0.7}, celerity=-3310.0), "unsettled"),
            _row(tmp_path, 3, _features({5: 1.0, 6: 0.5}, celerity=-2000.0), "unsettled"),
            _row(tmp_path, 4, _features({3: 1.0, 4: 0.8}, celerity=-3300.0), "unsettled",
                 CAP / 2)]
    for r, verdict in zip(rows, (CHAOTIC, CHAOTIC, DRIFTING, CHAOTIC), strict=True):
        r["chaos"] = verdict
    answer = answer_of(_meta(4), rows, None)
    classes = [r["class"] for r in answer["starts"]]
    # seed 4 is below the cap: still settling whatever a verdict says
    assert classes == ["chaotic", "chaotic", "unsettled", "settling"]
    members = {m["member"]: m for m in answer["members"]["132"]}
    chaotic = members["chaotic-k3-opposite-SSS"]
    assert chaotic["count"] == 2 and chaotic["lambda1_per_s"] == 42.0
    assert answer["accounting"]["132"]["attractors"] == 1
    assert answer["accounting"]["132"]["reached"] == 2
    assert list(answer["ladder"]["sets"].values()) == [["chaotic-k3-opposite-SSS"]]
    assert "1 attractor (0 rigid, 0 multi-wave, 1 chaotic), reached by 2 of 3" in answer["text"]
    assert "largest Lyapunov exponent 42 ± 5 1/s" in answer["text"]
    assert "not chaotic: its statistics drift over the last leg (rms_u_r)" in answer["text"]
    assert not answer["finished"]  # seed 4 has a leg due


def test_chaos_verdicts_of_a_real_census_at_its_cap(tmp_path):
    """2 starts of the smoke mesh, no extension (cap = first leg = 0.05 s): those
    unsettled at the cap each get a verdict in chaos.json, with the key of their
    features; the answer's classes are the verdicts' (a start is ``chaotic`` only with
    λ₁ > 0 beyond 3 standard errors and stationary statistics)."""
    pytest.importorskip("dolfinx")
    from stickslip.studies.attractors.census import Census, chaos_shared, collect, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    out = tmp_path / "census"
    spec = Census(SMOKE, (36,), StartDistribution(starts=2), ("time.end_time=0.05",),
                  max_time=0.05)
    assert run_census(spec, out, certify=False, stream=io.StringIO()) == 0
    from mpi4py import MPI

    said = io.StringIO()
    assert chaos_shared(out, MPI.COMM_SELF, said) is False
    answer = collect(out, certify=False)
    verdicts = json.loads((out / "chaos.json").read_text()) if (out / "chaos.json").exists() \
        else {}
    at_cap = [r for r in answer["starts"] if r["class"] in ("unsettled", "chaotic")]
    assert at_cap  # both starts are still growing at 0.05 s (measured: unsettled)
    assert len(verdicts) == len(at_cap)
    assert said.getvalue().startswith(f"chaos: {len(at_cap)} start(s) unsettled at the cap")
    for r in at_cap:
        assert r["chaos"] is not None
        lyap = r["chaos"]["lyapunov"]
        chaotic = bool(lyap and lyap["positive"] and r["chaos"]["stationarity"]["stationary"])
        assert (r["class"] == "chaotic") == chaotic
