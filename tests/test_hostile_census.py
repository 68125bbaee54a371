"""The attractor census (`stickslip attractors`) under hostile conditions: a signal or a full
disk during its settle legs, caches of the wrong JSON type, `--along` over an integer key,
a cap without bound, and a read-only census directory.

The one status rule: an answer is final only when every leg finished. A census stopped in
a settle leg says NOT FINISHED, exits 130 (a signal) or 1 (an error), writes no
final-looking answer (``attractors.json``: ``"finished": false``; its starts below the cap
are ``settling``, never "unsettled at the cap") and the same command resumes it to the answer
of a census never stopped.

The census of the report: the damped figure-3 scene at N = 36, 3 random starts, a first leg
of 0.1 s continued in legs of x1.5 up to 0.4 s (two starts settle on one multi-wave attractor
by 0.34 s, one is unsettled at the cap): about 5 s on one core.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from faults import digest
from test_ownership import cli, one_line
from test_sweep import _env

from stickslip.cli.main import main

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "scenes" / "figure3_n132_damped.toml"
CAP = 0.4
CENSUS = ["attractors", str(SCENE), "--starts", "3", "--meshes", "36", "--end-time", "0.1",
          "--max-time", str(CAP), "--progress", "lines"]


def census(out: Path, *extra: str) -> list[str]:
    return [*CENSUS, "-o", str(out), *extra]


def answer_of(out: Path) -> dict:
    return json.loads((out / "attractors.json").read_text())


def members(answer: dict) -> dict:
    """Per mesh, each member's (name, class, count of starts, starts counted)."""
    return {n: sorted((m["member"], m["class"], m["count"], m["starts"]) for m in ms)
            for n, ms in answer["members"].items()}


def assert_not_finished(out: Path, text: str, why: str) -> dict:
    """The answer of a stopped census: NOT FINISHED on the console and in attractors.json;
    no start below the cap is called unsettled (that is "at the cap"), in the json or csv."""
    assert f"NOT FINISHED ({why})" in text, text
    answer = answer_of(out)
    assert answer["finished"] is False and answer["stopped"] == why
    rows = answer["starts"]
    assert all(r["class"] != "unsettled" or r["sim_time_s"] >= CAP * (1 - 1e-9) for r in rows)
    assert any(r["class"] == "settling" for r in rows)
    csv_classes = [line.split(",")[6] for line in
                   (out / "attractors.csv").read_text().splitlines()[1:]]
    assert sorted(csv_classes) == sorted(r["class"] for r in rows)
    return answer


@pytest.fixture(scope="module")
def done(tmp_path_factory) -> tuple[Path, dict]:
    """The census of the report, never stopped: its directory and answer (copied by each
    test that changes it)."""
    pytest.importorskip("dolfinx")
    out = tmp_path_factory.mktemp("census") / "done"
    assert main(census(out)) == 0
    answer = answer_of(out)
    # the report's true answer: one attractor reached by 2 of 3 starts, one start unsettled
    # at the cap
    assert answer["finished"] is True and answer["counts"] == {"multi-wave": 2, "unsettled": 1}
    return out, answer


def copy(done: tuple[Path, dict], to: Path) -> Path:
    shutil.copytree(done[0], to, symlinks=True)
    return to


def assert_resumes_to(out: Path, done: tuple[Path, dict], capsys) -> None:  # noqa: ANN001
    """The same command again finishes the census: the answer of the one never stopped
    (the same members and counts; celerities to 1e-9, the same legs from the same states)."""
    capsys.readouterr()
    assert main(census(out)) == 0
    text = capsys.readouterr().out
    assert "NOT FINISHED" not in text and "3 already done, 0 to run" in text, text
    answer = answer_of(out)
    assert answer["finished"] is True and members(answer) == members(done[1])
    for mine, theirs in zip(answer["members"]["36"], done[1]["members"]["36"], strict=True):
        assert mine["celerity_m_s"] == pytest.approx(theirs["celerity_m_s"], rel=1e-9)


# ------------------------------------------------------------------ stopped in a settle leg


def test_sigterm_in_a_settle_leg_says_not_finished_and_resumes(done, tmp_path, capsys):
    """SIGTERM after a `settle:` line exited 130 but printed (and wrote) "0 attractors,
    unsettled 3/3 = 100 % ... at the cap": the starts stood at 0.15 s of 0.4 s."""
    out = tmp_path / "census"
    proc = subprocess.Popen([sys.executable, "-m", "stickslip.cli.main", *census(out)],
                            cwd=REPO, env=_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        seen = ""
        for line in proc.stdout:  # the program's own readiness line, then the signal
            seen += line
            if line.startswith("settle:"):
                proc.send_signal(signal.SIGTERM)
                break
        seen += proc.stdout.read()
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, seen
    assert_not_finished(out, seen, "interrupted")
    assert_resumes_to(out, done, capsys)


def _disk_full_in_settle_legs(monkeypatch) -> dict:  # noqa: ANN001
    """From the first settle leg on, every write of a start's samples or fields
    (``*.npz``) fails with ENOSPC, as on the full tmpfs of the report (the small files
    still fit); returns {"legs": calls of continue_batch}."""
    import stickslip.solver.atomic  # noqa: F401 (loaded: used as an attribute)
    import stickslip.studies.attractors.census  # noqa: F401 (loaded: used as an attribute)
    import stickslip.studies.rundir  # noqa: F401 (loaded: used as an attribute)
    from stickslip import solver, studies

    real_write, real_continue = solver.atomic.atomic_write, studies.rundir.continue_batch
    state = {"legs": 0}

    def write(path, fill):  # noqa: ANN001, ANN202
        if state["legs"] and "runs" in Path(path).parts and str(path).endswith(".npz"):
            raise OSError(errno.ENOSPC, "No space left on device (injected)")
        return real_write(path, fill)

    def continue_batch(*a, **k):  # noqa: ANN002, ANN003, ANN202
        state["legs"] += 1
        return real_continue(*a, **k)

    monkeypatch.setattr(solver.atomic, "atomic_write", write)
    monkeypatch.setattr(studies.rundir, "continue_batch", continue_batch)
    monkeypatch.setattr(studies.attractors.census, "continue_batch", continue_batch)
    return state


def test_a_full_disk_in_settle_legs_fails_the_census_and_resumes(done, tmp_path, monkeypatch,
                                                                 capsys):
    """On a 12 MB tmpfs the legs failed with ENOSPC, said only in settle-rank0.log; the
    census exited 0 with "0 attractors ... at the cap" ("not continued: its last leg ended
    at 0.100056 s"). Now each start's error is one line on stderr, exit 1, NOT FINISHED,
    every start kept at its last whole leg; with space again the same command finishes."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "census"
    state = _disk_full_in_settle_legs(monkeypatch)
    rc = main(census(out))
    cap = capsys.readouterr()
    assert state["legs"] >= 1 and rc == 1, cap.out + cap.err
    errors = cap.err.splitlines()
    assert len(errors) == 3 and all(
        e.startswith("error: settle: n_inner-36_perturbation-random_seed-") and
        "No space left on device" in e for e in errors), cap.err
    answer = assert_not_finished(out, cap.out, "a leg failed")
    assert all(r["sim_time_s"] == pytest.approx(0.100056, abs=1e-6) for r in answer["starts"])
    monkeypatch.undo()  # space again
    assert_resumes_to(out, done, capsys)


# ------------------------------------------------------------------ caches of the wrong type


@pytest.mark.parametrize("name", ["features.json", "certificates.json"])
def test_a_cache_of_another_json_type_is_computed_again(done, tmp_path, capsys, name):
    """features.json or certificates.json replaced by `[1,2,3]`: a traceback, reading or
    rerunning. A cache is only a cache: computed again, the same answer."""
    out = copy(done, tmp_path / "census")
    for argv in (["attractors", str(out)], census(out)):
        (out / name).write_text("[1,2,3]\n")
        assert main(argv) == 0
        assert "Traceback" not in capsys.readouterr().err
        assert members(answer_of(out)) == members(done[1])
    assert isinstance(json.loads((out / name).read_text()), dict)
    assert answer_of(out)["certificates"].keys() == done[1]["certificates"].keys()


@pytest.mark.parametrize(("content", "why"), [
    (b'{"kind": "stickslip-attractors", "defin', "Unterminated string"),  # truncated
    (b"[1,2,3]\n", "not a JSON object"),
    (b"\x89PNG\r\n\x1a\n\x00\xff\xfe", "not UTF-8 text"),
], ids=["truncated", "list", "bytes"])
def test_a_census_json_that_is_no_definition_is_named_in_one_line(done, tmp_path, capsys,
                                                                   content, why):
    """census.json truncated or `[1,2,3]`: a traceback; random bytes: "a file is not UTF-8
    text", not naming it. Now one line naming the file and the fix (exit 2), reading or
    rerunning, nothing changed; --force writes it again and the census answers as before."""
    out = copy(done, tmp_path / "census")
    (out / "census.json").write_bytes(content)
    before = digest(out)
    for argv in (["attractors", str(out)], census(out)):
        rc, err = cli(capsys, *argv)
        one_line(rc, err, f"{out / 'census.json'} is not a census definition", why,
                 "--force")
        assert digest(out) == before
    assert main(census(out, "--force")) == 0
    assert members(answer_of(out)) == members(done[1])


# ------------------------------------------------------------------ arguments


@pytest.mark.parametrize(("key", "values", "field"), [
    ("mesh.n_radial", (2, 3), lambda d: d["definition"]["scene"]["mesh"]["n_radial"]),
    ("initial.n_modes", (4, 8), lambda d: d["distribution"]["n_modes"]),
])
def test_along_an_integer_key(tmp_path, capsys, key, values, field):
    """`--along mesh.n_radial=2,3` (or `initial.n_modes=4,8`) said "has the wrong type: must
    be an integer"; and a curve along initial.n_modes ran every point with --n-modes. Now
    each point's census has the value (one start, one short leg: the values, not the
    physics, are checked here)."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "along"
    rc = main(["attractors", str(SCENE), "--starts", "1", "--meshes", "36", "--end-time",
               "0.02", "--max-time", "0.02", "--no-certify", "-o", str(out), "--along",
               f"{key}={','.join(map(str, values))}"])
    assert rc == 0, capsys.readouterr()
    short = key.rsplit(".", 1)[-1]
    for v in values:
        meta = json.loads((out / "points" / f"{short}-{v}" / "census.json").read_text())
        assert field(meta) == v
        assert meta["definition"]["scene"][key.split(".")[0]][short] == v


def test_along_a_key_that_every_start_sets_is_refused(tmp_path, capsys):
    rc, err = cli(capsys, *CENSUS, "-o", tmp_path / "c", "--along", "mesh.n_inner=36,48")
    one_line(rc, err, "every start of a census sets mesh.n_inner itself", "--meshes")
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize(("cap", "extra", "words"), [
    ("inf", (), "give a finite time"),
    ("inf", ("--yes-i-know",), "give a finite time"),  # never finishes: no opt-out
    ("1e9", (), "days on 1 rank(s) (estimate; the bound is 2 days)"),
    ("1e300", (), "more than 1e+18 time steps"),
])
def test_a_cap_without_bound_is_refused_by_its_cost_guard(tmp_path, capsys, cap, extra, words):
    """`--max-time inf` (or 1e9) was accepted: legs grew to 100 s, 6.6 GB of memory and
    3 GB of disk after 200 s. Now one line with the bound and the fix, nothing made."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "c"
    argv = [a if a != str(CAP) else cap for a in census(out, *extra)]
    rc, err = cli(capsys, *argv)
    one_line(rc, err, f"--max-time {float(cap):g}", words)
    if cap == "1e9":
        assert "give a smaller --max-time" in err and "--yes-i-know" in err
    assert not out.exists()


# ------------------------------------------------------------------ reading an answer


def test_reading_an_answer_writes_nothing_unchanged(done, capsys):
    """Reading a finished census rewrote features.json (and the answer) every time."""
    out = done[0]
    stamps = {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()}
    assert main(["attractors", str(out)]) == 0
    assert "1 attractor" in capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()} == stamps


def test_reading_an_answer_in_a_read_only_directory(done):
    """`stickslip attractors D` on a read-only mount failed writing `.features.json.*.tmp`.
    Read as the unprivileged user `nobody` (root writes anywhere), with features.json gone
    (the cache it would write): the same answer, exit 0, the directory as it was."""
    import tempfile

    if os.geteuid() != 0:
        pytest.skip("needs root to run a command as another user")
    top = Path(tempfile.mkdtemp(dir="/tmp"))
    try:
        out = copy(done, top / "census")
        (out / "features.json").unlink()
        for p in [top, *top.rglob("*")]:
            p.chmod(0o755 if p.is_dir() else 0o644)  # readable, writable by root only
        before = digest(out)
        res = subprocess.run(
            [sys.executable, "-m", "stickslip.cli.main", "attractors", str(out), "--json"],
            cwd=REPO, capture_output=True, text=True, timeout=120,
            env={**_env(), "HOME": "/tmp"}, preexec_fn=lambda: os.setuid(65534))
        assert res.returncode == 0 and not res.stderr, res.stderr
        answer = json.loads(res.stdout)
        assert answer["finished"] is True and members(answer) == members(done[1])
        assert digest(out) == before and not (out / "features.json").exists()
    finally:
        shutil.rmtree(top)
