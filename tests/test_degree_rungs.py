"""Element-degree rungs in the census ladder (``--meshes 264p1,132p2``, ``--degrees 1,2``).

A rung is (N, p): N contact nodes at Lagrange degree p. The census runs every start of a
rung with that ``mesh.degree``, keys its results ``"N"`` (degree 1, as a plain-N ladder)
or ``"Np2"``, and orders the rungs by dofs. The census here: the smoke scene (N = 36, two
element layers) at P1 and P2, 2 random starts each, one leg of 0.02 s, no certificates:
about 5 s on one core. Bad rungs are refused in one line before anything is written.
"""

from __future__ import annotations

import csv
import json
import tomllib
from pathlib import Path

import pytest
from test_ownership import cli, one_line

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"
CENSUS = ["attractors", str(SMOKE), "--starts", "2", "--end-time", "0.02", "--max-time",
          "0.02", "--no-certify", "--progress", "lines"]


@pytest.fixture(scope="module")
def p1_p2(tmp_path_factory) -> Path:
    """The census of the smoke scene on the rungs 36p1 and 36p2 (module docstring)."""
    from stickslip.cli.main import main

    out = tmp_path_factory.mktemp("rungs") / "census"
    assert main([*CENSUS, "--meshes", "36p2,36p1", "-o", str(out)]) == 0
    return out


def test_keys_folders_and_order(p1_p2):
    """The P1 rung keeps the plain-N key and folder names; the P2 rung is ``36p2`` and its
    start folders say ``degree-2``; the ladder goes by dofs (P1 first, whatever the order
    given)."""
    answer = json.loads((p1_p2 / "attractors.json").read_text())
    assert answer["meshes"] == [36, "36p2"]  # degree 1 as a plain-N census writes it
    assert list(answer["members"]) == ["36", "36p2"]
    assert list(answer["structured"]) == ["36", "36p2"]
    assert list(answer["ladder"]["sets"]) == ["36", "36p2"]
    assert list(answer["ladder"]["coarse"]["dominant_k"]) == ["36", "36p2"]
    assert all(m["count"] for ms in answer["members"].values() for m in ms)
    assert sum(m["count"] for m in answer["members"]["36p2"]) == 2  # both starts counted
    runs = sorted(p.name for p in (p1_p2 / "starts" / "runs").iterdir())
    assert runs == ["n_inner-36_perturbation-random_seed-1",
                    "n_inner-36_perturbation-random_seed-1_degree-2",
                    "n_inner-36_perturbation-random_seed-2",
                    "n_inner-36_perturbation-random_seed-2_degree-2"]
    assert {(r["n_inner"], r["degree"]) for r in answer["starts"]} == {(36, 1), (36, 2)}
    assert "N = 36p2 (2 random starts)" in answer["text"]


def test_p2_starts_ran_at_degree_2(p1_p2):
    """Each start ran at its rung's degree: its own scene says so, and its run has the dofs
    of that degree (N (layers p + 1) nodes, two dofs each: 36 x 3 x 2 = 216 at P1,
    36 x 5 x 2 = 360 at P2)."""
    answer = json.loads((p1_p2 / "attractors.json").read_text())
    for row in answer["starts"]:
        run = Path(row["run_dir"])
        scene = tomllib.loads((run / "scene.toml").read_text())
        summary = json.loads((run / "summary.json").read_text())
        assert scene["mesh"]["degree"] == row["degree"], row["id"]
        assert summary["dofs"] == 2 * 36 * (2 * row["degree"] + 1), row["id"]
        assert summary["status"] == "completed"


def test_csv_rows_tell_rungs_apart(p1_p2):
    """attractors.csv and members.csv carry n_inner and degree."""
    with open(p1_p2 / "attractors.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert sorted((r["n_inner"], r["degree"]) for r in rows) == [
        ("36", "1"), ("36", "1"), ("36", "2"), ("36", "2")]
    with open(p1_p2 / "members.csv") as fh:
        members = list(csv.DictReader(fh))
    assert {m["degree"] for m in members} == {"1", "2"}
    assert sum(int(m["count"]) for m in members if m["degree"] == "2") == 2


def test_reading_the_census_again(p1_p2, capsys):
    """The census directory read back (nothing runs) gives the same rung keys."""
    from stickslip.cli.main import main

    before = (p1_p2 / "attractors.json").read_text()
    assert main(["attractors", str(p1_p2), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["meshes"] == [36, "36p2"]
    assert (p1_p2 / "attractors.json").read_text() == before


def test_rungs_parsed_and_ordered():
    """Plain N at every degree, explicit rungs as given; keys; the ladder by dofs."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.attractors.census import ladder_order
    from stickslip.studies.attractors.starts import parse_rung_key, parse_rungs, rung_key

    assert parse_rungs("132,264", "1,2", 36) == ((132, 1), (132, 2), (264, 1), (264, 2))
    assert parse_rungs("264p1,132p2", None, 36) == ((264, 1), (132, 2))
    assert parse_rungs(None, None, 36, 2) == ((36, 2),)  # the scene's N and degree
    assert (rung_key(132), rung_key(132, 2)) == ("132", "132p2")
    assert parse_rung_key("132p2") == (132, 2) and parse_rung_key(132) == (132, 1)
    # smoke (2 layers): 72p1 has 72 x 3 nodes, 36p2 36 x 5, 48p2 48 x 5
    scene = load_scene(SMOKE)
    assert ladder_order(scene, ((48, 2), (72, 1), (36, 2))) == ((36, 2), (72, 1), (48, 2))


@pytest.mark.parametrize(("argv", "words"), [
    (["--meshes", "36p3"], ("--meshes '36p3'", "degree 3", "p1 or p2")),
    (["--meshes", "36p0"], ("--meshes '36p0'", "degree 0", "p1 or p2")),
    (["--meshes", "35p2"], ("--meshes '35p2'", "even N", "36p2")),
    (["--meshes", "36q2"], ("--meshes '36q2'", "not a rung", "264p1,132p2")),
    (["--meshes", "36,36p1"], ("the rung 36 appears twice",)),
    (["--degrees", "3"], ("--degrees '3'", "1, 2")),
    (["--degrees", "1,1"], ("--degrees '1,1'", "distinct")),
    (["--degrees", "one"], ("--degrees 'one'", "e.g. 1,2")),
    (["--along", "mesh.degree=1,2"], ("sets mesh.degree itself", "--degrees")),
])
def test_bad_rungs_refused_in_one_line(tmp_path, capsys, argv, words):
    """A bad rung or degree: exit 2, one line naming the value and the fix, nothing written."""
    rc, err = cli(capsys, *CENSUS, "-o", tmp_path / "c", *argv)
    one_line(rc, err, *words)
    assert not (tmp_path / "c").exists()


def test_api_takes_degrees(tmp_path):
    """``stickslip.attractors(..., degrees=...)`` reaches the same check (CensusRequest)."""
    import stickslip

    with pytest.raises(ValueError, match="--degrees '3'"):
        stickslip.attractors(SMOKE, tmp_path / "c", starts=1, degrees=(3,), quiet=True)
    assert not (tmp_path / "c").exists()
