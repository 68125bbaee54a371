"""The census's printed answer and ``basins.png`` read without a legend of signs.

* Printed lines name every component with its direction in words ("k = 6 with the
  rotation, +1352.6 m/s; k = 6 against the rotation, -4642.4 m/s"), use "with" for nothing
  but that direction ("carrying" lists companions) and keep the member ids in brackets;
  each member has a readable ``label`` (synthetic rows through ``census.answer_of``: no FE
  run, well under a second).
* ``basins.png`` draws attractors as solid bars and every other state (unsettled,
  settling, transient, diverged) hatched, in a group of its own, with a legend that says
  which is which (a synthetic answer).
* The annotated example of docs/tutorial/attractors.md is what its command prints: the
  census is run again here (figure 1 damped, 4 starts at N = 72 and 132, a first leg of
  0.1 s capped at 0.3 s: 10 – 20 s on one core) and compared line for line, every number
  to its printed digits; only the wall-clock ``time:`` line is masked.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from stickslip.studies.attractors.classify import member_description
from stickslip.studies.attractors.features import Component, Features
from stickslip.studies.attractors.plots import OTHER_HATCH, basins_figure
from stickslip.studies.attractors.statistics import SETTLED

REPO = Path(__file__).resolve().parents[1]
TUTORIAL = REPO / "docs" / "tutorial" / "attractors.md"
#: The example census of the tutorial (run with ``-o`` added).
EXAMPLE = ("attractors scenes/figure1_n132_damped.toml --starts 4 --meshes 72,132 "
           "--end-time 0.1 --max-time 0.3")
SSS = "stick-slip-separation"

# ============================================================ the printed lines


def _features(dominant: tuple[int, str, float], companions=()) -> Features:
    """Features with a dominant (k, direction, celerity) and companions (k, direction,
    celerity, share); frequencies k c / 2π R with R = 1."""
    def comp(k, direction, celerity, share):
        return Component(k=k, direction=direction, share=share, amplitude_m=share * 1e-3,
                         frequency_hz=k * celerity / (2 * math.pi), celerity_m_s=celerity,
                         weak=share < 0.1)

    return Features((comp(*dominant, 1.0), *(comp(*c) for c in companions)),
                    {"separation": 0.7, "stick": 0.14, "slip": 0.16})


#: The report's multi-wave state: k = 9 with the rotation carrying k = 15 against it, k = 3
#: and 6 with it, and k = 6 against it (the same k both ways: told apart by words).
TORUS = _features((9, "rotation", 1773.9), [(15, "opposite", -800.2, 0.40),
                                            (3, "rotation", 2596.1, 0.35),
                                            (6, "rotation", 1352.6, 0.34),
                                            (6, "opposite", -4642.4, 0.12)])
RIGID = _features((13, "opposite", -857.9))


def _row(n: int, seed: int, cls: str, feats: Features | None) -> dict:
    top = feats.dominant if feats else None
    return {"id": f"n{n}-s{seed}", "n_inner": n, "start": "random", "seed": seed,
            "start_mode": None, "status": "completed" if cls != "diverged" else "diverged",
            "class": cls, "k": top.k if top else None,
            "direction": top.direction if top else None, "regime": SSS if top else None,
            "celerity_m_s": top.celerity_m_s if top else None,
            "frequency_hz": abs(top.frequency_hz) if top else None, "sim_time_s": 4.0,
            "settle_time_s": 1.2 if cls in SETTLED else math.nan,
            "features": feats.to_dict() if feats else None,
            "features_before": feats.to_dict() if feats else None,
            **{k: 0.5 for k in ("fraction_separation", "fraction_stick", "fraction_slip",
                                "psi1", "psi2", "amplitude_m", "rms_amplitude_m")}}


@pytest.fixture(scope="module")
def answer() -> dict:
    """Two meshes: the torus (2 starts), the rigid k = 13, an unsettled k = 12 and a
    diverged start each; certificates left out (``certify_in`` None)."""
    from stickslip.studies.attractors.census import answer_of

    unsettled = _features((12, "opposite", -880.8), [(11, "opposite", -935.0, 0.3)])
    rows = [r for n in (132, 264) for r in (
        _row(n, 1, "multi-wave", TORUS), _row(n, 2, "multi-wave", TORUS),
        _row(n, 3, "wave", RIGID), _row(n, 4, "unsettled", unsettled),
        _row(n, 5, "diverged", None))]
    meta = {"celerity_tol": 0.02, "spread_tol": 0.1, "scene_file": "x", "overrides": [],
            "meshes": [132, 264], "definition": {"scene": {"name": "x"}}, "max_time_s": 4.0,
            "distribution": {"starts": 5, "seed": 1, "n_modes": 16, "amplitude": 0.1}}
    return answer_of(meta, rows)


def test_every_component_is_named_with_its_direction_in_words(answer):
    text = answer["text"]
    mentions = list(re.finditer(r"k = \d+(.{0,21})", text))
    assert len(mentions) > 20, text
    for found in mentions:  # every wavenumber printed carries its direction in words
        assert found[1].startswith((" with the rotation", " against the rotation")), (
            found[0], text)
    # "with" says a direction only; companions are "carried"
    assert not re.findall(r"\bwith\b(?! the rotation)", text), text
    assert not re.search(r"\bk\d+[+-](\s|$)", text), text  # no "k9+" keys of the ladder
    # the report's case: the same k both ways, told apart by words, on the companions' line
    carrying = next(line for line in text.splitlines() if "k = 6 with" in line)
    assert carrying.strip().startswith("carrying ")
    assert "k = 6 with the rotation, +1352.6 m/s (34 %)" in carrying
    assert "k = 6 against the rotation, -4642.4 m/s (12 %)" in carrying
    assert "k = 15 against the rotation, -800.2 m/s (40 %)" in carrying


def test_attractors_first_then_the_rest_with_the_machine_ids_kept(answer):
    text = answer["text"]
    ids = {m["member"] for m in answer["members"]["132"]}
    assert ids == {"k9-rotation-SSS+k15o+k3+k6+k6o", "k13-opposite-SSS",
                   "unsettled-k12-opposite-SSS", "diverged"}
    mesh = text.split("N = 132")[1].split("N = 264")[0].splitlines()
    attractors = [line[2:] for line in mesh if re.match(r"  \S", line)]
    others = [line[4:] for line in mesh if re.match(r"    \S", line)]
    assert attractors[0].startswith("multi-wave k = 9 with the rotation, +1773.9 m/s, "
                                    "2540.9 Hz, stick-slip-separation: 2 of 5 starts = 40 % "
                                    "(95 % CI 12 %–77 %); settled by 1.20 s (median)")
    assert attractors[0].endswith("[k9-rotation-SSS+k15o+k3+k6+k6o]")
    assert attractors[1].startswith("rigid wave k = 13 against the rotation, -857.9 m/s")
    assert attractors[2] == "not attractors:"
    assert others[0].startswith("carrying k = 15 against the rotation")  # the torus's
    assert others[1] == "torus of 5 generators"  # its lattice (no resolution: no tones)
    assert others[2] == "diverged: 1 of 5 starts = 20 % (95 % CI 4 %–62 %)"
    assert others[3].startswith("unsettled k = 12 against the rotation, -880.8 m/s")
    assert others[3].endswith("[unsettled-k12-opposite-SSS]")
    assert ("k9-rotation-SSS+k15o+k3+k6+k6o: k = 9 with the rotation, celerity 132→264: "
            "+0.00 %; k = 15 against the rotation, celerity 132→264: +0.00 %, share 40 % → "
            "40 %") in text
    assert "N = 132: 40 % k = 9 with the rotation, 20 % diverged" in text


def test_labels_and_names_say_direction_in_words(answer):
    by = {m["member"]: m for m in answer["members"]["132"]}
    torus = by["k9-rotation-SSS+k15o+k3+k6+k6o"]
    assert torus["label"] == ("multi-wave k = 9 with the rotation carrying k = 15, 6 against "
                              "the rotation and k = 3, 6 with the rotation")
    assert torus["name"] == (
        "k = 9 with the rotation, carrying k = 15 against the rotation (40 %), k = 3 with "
        "the rotation (35 %), k = 6 with the rotation (34 %) and k = 6 against the rotation "
        "(12 %)")
    assert by["k13-opposite-SSS"]["label"] == "rigid wave k = 13 against the rotation"
    assert by["unsettled-k12-opposite-SSS"]["label"] == "unsettled k = 12 against the rotation"
    assert by["diverged"]["label"] == "diverged"
    assert member_description("k9-rotation-SSS+k15o+k3+k6+k6o#2") == (
        "k = 9 with the rotation, stick-slip-separation, carrying k = 15 against the "
        "rotation, k = 3 with the rotation, k = 6 with the rotation and k = 6 against the "
        "rotation (group 2)")


# ============================================================ basins.png


def _entry(member, cls, count, k=None, label=None):
    from stickslip.studies.attractors.statistics import wilson

    lo, hi = wilson(count, 8)
    return {"member": member, "class": cls, "count": count, "starts": 8, "share": count / 8,
            "share_lo": lo, "share_hi": hi, "label": label or cls, "k": k}


def test_basins_draws_attractors_solid_and_the_rest_hatched_apart(tmp_path):
    """Two meshes. The rigid k = 12 is an attractor at N = 132 and a transient at 264: it
    stands with the attractors, hatched at 264. A settling start carries no member id."""
    answer = {"scene": {"name": "x"}, "members": {
        "132": [_entry("k12-opposite-SSS", "wave", 3, 12, "rigid wave k = 12 against"),
                _entry("k9-rotation-SSS+k3", "multi-wave", 2, 9, "multi-wave k = 9 with"),
                _entry("unsettled-k13-opposite-SSS", "unsettled", 2, 13, "unsettled k = 13"),
                _entry("diverged", "diverged", 1)],
        "264": [_entry("k12-opposite-SSS", "transient", 4, 12, "transient k = 12"),
                _entry(None, "settling", 3, 11, "settling k = 11"),
                _entry("diverged", "diverged", 1)]}}
    fig = basins_figure(answer)
    ax = fig.axes[0]
    ticks = [t.get_text().replace("\n", " ") for t in ax.get_xticklabels()]
    assert ticks == ["rigid wave k = 12 against", "multi-wave k = 9 with", "diverged",
                     "settling k = 11", "unsettled k = 13"]
    bars = ax.patches  # one bar per mesh and member, mesh by mesh, in the ticks' order
    assert len(bars) == 2 * len(ticks)
    classes = {(n, m["member"] or m["class"]): m["class"]
               for n, ms in answer["members"].items() for m in ms}
    keys = ["k12-opposite-SSS", "k9-rotation-SSS+k3", "diverged", "settling",
            "unsettled-k13-opposite-SSS"]
    for j, n in enumerate(("132", "264")):
        for i, key in enumerate(keys):
            bar = bars[j * len(keys) + i]
            cls = classes.get((n, key))
            solid = cls in SETTLED if cls else i < 2  # a member not reached: its group's
            assert (bar.get_hatch() is None) == solid, (n, key, bar.get_hatch())
            if not solid:
                assert bar.get_hatch() == OTHER_HATCH
                assert bar.get_facecolor()[:3] == pytest.approx((0.92,) * 3)
    x = [b.get_x() + b.get_width() / 2 for b in bars[:len(keys)]]
    assert max(x[:2]) < min(x[2:]) - 1.0  # the non-attractors apart, past a gap
    assert {t.get_text() for t in ax.texts} == {"attractors", "not attractors"}
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend[:2] == ["N = 132 (8 starts)", "N = 264 (8 starts)"]
    assert legend[2].startswith("attractor: solid bar")
    assert legend[3].startswith("not an attractor: hatched") and "settling" in legend[3]
    fig.savefig(tmp_path / "basins.png")
    assert (tmp_path / "basins.png").stat().st_size > 10_000


# ============================================================ the tutorial's example


def _quoted_answer(doc: str) -> str:
    """The ``text`` block that follows the example command in the tutorial."""
    after = doc.split(f"./dev stickslip {EXAMPLE} -o ", 1)[1]
    return after.split("```text\n", 1)[1].split("```", 1)[0]


def _masked(text: str) -> str:
    return re.sub(r"^time: .*$", "time: (wall clock)", text.strip(), flags=re.M)


def test_the_tutorials_annotated_answer_is_what_the_command_prints(tmp_path, capsys):
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    doc = TUTORIAL.read_text()
    assert f"./dev stickslip {EXAMPLE} -o " in doc
    args = EXAMPLE.replace("scenes/", f"{REPO}/scenes/").split()
    assert main([*args, "-o", str(tmp_path / "census")]) == 0
    out = capsys.readouterr().out
    printed = out[out.index("attractors of "):]
    assert _masked(printed) == _masked(_quoted_answer(doc))
    assert not re.search(r"\bnan\b", printed, re.I)  # no silent NaN among the values
