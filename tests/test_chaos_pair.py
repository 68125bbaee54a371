"""The chaos test's twin split over two ranks (``chaos.SplitTwin``): the reference on one
rank and the twin on the other, each a batch of one, exchanging the reference's state every
renormalisation.

* ``twin_shares`` puts every λ₁ test on a pair of ranks while there are ranks for all, and
  one rank each otherwise (serial, no FE).
* Under ``mpirun -n 2``, on a census start of the smoke mesh (N = 36):
  - the split twin's ln(d/d₀) of every interval, and so λ₁ and its error, are **bitwise**
    those of the two-column ``BatchTwin`` on one rank (the one-column kernel sums in the
    batched kernels' order, so the same arithmetic runs on either layout);
  - a rank whose set-up or step raises, or that receives SIGINT, stops both ranks at the
    next exchange (``TwinStopped`` naming the rank, or KeyboardInterrupt on both): nothing
    waits for a partner that has left. Each such test ends, or the suite would hang here;
  - ``census.chaos_shared`` with one stationary start runs its λ₁ on both ranks and writes
    the verdict rank 0 alone computes, bit for bit.
"""

from __future__ import annotations

import io
import json
import os
import signal
from pathlib import Path

import pytest
from test_attractors import SMOKE

from stickslip.studies.attractors import census, chaos
from stickslip.studies.attractors.census import twin_shares


def test_twin_shares_pair_ranks_while_there_are_enough():
    """One test on 2 ranks: ranks 0 and 1 share it (roles 0 and 1, each the other's
    partner); two tests on 2 ranks, or three on 4: one rank each (longest first); one test
    on 3 ranks: a pair, the third rank idle."""
    one = [{"id": "a", "cost": 1.0}]
    shares = twin_shares(one, 2)
    assert [[(t["id"], t["role"], t["partner"]) for t in s] for s in shares] == \
        [[("a", 0, 1)], [("a", 1, 0)]]
    two = [{"id": "a", "cost": 1.0}, {"id": "b", "cost": 2.0}]
    assert [[t["id"] for t in s] for s in twin_shares(two, 2)] == [["b"], ["a"]]
    assert all("partner" not in t for s in twin_shares(two, 2) for t in s)
    three = [{"id": x, "cost": 1.0} for x in "abc"]
    assert sum(len(s) for s in twin_shares(three, 4)) == 3
    assert [len(s) for s in twin_shares(one, 3)] == [1, 1, 0]


def _world():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    if comm.size != 2:
        pytest.skip("a paired twin needs mpirun -n 2")
    return comm


@pytest.fixture(scope="module")
def unsettled_start(tmp_path_factory):
    """Two census starts of the smoke mesh run to the cap of 0.05 s on rank 0 (as
    tests/test_census_rungs_chaos.py: both still changing there), the directory shared with
    rank 1: (the census, one start's run directory, the window W)."""
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from stickslip.studies.attractors.census import Census, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    comm = _world()
    out = None
    if comm.rank == 0:
        out = tmp_path_factory.mktemp("pair") / "census"
        spec = Census(SMOKE, (36,), StartDistribution(starts=2), ("time.end_time=0.05",),
                      max_time=0.05)
        assert run_census(spec, out, comm=MPI.COMM_SELF, certify=False,
                          stream=io.StringIO()) == 0
    out = Path(comm.bcast(str(out) if out else None, root=0))
    run = sorted(p.parent for p in (out / "starts" / "runs").glob("*/summary.json"))[0]
    window = json.loads((out / "census.json").read_text())["window_s"]
    return out, run, window


def _pair(comm):
    return chaos.Pair(comm, 1 - comm.rank, comm.rank)


@pytest.mark.parallel
def test_a_split_twin_is_bitwise_the_batch_twin(unsettled_start):
    """30 renormalisations every W/20: the split twin's logs, λ₁ and error on both ranks
    equal the two-column twin's on this rank exactly (no tolerance: the same arithmetic)."""
    comm = _world()
    _, run, window = unsettled_start
    whole = chaos.fe_lyapunov(run, 30 * window / 20, window / 20)
    split = chaos.fe_lyapunov(run, 30 * window / 20, window / 20, pair=_pair(comm))
    assert split.logs == whole.logs
    assert (split.exponent, split.error) == (whole.exponent, whole.error)
    assert comm.allgather(split.logs)[0] == split.logs


@pytest.mark.parallel
def test_a_rank_whose_set_up_fails_stops_both(unsettled_start, monkeypatch):
    """Rank 1 cannot build its batch: both ranks raise TwinStopped naming rank 1."""
    comm = _world()
    _, run, window = unsettled_start
    if comm.rank == 1:
        def broken(run_dir, width):
            raise OSError("disk gone")
        monkeypatch.setattr(chaos, "restored_batch", broken)
    with pytest.raises(chaos.TwinStopped, match="failed on rank 1: OSError: disk gone"):
        chaos.fe_lyapunov(run, 30 * window / 20, window / 20, pair=_pair(comm))


def _at_interval(monkeypatch, comm, rank: int, interval: int, action) -> dict:
    """``action(twin)`` on ``rank`` as its ``interval``-th advance begins; the count of
    advances on this rank."""
    real = chaos.SplitTwin.advance
    calls = {"n": 0}

    def advance(self, duration):
        calls["n"] += 1
        if comm.rank == rank and calls["n"] == interval:
            action(self)
        return real(self, duration)

    monkeypatch.setattr(chaos.SplitTwin, "advance", advance)
    return calls


@pytest.mark.parallel
def test_a_rank_whose_step_fails_midway_stops_both(unsettled_start, monkeypatch):
    """Rank 0's stepper raises at its 5th interval's steps: both ranks raise TwinStopped
    naming rank 0 at that interval's exchange."""
    comm = _world()
    _, run, window = unsettled_start

    def fail(twin):
        twin.stepper.step = lambda: (_ for _ in ()).throw(RuntimeError("NaN in u"))

    calls = _at_interval(monkeypatch, comm, 0, 5, fail)
    with pytest.raises(chaos.TwinStopped, match="failed on rank 0: RuntimeError: NaN in u"):
        chaos.fe_lyapunov(run, 30 * window / 20, window / 20, pair=_pair(comm))
    assert calls["n"] == 5


@pytest.mark.parallel
def test_a_signal_on_one_rank_interrupts_both(unsettled_start, monkeypatch):
    """Rank 1 receives SIGINT during its 3rd interval: recorded, not raised there; both
    ranks raise KeyboardInterrupt at that interval's exchange, and the handlers are back."""
    comm = _world()
    _, run, window = unsettled_start
    calls = _at_interval(monkeypatch, comm, 1, 3,
                         lambda twin: os.kill(os.getpid(), signal.SIGINT))
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        chaos.fe_lyapunov(run, 30 * window / 20, window / 20, pair=_pair(comm))
    assert calls["n"] == 3
    assert signal.getsignal(signal.SIGINT) is before


@pytest.mark.parallel
def test_chaos_shared_splits_one_stationary_start_over_both_ranks(unsettled_start,
                                                                  monkeypatch, tmp_path):
    """The census's chaos pass with its first start's statistics taken as stationary (the
    smoke starts' drift at 0.05 s; the pairing is what is tested): that start's λ₁ runs on
    both ranks (the twin's rank builds a batch too) and chaos.json holds the verdict that
    ``with_lyapunov`` gives on rank 0 alone, bitwise; the other start's drifting verdict is
    written by rank 0 as before."""
    comm = _world()
    out, run, window = unsettled_start
    work = Path(comm.bcast(str(tmp_path) if comm.rank == 0 else None, root=0)) / "c"
    if comm.rank == 0:
        import shutil

        shutil.copytree(out, work, symlinks=True)
    comm.Barrier()
    real = chaos.statistics_verdict
    run = work / run.relative_to(out)

    def first_stationary(run_dir, window, **kw):
        verdict, windows = real(run_dir, window, **kw)
        if Path(run_dir).name == run.name:
            verdict["stationarity"] = dict(verdict["stationarity"], stationary=True)
            verdict["why"] = []
        return verdict, windows

    monkeypatch.setattr(census, "statistics_verdict", first_stationary)
    built = []
    real_restored = chaos.restored_batch
    monkeypatch.setattr(chaos, "restored_batch",
                        lambda run_dir, width: built.append(width) or real_restored(run_dir,
                                                                                      width))
    assert census.chaos_shared(work, comm) is False
    assert comm.allgather(built) == [[1], [1]]  # a batch of one on each rank
    if comm.rank == 0:
        verdicts = json.loads((work / "chaos.json").read_text())
        assert len(verdicts) == 2
        mine = [v for v in verdicts.values() if v["lyapunov"] is not None]
        assert len(mine) == 1
        verdict, windows = first_stationary(run, window)
        alone = chaos.with_lyapunov(verdict, run, window, windows)
        assert mine[0]["lyapunov"] == alone["lyapunov"]
        assert mine[0]["class"] == alone["class"]
