"""Batched ensemble (solver/ensemble.py, studies/sweep/batch.py): a batch gives every scene
the numbers of its single-scene run, its own run directory, status and resume semantics."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

pytest.importorskip("dolfinx")
pytest.importorskip("numba")
from mpi4py import MPI  # noqa: E402

SELF = MPI.COMM_SELF
#: Keys of summary.json that are about the machine, not the numbers (wall times, memory,
#: the kernel's name and compile time, the batch facts).
MACHINE_KEYS = {"wall_time_s", "profile_s", "peak_rss_mb", "scheme", "batch"}

MIXED = """
name = "mixed"
base = "{base}"
set = ["time.end_time = 0.01"]
[grid]
"loading.omega" = [20.0, 50.0]
[[points]]
"loading.f" = 0.7
"initial.amplitude" = 0.1
[[points]]
"loading.f" = 0.5
"initial.amplitude" = 0.3
[[points]]
"loading.f" = 0.0
"initial.amplitude" = 0.3
[[points]]
"loading.f" = 0.7
"initial.amplitude" = 1e200
[[points]]
"loading.f" = 0.6
"initial.amplitude" = 0.2
"output.sample_interval" = 3e-4
"""


#: One scene that reaches a stick-slip wave in 0.03 s (the writer test).
WAVE = """
name = "wave"
base = "{base}"
set = ["time.end_time = 0.03", "output.sample_interval = 1e-4"]
[[points]]
"loading.f" = 0.7
"initial.amplitude" = 0.3
"""


def _spec(tmp_path):
    from pathlib import Path

    from stickslip.studies.sweep.spec import load_sweep

    path = tmp_path / "mixed.toml"
    path.write_text(MIXED.format(base=Path("scenes/smoke.toml").resolve()))
    return load_sweep(path)


def _strip(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k not in MACHINE_KEYS | {"energy"}}


def _same_energies(a: dict | None, b: dict | None) -> None:
    """The energy balance of a scene alone and in a batch: bitwise (one recorder,
    ``BatchRecorder``: the kinetic and strain energies are the kernel's sums in row order
    either way)."""
    assert a == b


@pytest.fixture(scope="module")
def two_sweeps(tmp_path_factory):
    """The mixed sweep (10 scenes: two Omega x (f = 0.7, 0.5, 0 frictionless, a start at
    1e200 x d that blows up at the first energy check, and f = 0.6 sampled every 4th step
    (3e-4 s), so that the batch's unsampled steps skip storing v, a, K u)) run alone
    (--batch off) and in batches of 3 (3 + 3 + 2 scenes, and the 2 scenes of the other
    sample interval: the batch size must not matter)."""
    from stickslip.studies.sweep.schedule import run_sweep

    tmp = tmp_path_factory.mktemp("ens")
    spec = _spec(tmp)
    out = {}
    with open(os.devnull, "w") as quiet:
        for batch in ("off", "3"):
            rc = run_sweep(spec, tmp / batch, comm=SELF, batch=batch, stream=quiet,
                           progress="lines")
            assert rc == 0
            out[batch] = tmp / batch
    return spec, out


def test_every_summary_equals_the_single_scene_run(two_sweeps):
    """Bitwise: the batched kernel sums in the single-scene kernel's order and one recorder
    takes both, so the summaries (regime, mode, celerity, fractions, amplitude, energies,
    works, steps, status, message) and the recorded samples and probes are the same numbers,
    not only close ones."""
    spec, out = two_sweeps
    statuses = {}
    for task in spec.tasks:
        single = json.loads((out["off"] / "runs" / task.id / "summary.json").read_text())
        batched = json.loads((out["3"] / "runs" / task.id / "summary.json").read_text())
        assert batched["batch"]["size"] in (2, 3)
        assert _strip(batched) == _strip(single), task.id
        _same_energies(single.get("energy"), batched.get("energy"))
        statuses[task.id] = batched["status"]
        a = np.load(out["off"] / "runs" / task.id / "samples.npz")
        b = np.load(out["3"] / "runs" / task.id / "samples.npz")
        assert sorted(a.files) == sorted(b.files)
        for key in a.files:
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{task.id}: {key}")
        fa = np.load(out["off"] / "runs" / task.id / "final_field.npz")
        fb = np.load(out["3"] / "runs" / task.id / "final_field.npz")
        np.testing.assert_array_equal(fa["u"], fb["u"])
    assert sorted(statuses.values()).count("diverged") == 2
    assert sorted(statuses.values()).count("completed") == 8


def _run_files(run_dir) -> tuple[list[str], set[str]]:
    """The file names of a run directory (its live lock aside) and its summary's keys
    (without ``batch``, which says how a member ran)."""
    names = sorted(p.name for p in run_dir.iterdir() if p.name != ".stickslip.lock")
    keys = set(json.loads((run_dir / "summary.json").read_text())) - {"batch"}
    return names, keys


def test_a_batch_member_directory_is_a_single_runs_directory(two_sweeps, tmp_path):
    """One writer (``studies.rundir.writer``): the same scene alone and as a member of a
    batch (of 3, of 1) leaves the same files and the same summary keys (the sampling check's
    included: a scene that reaches a wave in 0.03 s, sampled every 1e-4 s), with the same
    numbers, bitwise."""
    from pathlib import Path

    from stickslip.studies.rundir import run_scene
    from stickslip.studies.sweep.batch import run_batch
    from stickslip.studies.sweep.spec import load_sweep, scene_for

    spec, out = two_sweeps
    for task in spec.tasks:
        single = out["off"] / "runs" / task.id
        assert _run_files(out["3"] / "runs" / task.id) == _run_files(single), task.id
    (tmp_path / "wave.toml").write_text(WAVE.format(base=Path("scenes/smoke.toml").resolve()))
    spec = load_sweep(tmp_path / "wave.toml")
    task = spec.tasks[0]
    for sub in ("runs", "logs"):
        (tmp_path / sub).mkdir()
    alone, member = tmp_path / "alone", tmp_path / "runs" / task.id
    with open(os.devnull, "w") as quiet:
        run_scene(scene_for(spec, task), alone, comm=SELF, stream=quiet)
        assert run_batch(spec, [task], tmp_path, 0, stream=quiet) == ["completed"]
    assert _run_files(member) == _run_files(alone)
    s_alone, s_member = (json.loads((d / "summary.json").read_text()) for d in (alone, member))
    assert "nyquist_hz" in s_member and s_member["batch"] == {"size": 1, "backend": "cpu"}
    assert _strip(s_member) == _strip(s_alone)
    _same_energies(s_alone.get("energy"), s_member.get("energy"))
    for name in ("samples.npz", "final_field.npz"):
        a, b = np.load(alone / name), np.load(member / name)
        if name == "samples.npz":
            assert sorted(a.files) == sorted(b.files)
        else:  # a member's final field is the displacement on the mesh only: the last
            # level's stress and contact tractions are not gathered from a batch's columns
            assert set(b.files) == {"points", "cells", "cell_types", "u", "time"}
        for key in b.files:
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{name}: {key}")


def test_diverged_scene_is_masked_and_recorded_the_others_go_on(two_sweeps):
    spec, out = two_sweeps
    table = json.loads((out["3"] / "sweep.json").read_text())
    rows = {r["id"]: r for r in table["rows"]}
    for task in spec.tasks:
        row = rows[task.id]
        if task.params["initial.amplitude"] > 1e100:
            assert row["status"] == "diverged" and row["regime"] == "diverged"
            assert "non-finite energy" in row["message"]
            assert row["steps"] < 10  # stopped at the first energy check, as alone
        else:
            assert row["status"] == "completed"
            assert row["steps"] == rows[spec.tasks[0].id]["steps"] > 100  # 0.01 s, 130 steps
    log = (out["3"] / "logs" / f"{spec.tasks[0].id}.log").read_text()
    assert "batch of 3" in log and "== end completed" in log
    assert not list(out["3"].glob(".batch-*")), "the batch's sample spool must be removed"


def test_resume_runs_nothing_that_is_final(two_sweeps):
    from stickslip.studies.sweep.schedule import run_sweep

    spec, out = two_sweeps
    before = {p: p.stat().st_mtime for p in (out["3"] / "runs").glob("*/summary.json")}
    with open(os.devnull, "w") as quiet:
        assert run_sweep(spec, out["3"], comm=SELF, batch="3", stream=quiet) == 0
    after = {p: p.stat().st_mtime for p in (out["3"] / "runs").glob("*/summary.json")}
    assert before == after


def _batch(B_scenes, kernel="numba", common=()):
    from stickslip.solver.ensemble import BatchedExplicit, BatchedProblem
    from stickslip.solver.fused import friction_bound
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene

    sims = [Simulation(load_scene("scenes/smoke.toml", ["output.progress=false", *common,
                                                         *o]), SELF)
            for o in B_scenes]
    s0 = sims[0]
    bp = BatchedProblem.from_problem(s0.problem, s0.dt, s0.scene.time.beta2)
    integ = BatchedExplicit(
        bp, d=[s.scene.geometry.d for s in sims],
        slide=[s.scene.geometry.R * s.scene.loading.omega * s.dt for s in sims],
        f=[s.scene.loading.f for s in sims], kernel=kernel, tau=s0.scene.damping.tau,
        bound=friction_bound(s0.columns.projection.law))
    u0 = np.stack([s.integrator.u for s in sims], axis=1)
    integ.set_state(u0, np.zeros_like(u0))
    return integ, sims


VARIANTS = [(), ("loading.omega=20.0",), ("loading.f=0.0",), ("geometry.delta=0.001",
                                                                 "initial.amplitude=0.4")]


def test_batched_kernel_equals_the_single_scene_kernel_bitwise_for_any_batch_size():
    """Each column of a 4-scene batch, and a batch of one, give the bits of the fused
    single-scene run (time.kernel = numba): displacement and contact statuses, 250 steps."""
    integ, sims = _batch(VARIANTS)
    alone, _ = _batch(VARIANTS[2:3])
    for _ in range(250):
        integ.step()
        alone.step()
        for s in sims:
            s.integrator.step()
    for b, s in enumerate(sims):
        np.testing.assert_array_equal(integ.u[:, b], s.integrator.u)
        np.testing.assert_array_equal(integ.status[:, b], s.columns.projection.out.status)
        np.testing.assert_array_equal(integ.work[:, b], s.integrator.work)
    np.testing.assert_array_equal(alone.u[:, 0], integ.u[:, 2])


def test_register_passes_and_single_columns_give_the_single_scene_bits():
    """A 7-scene batch runs one 4-scene register pass (``half_product4``, SLP-vectorised),
    one 2-scene pass (``half_product2``) and a single column (``pair_product_col``) per
    node, over node blocks whose last one
    is partial: every column is the fused single-scene run's bits (u, v~, statuses, works),
    lean steps (diag = False) included. Exact equality: same operations in the same order
    (docs/performance.md, 'Batches')."""
    extra = [("loading.omega=35.0",), ("geometry.delta=0.0008",), ("loading.f=0.2",)]
    integ, sims = _batch(VARIANTS + extra)
    from stickslip.solver.fused import _kernels

    assert integ.B == 7 and (integ.n // 2) % _kernels().NODE_BLOCK != 0
    for n in range(120):
        integ.step(diag=n % 5 == 0)
        for s in sims:
            s.integrator.step()
    for b, s in enumerate(sims):
        np.testing.assert_array_equal(integ.u[:, b], s.integrator.u)
        np.testing.assert_array_equal(integ.v_pred[:, b], s.integrator.v_pred)
        np.testing.assert_array_equal(integ.status[:, b], s.columns.projection.out.status)
        np.testing.assert_array_equal(integ.work[:, b], s.integrator.work)


def test_long_batches_run_the_term_outer_kernel_with_the_same_bits():
    """Long batches run ``batched_step_long`` (B-long vector loops) instead of the register
    passes: from B = LONG_B on, or SMALL_K_LONG_B when K fits the L2 cache (the smoke
    mesh's does: B = 48 here). That batch, the 4 variants 12 times over, gives column by
    column the 4-scene batch's bits (itself the single-scene runs', tests above), lean steps
    included."""
    from stickslip.solver.ensemble import BatchedExplicit
    from stickslip.solver.fused import _kernels

    kern = _kernels()
    assert kern.batched_kernel_name(kern.LONG_B - 1, 1 << 30) == "batched_step"
    assert kern.batched_kernel_name(kern.LONG_B, 1 << 30) == "batched_step_long"
    assert kern.batched_kernel_name(kern.SMALL_K_LONG_B - 1, 1000) == "batched_step"
    assert kern.batched_kernel_name(kern.SMALL_K_LONG_B, 1000) == "batched_step_long"
    small, _ = _batch(VARIANTS)
    reps = kern.SMALL_K_LONG_B // 4
    big = BatchedExplicit(small.bp, d=np.tile(small.d, reps), slide=np.tile(small.slide, reps),
                          f=np.tile(small.f, reps))
    big.set_state(np.tile(small.u, reps), np.zeros((small.n, 4 * reps)))
    assert big.columns.name == "batched_step_long" and small.columns.name == "batched_step"
    for n in range(120):
        big.step(diag=n % 5 == 0)
        small.step(diag=n % 5 == 0)
    for b in range(4 * reps):
        np.testing.assert_array_equal(big.u[:, b], small.u[:, b % 4])
        np.testing.assert_array_equal(big.v_pred[:, b], small.v_pred[:, b % 4])
        np.testing.assert_array_equal(big.status[:, b], small.status[:, b % 4])
        np.testing.assert_array_equal(big.work[:, b], small.work[:, b % 4])


def test_lean_steps_keep_the_state_bitwise_and_store_outputs_when_asked():
    """Steps with ``diag = False`` (not sampled) store v_n, a_n, K u_n only at the
    ``keep_nodes`` (probes) but leave the state untouched: sampled every 3rd step, 250
    steps, each column's u, v~, statuses and works are the single-scene run's bits at every
    step, v_n, a_n, K u_n at every sampled step, and v_n at the kept nodes at every step."""
    integ, sims = _batch(VARIANTS)
    kept = np.array([int(integ.cx[0]) // 2, 1])  # a contact node and an interior node
    integ.keep_nodes(kept)
    rows = np.concatenate([2 * kept, 2 * kept + 1])
    for n in range(250):
        diag = n % 3 == 0
        integ.step(diag=diag)
        for b, s in enumerate(sims):
            s.integrator.step()
            it = s.integrator
            np.testing.assert_array_equal(integ.u[:, b], it.u)
            np.testing.assert_array_equal(integ.v_pred[:, b], it.v_pred)
            np.testing.assert_array_equal(integ.status[:, b], s.columns.projection.out.status)
            np.testing.assert_array_equal(integ.work[:, b], it.work)
            np.testing.assert_array_equal(integ.v[rows, b], it.v[rows])
            if diag:
                np.testing.assert_array_equal(integ.v[:, b], it.v)
                np.testing.assert_array_equal(integ.a[:, b], it.a)
                np.testing.assert_array_equal(integ.ku[:, b], it.ku)
        if not diag:  # the lean step did run: v_n elsewhere is the last sampled step's
            assert not np.array_equal(integ.v[:, 0], sims[0].integrator.v)


def test_memory_record_and_disk_spool_hold_the_same_samples(tmp_path):
    """The batch's record kept whole in memory (``spool_dir = None``, what a sweep uses when
    it fits) and spooled to disk in chunks give every scene the same samples and probes,
    bit for bit: both observe the same steps, 4 scenes, 70 steps (several chunks and a
    partial one), sampled every 3rd step."""
    from stickslip.solver.ensemble_observers import BatchRecorder

    integ, _ = _batch(VARIANTS)
    bp = integ.bp
    kept = np.array([int(integ.cx[0]) // 2])
    integ.keep_nodes(kept)
    kw = dict(mass=bp.mass, perm=np.argsort(bp.theta), theta=bp.theta,
              ds=np.zeros(bp.cx.size), every=3, max_samples=30, max_steps=80,
              probe_nodes=kept, probe_pc=np.ones(1), probe_deg=np.zeros(1), chunk=4)
    memory = BatchRecorder(integ, **kw)
    disk = BatchRecorder(integ, spool_dir=tmp_path, **kw)
    assert disk.fields.path == tmp_path / "fields.f64" and not hasattr(memory.fields, "path")
    for _ in range(70):
        integ.step(diag=memory.due(integ.step_count))
        for rec in (memory, disk):
            rec.record_probes()
            if rec.due(integ.step_count - 1):
                rec.sample()
    for rec in (memory, disk):
        rec.close()
    assert memory.n == disk.n == 24 and memory.n_probe == disk.n_probe == 70
    for b in range(integ.B):
        for got, want in ((memory.arrays(b), disk.arrays(b)),
                          (memory.probe_arrays(b), disk.probe_arrays(b))):
            assert sorted(got) == sorted(want)
            for key in got:
                np.testing.assert_array_equal(got[key], want[key], err_msg=key)


def test_array_namespace_reference_equals_the_kernel_to_round_off():
    """The xp (numpy) reference step against the numba kernel: 250 steps, scipy's K @ U sums
    rows in CSR order, not in even/odd pairs, so 1e-12 of max|u| (round-off, amplified by the
    flutter of steady sliding); statuses equal; work to 1e-9 relative."""
    ref, _ = _batch(VARIANTS, kernel="xp")
    new, _ = _batch(VARIANTS)
    for _ in range(250):
        ref.step()
        new.step()
    scale = np.max(np.abs(ref.u))
    assert np.max(np.abs(ref.u - new.u)) < 1e-12 * scale
    np.testing.assert_array_equal(ref.status, new.status)
    assert np.allclose(ref.work_totals(), new.work_totals(), rtol=1e-9, atol=1e-30)


def test_grouping_and_batch_option(tmp_path):
    from stickslip.studies.batching import batch_key
    from stickslip.studies.sweep.batch import auto_batch_size, bytes_per_scene, parse_batch
    from stickslip.studies.sweep.spec import scene_for

    spec = _spec(tmp_path)
    scenes = [scene_for(spec, t) for t in spec.tasks]
    # Omega, f, start differ: one group; the output's sample interval differs: another
    assert len({batch_key(s) for s in scenes}) == 2
    base = scenes[0]
    assert batch_key(base.with_overrides("mesh.n_inner=48")) != batch_key(base)
    assert batch_key(base.with_overrides("time.beta1=0.25", "time.beta2=0.5")) is None
    assert batch_key(base.with_overrides("output.fields=true")) is None
    assert batch_key(base.with_overrides('time.kernel="numpy"')) is None
    assert parse_batch("auto") == "auto" and parse_batch("16") == "16"
    for bad in ("0", "x", "-3"):
        with pytest.raises(ValueError, match="--batch"):
            parse_batch(bad)
    assert auto_batch_size(base, 64, 2) == 32  # split evenly over the ranks
    # memory: a 1024-scene N = 132 batch (state, contact arrays, observer chunks) < 4 GB
    n132 = base.with_overrides("mesh.n_inner=132", "mesh.n_radial=0")
    assert 1024 * bytes_per_scene(n132) < 4e9


def test_sweep_file_batch_and_backend_keys(tmp_path):
    from stickslip.studies.sweep.spec import SweepError, load_sweep

    text = MIXED.format(base=__import__("pathlib").Path("scenes/smoke.toml").resolve())
    path = tmp_path / "s.toml"
    path.write_text('batch = "auto"\nbackend = "cpu"\n' + text)
    spec = load_sweep(path)
    assert (spec.batch, spec.backend) == ("auto", "cpu")
    path.write_text("batch = 16\n" + text)
    assert load_sweep(path).batch == "16"
    for bad in ('batch = "fast"', "batch = 0", 'backend = "tpu"'):
        path.write_text(bad + "\n" + text)
        with pytest.raises(SweepError, match="batch|backend"):
            load_sweep(path)


def test_slp_flag_is_set_for_the_first_call_only():
    """``slp_vectorize`` turns numba's SLP vectoriser on inside the block (the batch kernel's
    first call) and restores the process-wide default after it, also on an error."""
    from numba.core import config

    from stickslip.solver.fused import slp_vectorize

    before = config.SLP_VECTORIZE
    with slp_vectorize():
        assert config.SLP_VECTORIZE == 1
    assert config.SLP_VECTORIZE == before
    with pytest.raises(RuntimeError), slp_vectorize():
        raise RuntimeError("compile failed")
    assert config.SLP_VECTORIZE == before


#: Kelvin-Voigt damping shared by a batch (tau enters dt, so it is part of the batch key)
DAMPED = ("damping.retardation_time=2e-6",)


def test_damped_batch_equals_the_damped_single_scene_kernel_bitwise():
    """Kelvin-Voigt damping: each column of a damped 4-scene batch (register passes), of the
    same 4 scenes 12 times over (``batched_step_long``) and of the xp reference gives the
    damped fused single-scene run: u, v~, statuses and the four works (contact, cylinder,
    friction, the damping work's step sum) bitwise for the numba kernels, lean steps
    included (K w_n is summed in the single kernel's order; the damping sums run in row
    order per scene); the xp reference (scipy's K @ W, einsum) to 1e-12 of max|u| and 1e-9
    relative in the works, as undamped."""
    integ, sims = _batch(VARIANTS, common=DAMPED)
    ref, _ = _batch(VARIANTS, kernel="xp", common=DAMPED)
    from stickslip.solver.ensemble import BatchedExplicit

    reps = 12
    big = BatchedExplicit(integ.bp, d=np.tile(integ.d, reps),
                          slide=np.tile(integ.slide, reps), f=np.tile(integ.f, reps),
                          tau=integ.tau)
    big.set_state(np.tile(integ.u, reps), np.zeros((integ.n, 4 * reps)))
    assert integ.damped and integ.columns.name == "batched_step"
    assert big.columns.name == "batched_step_long"
    for n in range(120):
        for it in (integ, big):
            it.step(diag=n % 5 == 0)
        ref.step()
        for s in sims:
            s.integrator.step()
    for b, s in enumerate(sims):
        it = s.integrator
        assert it.damped and it.work[3] != 0.0
        for batch, col in ((integ, b), (big, b + 4 * (reps - 1))):
            np.testing.assert_array_equal(batch.u[:, col], it.u)
            np.testing.assert_array_equal(batch.v_pred[:, col], it.v_pred)
            np.testing.assert_array_equal(batch.status[:, col], s.columns.projection.out.status)
            np.testing.assert_array_equal(batch.work[:, col], it.work)
    assert np.max(np.abs(ref.u - integ.u)) < 1e-12 * np.max(np.abs(integ.u))
    np.testing.assert_array_equal(ref.status, integ.status)
    np.testing.assert_allclose(ref.work, integ.work, rtol=1e-9, atol=1e-30)


def test_regularised_batch_equals_the_single_scene_kernel_bitwise():
    """A Prakash-Clifton friction bound (with Kelvin-Voigt damping): each column of a
    4-scene batch, and of the 4 scenes 12 times over (``batched_step_long``), gives the fused
    single-scene run's u, v~, statuses, works and effective pressure bitwise, lean steps
    included (``project_regularised`` is shared by the kernels)."""
    pc = ('friction.regularization="prakash-clifton"', "friction.slip_length=2e-5",
          "friction.reference_velocity=1.0", *DAMPED)
    integ, sims = _batch(VARIANTS, common=pc)
    from stickslip.solver.ensemble import BatchedExplicit

    reps = 12
    big = BatchedExplicit(integ.bp, d=np.tile(integ.d, reps),
                          slide=np.tile(integ.slide, reps), f=np.tile(integ.f, reps),
                          tau=integ.tau, bound=(integ.reg, integ.rate_slip, integ.rate_base))
    big.set_state(np.tile(integ.u, reps), np.zeros((integ.n, 4 * reps)))
    assert integ.reg == 1 and big.columns.name == "batched_step_long"
    for n in range(120):
        for it in (integ, big):
            it.step(diag=n % 5 == 0)
        for s in sims:
            s.integrator.step()
    for b, s in enumerate(sims):
        it = s.integrator
        for batch, col in ((integ, b), (big, b + 4 * (reps - 1))):
            np.testing.assert_array_equal(batch.u[:, col], it.u)
            np.testing.assert_array_equal(batch.v_pred[:, col], it.v_pred)
            np.testing.assert_array_equal(batch.status[:, col], s.columns.projection.out.status)
            np.testing.assert_array_equal(batch.work[:, col], it.work)
            np.testing.assert_array_equal(batch.sigma[:, col], it.batch.sigma[:, 0])


@pytest.mark.parametrize("common", [(), "pc"], ids=["plain", "damped-prakash-clifton"])
def test_a_batch_of_one_runs_the_single_scene_kernel_with_the_batch_bits(common):
    """A batch of one steps with ``single_step`` on its column (faster than the batched
    loops at B = 1, ``batched_kernel_name``). It must keep the batch's state and outputs
    bit for bit, so that a census leg of one start and a leg of several give the same
    numbers: against ``batched_step`` forced at B = 1, 120 steps, lean and sampled, with a
    kick half way: u, v~, w = u + tau v~ (damped), statuses, the four works, the
    Prakash-Clifton state, and on sampled steps v_n, a_n, K u_n and the energy sums."""
    from stickslip.solver.fused import kernel

    if common == "pc":
        common = ('friction.regularization="prakash-clifton"', "friction.slip_length=2e-5",
                  "friction.reference_velocity=1.0", *DAMPED)
    one, _ = _batch(VARIANTS[3:4], common=common)
    forced, _ = _batch(VARIANTS[3:4], common=common)
    assert one.columns.name == "single_step" and one.columns.single
    forced.columns.name, forced.columns.fn = "batched_step", kernel("batched_step")
    forced.columns.single = False
    rng = np.random.default_rng(0)
    du, dv = 1e-6 * rng.standard_normal((2, one.n))
    du[np.abs(one.u[:, 0]) == 0.0] = dv[np.abs(one.u[:, 0]) == 0.0] = 0.0
    for n in range(120):
        diag = n % 4 == 0
        if n == 60:
            for it in (one, forced):
                it.kick(0, du, dv)
        for it in (one, forced):
            it.step(diag=diag)
        names = ["u", "v_pred", "status", "work", "sigma", "ut_last"]
        names += ["u_tau"] if one.damped else []
        names += ["v", "a", "ku", "energy"] if diag else []
        for name in names:
            np.testing.assert_array_equal(getattr(one, name), getattr(forced, name), name)
    assert one.damped == (common != ())


DAMPED_SWEEP = """
name = "damped"
base = "{base}"
set = ["time.end_time = 0.01", "damping.retardation_time = 2e-6"]
[grid]
"loading.omega" = [20.0, 50.0]
"loading.f" = [0.7, 0.0]
"""


def test_damped_sweep_batched_equals_the_sweep_without_batches(tmp_path):
    """A damped sweep (4 scenes, tau = 2 us) with --batch off (the fused single-scene
    kernel) and --batch 3: summaries, samples and final fields as the undamped sweep above
    (bitwise, the energies and the Kelvin-Voigt work W_d included), and the batched scenes
    do run in a batch."""
    from pathlib import Path

    from stickslip.studies.sweep.schedule import run_sweep
    from stickslip.studies.sweep.spec import load_sweep

    path = tmp_path / "damped.toml"
    path.write_text(DAMPED_SWEEP.format(base=Path("scenes/smoke.toml").resolve()))
    spec = load_sweep(path)
    with open(os.devnull, "w") as quiet:
        for batch in ("off", "3"):
            assert run_sweep(spec, tmp_path / batch, comm=SELF, batch=batch, stream=quiet,
                             progress="lines") == 0
    sizes = []
    for task in spec.tasks:
        runs = [tmp_path / b / "runs" / task.id for b in ("off", "3")]
        single, batched = (json.loads((r / "summary.json").read_text()) for r in runs)
        assert single["scheme"]["kernel"] == "numba"
        assert single["scheme"]["damping_tau_s"] == batched["scheme"]["damping_tau_s"] > 0
        sizes.append(batched.get("batch", {}).get("size", 1))
        assert _strip(batched) == _strip(single), task.id
        _same_energies(single.get("energy"), batched.get("energy"))
        assert single["energy"]["damping_dissipation_J_per_m"] > 0.0
        a, b = (np.load(r / "samples.npz") for r in runs)
        for key in a.files:
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{task.id}: {key}")
        fa, fb = (np.load(r / "final_field.npz") for r in runs)
        np.testing.assert_array_equal(fa["u"], fb["u"])
    assert 3 in sizes


def test_damped_cuda_kernels_equal_the_numba_kernel_on_the_cpu(monkeypatch):
    """The damped CUDA path (``kelvin_voigt_argument``, ``fused_step_damped``, and
    ``stiffness_product`` for the samples' K u_n), with CuPy replaced by its CPU emulation
    (benchmarks/gpu_emulate.py: the source compiled as C++ without fused multiply-adds, as
    nvcc --fmad=false, run thread by thread): over 120 steps the state (u, v~, statuses) and
    K u_n are the damped numba batch's bits; the contact works and W_d to 1e-9 relative
    (per-node partial sums added in another order, einsum dot products)."""
    import shutil
    import sys

    from benchmarks import gpu_emulate

    if shutil.which("g++") is None and shutil.which("c++") is None:
        pytest.skip("no C++ compiler")
    emulated = gpu_emulate.cupy_module()
    monkeypatch.setitem(sys.modules, "cupy", emulated)
    from stickslip.solver.ensemble import BatchedExplicit

    ref, _ = _batch(VARIANTS[:3], common=DAMPED)
    cuda = BatchedExplicit(ref.bp, ref.d, ref.slide, ref.f, xp=emulated, kernel="cuda",
                           tau=ref.tau)
    cuda.set_state(ref.u.copy(), np.zeros_like(ref.u))
    for n in range(120):
        ref.step(diag=n % 5 == 0)
        cuda.step(diag=n % 5 == 0)
    np.testing.assert_array_equal(cuda.u, ref.u)
    np.testing.assert_array_equal(cuda.v_pred, ref.v_pred)
    np.testing.assert_array_equal(cuda.status, ref.status)
    np.testing.assert_allclose(cuda.work_totals(), ref.work_totals(), rtol=1e-9, atol=1e-30)
    for it in (ref, cuda):
        it.refresh_ku()
    np.testing.assert_array_equal(cuda.ku, ref.ku)
    np.testing.assert_allclose(cuda.damping_work_totals(), ref.damping_work_totals(),
                               rtol=1e-9, atol=0)


def test_group_size_above_the_ranks_is_said(tmp_path):
    """A group_size larger than the run's ranks runs each scene on the ranks there are, and
    the sweep's first lines say so (and how to get the group asked for)."""
    import io

    from stickslip.studies.sweep.schedule import _announce

    spec = _spec(tmp_path)
    out = io.StringIO()
    _announce(spec, tmp_path, [[t] for t in spec.tasks], 0, 2, 4, "cpu", out)
    assert "group_size 4 is more than the 2 rank(s) of this run" in out.getvalue()
    assert "mpirun -n 4" in out.getvalue()
    out = io.StringIO()
    _announce(spec, tmp_path, [[t] for t in spec.tasks], 0, 3, 2, "cpu", out)
    assert "3 ranks are not a multiple of group_size 2" in out.getvalue()


def test_checkpoint_layouts_of_the_kernels_convert_both_ways():
    """The CUDA kernel keeps the work sums per contact node (3, m) and the damping step sum
    per node; numba and numpy keep the 4 totals. A column's checkpoint converts between the
    layouts with its totals kept exactly (one value on the first node, zeros elsewhere)."""
    from stickslip.solver.ensemble import CudaColumns, NumbaColumns

    m, nodes = 5, 12
    rng = np.random.default_rng(0)
    totals = rng.normal(size=4)
    state = {"work": totals.copy(), "zprev": np.zeros((m, 2)), "u": np.zeros(2 * nodes)}
    cuda = CudaColumns.from_totals(dict(state), damped=True)
    assert cuda["work"].shape == (3, m) and cuda["dwork"].shape == (nodes,)
    back = NumbaColumns.from_totals(CudaColumns.totals(dict(cuda), damped=True), True)
    np.testing.assert_array_equal(back["work"], totals)
    assert "dwork" not in back
    undamped = CudaColumns.totals(CudaColumns.from_totals(dict(state), damped=False), False)
    np.testing.assert_array_equal(undamped["work"], [*totals[:3], 0.0])


def test_one_run_class_for_one_scene_and_a_batch():
    """B ≥ 1 is the only kind of run: ``Simulation(scene)`` (one scene on its ranks, B = 1)
    and ``Simulation.batch(scenes)`` are one class with one set of observers and a
    ``SceneRun`` per scene. A blow-up (a start of 1e200 d: non-finite energy at the first
    sample) masks its column and records it ``diverged`` alone or in a batch, at the same
    step, with the same message and no checkpoint; the batch's other scene goes on, and a
    run with no column left ends "diverged"."""
    from stickslip.solver.columns import SceneRun
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene
    from stickslip.solver.stepper import BatchStepper, Stepper

    good = load_scene("scenes/smoke.toml", ["output.progress=false", "time.end_time=0.004"])
    bad = good.with_overrides("initial.amplitude=1e200")
    alone, batch = Simulation(bad, SELF), Simulation.batch([good, bad])
    assert type(alone) is type(batch) is Simulation
    assert isinstance(alone.stepper, Stepper) and isinstance(batch.stepper, BatchStepper)
    names = [[type(obs).__name__ for obs in sim.observers] for sim in (alone, batch)]
    assert names[0] == names[1] == ["Sampling", "ProgressLine", "StopCheck"]
    assert alone.proceed() == "diverged"
    assert batch.proceed() == "end_time"
    lone, member = alone.runs[0], batch.runs[1]
    for run in (lone, member):
        assert isinstance(run, SceneRun)
        assert run.status == "diverged" and run.stop_reason == "" and run.state is None
        assert run.message.startswith("non-finite energy")
    assert lone.steps == member.steps and lone.message == member.message
    assert lone.recorder.n == member.recorder.n == 1
    assert batch.runs[0].status == "completed" and batch.runs[0].state is not None
    assert batch.runs[0].sim_time > 0.9 * 0.004
