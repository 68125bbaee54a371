"""Settle or extend: a census continues its unsettled starts from their checkpoints (never
from t = 0) up to its cap, records each start's settle time, and a resumed census counts
a continued start as done."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys

import numpy as np
import pytest
from test_attractors import REPO, SMOKE
from test_sweep import _env, _starts

from stickslip.studies.attractors.features import settle_scan

# ------------------------------------------------------------------ the settle time, exact


def _switched(t_switch: float) -> tuple[dict, float]:
    """A rigid wave whose amplitude steps up by 20 % at t_switch: stationary before and
    after, never across the step. Samples every 1e-4 s to 0.6 s; window 0.05 s."""
    theta = np.linspace(0.0, 2.0 * np.pi, 36, endpoint=False)  # 36 contact nodes
    t = np.arange(0.0, 0.6 + 5e-5, 1e-4)
    k, c, radius = 7, -300.0, 1.0  # wavenumber, angular speed (rad/s)
    phase = k * (theta[None, :] - c * t[:, None])
    gain = np.where(t >= t_switch, 1.2, 1.0)[:, None]
    u_r = 1e-3 * gain * np.cos(phase)
    u_theta = 3e-4 * gain * np.sin(phase)
    return {"t": t, "theta": theta, "u_r": u_r, "u_theta": u_theta}, radius


def test_settle_time_is_the_first_stationary_pair_after_a_change():
    samples, radius = _switched(10.0)  # no step: stationary from the first pair on
    window = 0.05
    earlier, later, t_s = settle_scan(samples, radius, window)
    assert earlier.listed[0].k == later.listed[0].k == 7
    # Pairs end at t_end − jW; the earliest with t − 2W ≥ t₀ = 0 ends at 0.1 s (up to one
    # sample, 1e-4 s, from the inclusive window ends).
    assert t_s == pytest.approx(0.1, abs=1.1e-4)
    # A 20 % step at 0.3 s changes the RMS amplitude of every pair that straddles it
    # (tolerance 5 %): the first pair wholly after it ends at 0.3 + 2W = 0.4 s.
    samples, radius = _switched(0.3)
    _, _, t_s = settle_scan(samples, radius, window)
    assert t_s == pytest.approx(0.4, abs=1.1e-4)
    # The step inside the last pair: unsettled, no settle time.
    samples, radius = _switched(0.57)
    _, _, t_s = settle_scan(samples, radius, window)
    assert math.isnan(t_s)


# ------------------------------------------------------------------ the census, end to end


def _census(out, max_time: float):
    from stickslip.studies.attractors.census import Census, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    # Stick-slip on the smoke mesh (Omega = 20 rad/s, delta = 5e-3, as test_attractors):
    # 3 starts at N = 36, a first leg of 0.05 s (windows of 1/60 s).
    census = Census(SMOKE, (36,), StartDistribution(starts=3),
                    ("loading.omega=20", "geometry.delta=0.005", "time.end_time=0.05"),
                    max_time=max_time)
    import io

    stream = io.StringIO()
    rc = run_census(census, out, certify=False, stream=stream, progress="lines")
    return rc, stream.getvalue(), json.loads((out / "attractors.json").read_text())


@pytest.fixture(scope="module")
def settled(tmp_path_factory):
    pytest.importorskip("dolfinx")
    out = tmp_path_factory.mktemp("settle") / "census"
    rc, text, answer = _census(out, 0.1)
    return out, rc, text, answer


def test_unsettled_starts_are_continued_up_to_the_cap(settled):
    out, rc, text, answer = settled
    assert rc == 0, text
    rows = answer["starts"]
    assert len(rows) == 3
    # Each start ran once from t = 0 (one '== start' line in its sweep log) ...
    assert _starts(out / "starts") == {r["id"]: 1 for r in rows}
    # ... and the continued ones went on from their checkpoints: one 'continuing ... from
    # t = T' line per leg in the settle log, T the end of the leg before (never 0).
    log = (out / "settle-rank0.log").read_text()
    froms = [float(x.split("from t = ")[1].split(" s")[0]) for x in log.splitlines()
             if x.startswith("continuing")]
    assert froms and min(froms) >= 0.05, log
    assert "settle: continuing" in text
    for r in rows:
        t, dt = r["sim_time_s"], r["dt_s"]
        # the samples span [0, t]: one run, its steps t/dt (a whole step past each end)
        assert r["steps"] == pytest.approx(t / dt, abs=1.0)
        assert t <= 0.1 + dt  # never past the cap
        if r["class"] == "unsettled":
            assert t >= 0.1 - 1e-9  # unsettled only at the cap
            assert not math.isfinite(r["settle_time_s"] or math.nan)
        elif r["class"] in ("wave", "multi-wave"):
            # settled from a window pair's end: at least 2W = 1/30 s, at most its end time
            assert 1.0 / 30.0 - 1e-9 <= r["settle_time_s"] <= t + 1e-12


def test_resumed_census_does_not_rerun_continued_starts(settled):
    out, _, _, answer = settled
    before = {r["id"]: (r["steps"], r["sim_time_s"]) for r in answer["starts"]}
    log = (out / "settle-rank0.log").read_text()
    rc, text, again = _census(out, 0.1)
    assert rc == 0, text
    assert "3 already done, 0 to run" in text and "settle: continuing" not in text
    assert _starts(out / "starts") == {i: 1 for i in before}
    assert {r["id"]: (r["steps"], r["sim_time_s"]) for r in again["starts"]} == before
    assert (out / "settle-rank0.log").read_text() == log
    assert again["members"] == answer["members"]


def test_a_larger_cap_continues_only_the_unsettled(settled):
    out, _, _, answer = settled
    before = {r["id"]: r for r in answer["starts"]}
    rc, text, again = _census(out, 0.15)
    assert rc == 0, text
    assert _starts(out / "starts") == {i: 1 for i in before}  # nothing from t = 0
    for r in again["starts"]:
        old = before[r["id"]]
        if old["class"] == "unsettled":
            assert r["sim_time_s"] > old["sim_time_s"]
        else:  # settled before: untouched
            assert r["sim_time_s"] == old["sim_time_s"] and r["steps"] == old["steps"]


def test_sweep_counts_a_run_continued_past_its_end_time_as_done():
    from stickslip.studies.sweep.table import _continued_past

    wanted = {"time": {"end_time": 0.3, "max_steps": 0}, "mesh": {"n_inner": 132}}
    longer = {"time": {"end_time": 0.45, "max_steps": 0}, "mesh": {"n_inner": 132}}
    assert _continued_past(longer, wanted, {"sim_time_s": 0.4500001})
    assert not _continued_past(longer, wanted, {"sim_time_s": 0.2})  # stopped early
    assert not _continued_past(wanted, longer, {"sim_time_s": 0.3})  # shorter: run again
    other = {**longer, "mesh": {"n_inner": 264}}
    assert not _continued_past(other, wanted, {"sim_time_s": 0.45})  # another scene
    capped = {**longer, "time": {"end_time": 0.45, "max_steps": 10}}
    assert not _continued_past(capped, wanted, {"sim_time_s": 0.45})


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_census_killed_while_settling_resumes_every_start_once(tmp_path, sig):
    """Killed once it says it continues starts (its own marker line), then run again: every
    start in the answer once, each run once from t = 0, none lost or half-continued."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "census"
    cmd = [sys.executable, "-m", "stickslip.cli.main", "attractors", str(SMOKE), "--starts", "3",
           "--meshes", "36", "--end-time", "0.05", "--max-time", "0.1",
           "--set", "loading.omega=20", "--set", "geometry.delta=0.005", "-o", str(out),
           "--no-certify", "--progress", "lines"]
    proc = subprocess.Popen(cmd, cwd=REPO, env=_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        seen = ""
        for line in proc.stdout:
            seen += line
            if line.startswith("settle: continuing"):
                proc.send_signal(sig)
                break
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "settle: continuing" in seen, seen
    res = subprocess.run([*cmd, "--json"], cwd=REPO, env=_env(), capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    rows = json.loads(res.stdout)["starts"]
    assert sorted(r["id"] for r in rows) == sorted(_starts(out / "starts"))
    assert set(_starts(out / "starts").values()) == {1}  # each run once from t = 0
    assert all(r["class"] in ("wave", "multi-wave", "unsettled") for r in rows)
    assert all(r["class"] != "unsettled" or r["sim_time_s"] >= 0.1 - 1e-9 for r in rows)
    assert not [p for p in (out / "starts" / "runs").iterdir() if p.name.startswith(".")]


@pytest.mark.parallel
def test_shared_featurising_and_certificates_give_the_answer_of_rank_0_alone(tmp_path):
    """Under mpirun the ranks featurise each settle round's starts and certify the members
    (with kicks) together (``census.on_ranks``). Rank 0 then collects the same census again
    alone from a copy without those caches: every row, member and certificate is the same
    (as attractors.json writes them; only the directories of the runs they name differ)."""
    pytest.importorskip("dolfinx")
    import io
    import shutil
    from pathlib import Path

    from mpi4py import MPI

    from stickslip.studies.attractors.census import Census, collect, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_path), root=0)) / "census"
    spec = Census(SMOKE, (36, 48), StartDistribution(starts=3),  # a mesh per rank
                  ("loading.omega=20", "geometry.delta=0.005", "time.end_time=0.05"),
                  max_time=0.1)
    assert run_census(spec, out, comm=comm, stream=io.StringIO()) == 0
    if comm.rank != 0:
        return
    shared = json.loads((out / "attractors.json").read_text())
    alone_dir = out.parent / "alone"
    shutil.copytree(out, alone_dir, ignore=shutil.ignore_patterns(
        "features.json", "certificates.json", "kicks"))
    collect(alone_dir, certify="run", sweep_s=1.0)
    alone = json.loads((alone_dir / "attractors.json").read_text())
    assert shared["certificates"], shared["text"]

    def same(answer: dict) -> tuple:
        rows = [{k: v for k, v in r.items() if k not in ("run_dir", "wall_time_s")}
                for r in answer["starts"]]
        certs = {k: {q: {**v, "run": None} if isinstance(v, dict) and "run" in v else v
                     for q, v in c.items()} for k, c in answer["certificates"].items()}
        return rows, answer["members"], certs

    assert same(shared) == same(alone)
