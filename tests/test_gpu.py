"""GPU backend of the batched ensemble (solver/ensemble.py, CuPy).

The CUDA kernel is compiled with --fmad=false and sums K u in the CPU kernels' order, so its
state is bitwise the numba kernel's; the plain CuPy path (cuSPARSE SpMM) agrees to round-off.
Tests marked ``gpu`` skip without CuPy; the CUDA kernel's *source* is still checked on every
machine with a C++ compiler, compiled for the CPU and run thread by thread, and so is the GPU
path of the benchmark suite (benchmarks/gpu_suite.sh) with CuPy replaced by that emulation.
Without a GPU, ``stickslip sweep --backend gpu`` refuses in one line (exit 2).
Runs from a problem built here (dolfinx) or, without dolfinx, from a bundle of
benchmarks/gpu_bench.py's ``prepare`` (``STICKSLIP_GPU_BUNDLE=path/problem_n132``).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]

try:
    import cupy
except ImportError:  # the device tests skip; the CPU emulation of the kernel below runs
    cupy = None


#: Three scenes of one batch: two speeds, and no friction.
SCENES = ("loading.omega=50.0", "loading.omega=20.0", "loading.f=0.0")


def _bundle(directory: Path) -> Path:
    """A bundle (``solver.bundle``) of the three smoke scenes, made here (dolfinx), or the
    one named by ``STICKSLIP_GPU_BUNDLE`` (a GPU node without dolfinx)."""
    path = os.environ.get("STICKSLIP_GPU_BUNDLE")
    if path:
        return Path(path)
    pytest.importorskip("dolfinx")
    from stickslip.solver.bundle import prepare_bundle
    from stickslip.solver.scene import load_scene

    scenes = [load_scene("scenes/smoke.toml", ["output.progress=false", o]) for o in SCENES]
    prepare_bundle(directory, [(["omega50", "omega20", "f0"], scenes)])
    return directory


def _problem(directory: Path):
    """(BatchedProblem, u0 (n, 3), d, R Omega dt, f) of the bundle's scenes."""
    from benchmarks.gpu_bench import load
    from stickslip.solver.contact import ContactLaw

    scenes, layout, starts = load(_bundle(directory))
    laws = [ContactLaw.from_scene(sc, layout.problem.dt) for sc in scenes]
    return (layout.problem, starts.u0, *(np.array([getattr(law, k) for law in laws])
                                         for k in ("d", "slide", "f")))


@pytest.mark.gpu
@pytest.mark.skipif(cupy is None, reason="CuPy is not installed (optional GPU extra)")
@pytest.mark.parametrize("kernel", ["cuda", "xp"])
def test_gpu_batch_equals_the_cpu_kernel(kernel, tmp_path):
    """200 steps: cuda bitwise (same operations, same order, no fused multiply-add), xp to
    1e-12 of max|u| (cuSPARSE's sum order; round-off amplified by the flutter of steady
    sliding); statuses equal; contact work to 1e-9 relative (per-node partial sums on the GPU)."""
    from stickslip.solver.ensemble import BatchedExplicit

    bp, u0, d, slide, f = _problem(tmp_path / "bundle")
    cpu = BatchedExplicit(bp, d, slide, f, kernel="numba")
    gpu = BatchedExplicit(bp, d, slide, f, xp=cupy, kernel=kernel)
    for integ in (cpu, gpu):
        integ.set_state(u0, np.zeros_like(u0))
        for _ in range(200):
            integ.step()
    u = cupy.asnumpy(gpu.u)
    if kernel == "cuda":
        np.testing.assert_array_equal(u, cpu.u)
    else:
        assert np.max(np.abs(u - cpu.u)) < 1e-12 * np.max(np.abs(cpu.u))
    np.testing.assert_array_equal(cupy.asnumpy(gpu.status), cpu.status)
    assert np.allclose(gpu.work_totals(), cpu.work_totals(), rtol=1e-9, atol=1e-30)


# ------------------------------------------------------------------------------------------
# The CUDA kernel's logic without a GPU: its source compiled as C++ for the CPU and run
# thread by thread (benchmarks/gpu_emulate.py; threads of one step are independent: each
# writes only its own node).


def _emulated_kernel(tmp_path):
    from benchmarks.gpu_emulate import compile_kernel
    from stickslip.solver.ensemble import CUDA_SOURCE

    try:
        return compile_kernel(CUDA_SOURCE, "fused_step", tmp_path)
    except RuntimeError as err:  # no C++ compiler
        pytest.skip(str(err))


@pytest.mark.parametrize("diag", [True, False])
def test_cuda_kernel_source_equals_the_numba_kernel_on_the_cpu(tmp_path, diag):
    """The CUDA kernel (solver.ensemble.CUDA_SOURCE), emulated on the CPU, gives the numba
    kernel's state bitwise over 120 steps; with ``diag = False`` (v, a, K u written only at
    the probe nodes) the state u, v~ and the contact statuses are unchanged."""
    import ctypes

    from stickslip.solver.ensemble import BatchedExplicit

    pytest.importorskip("numba")
    emulate = _emulated_kernel(tmp_path)
    bp, u0, d, slide, f = _problem(tmp_path / "bundle")
    ref = BatchedExplicit(bp, d, slide, f, kernel="numba")
    emu = BatchedExplicit(bp, d, slide, f, kernel="numba")  # arrays only; stepped below
    for integ in (ref, emu):
        integ.set_state(u0, np.zeros_like(u0))
    nodes, B, m = bp.n // 2, u0.shape[1], bp.cx.size
    cslot = emu.cslot.astype(np.int32)
    keep = np.zeros(nodes, dtype=np.int8)
    keep[int(bp.cx[0]) // 2] = 1
    work = np.zeros((3, m, B))
    P = ctypes.c_void_p

    def ptr(a):
        return P(a.ctypes.data)

    threads = 64
    blocks = (nodes * B + threads - 1) // threads
    dt, b2, kappa = emu.dt, emu.beta2, emu.kappa
    for _ in range(120):
        ref.step()
        cur, nxt = emu.cur, 1 - emu.cur
        emulate(ctypes.c_int(blocks), ctypes.c_int(threads), *map(ptr, (
            emu.indptr, emu.indices, emu.data, emu.u_levels[cur], emu.u_levels[nxt], emu.v,
            emu.v_pred,
            emu.a, emu.ku, emu.nim, cslot, emu.ph_re, emu.ph_im, emu.pc_re, emu.pc_im,
            emu.cmass, emu.cinv, emu.d, emu.slide, emu.f, emu.r_r, emu.r_t, emu.r_x, emu.r_y,
            emu.status, emu.zprev, work)),
            ctypes.c_double(b2 * dt), ctypes.c_double(0.5 * dt),
            ctypes.c_double((0.5 - b2) * dt), ctypes.c_int(int(b2 == 0.5)),
            ctypes.c_double(dt), ctypes.c_double(kappa), ctypes.c_double(1.0 / kappa),
            ctypes.c_int(nodes), ctypes.c_int(B), ctypes.c_int(m), ctypes.c_int(int(diag)),
            ptr(keep))
        emu.cur = nxt
    np.testing.assert_array_equal(emu.u, ref.u)
    np.testing.assert_array_equal(emu.v_pred, ref.v_pred)
    np.testing.assert_array_equal(emu.status, ref.status)
    np.testing.assert_array_equal(emu.r_t, ref.r_t)
    if diag:
        np.testing.assert_array_equal(emu.v, ref.v)
        np.testing.assert_array_equal(emu.ku, ref.ku)
    else:
        k = int(bp.cx[0])
        np.testing.assert_array_equal(emu.v[k:k + 2], ref.v[k:k + 2])
    assert np.allclose(work.sum(axis=1), ref.work_totals(), rtol=1e-9, atol=1e-30)


# ------------------------------------------------------------------------------------------
# The benchmark suite's plumbing (benchmarks/gpu_suite.sh, gpu_bench.py) on the CPU: the GPU
# stages with CuPy replaced by its CPU emulation, at a few scenes and steps.


@pytest.fixture
def problem_bundle(tmp_path):
    """The bundle of ``_bundle``."""
    pytest.importorskip("numba")
    return _bundle(tmp_path / "bundle")


def _emulate_cupy(monkeypatch) -> None:
    """``import cupy`` gives the CPU emulation for this test only (restored afterwards)."""
    if shutil.which("g++") is None and shutil.which("c++") is None:
        pytest.skip("no C++ compiler")
    from benchmarks import gpu_emulate

    monkeypatch.setitem(sys.modules, "cupy", gpu_emulate.cupy_module())


@pytest.fixture
def suite_bundle(problem_bundle, monkeypatch):
    """``problem_bundle`` and an emulated CuPy for this test only."""
    _emulate_cupy(monkeypatch)
    return problem_bundle


def test_suite_check_stage_gpu_path_with_observers_equals_the_cpu_path(suite_bundle, tmp_path):
    """The stage that checks the GPU on its node, run here on the emulated CUDA kernel: the
    whole observed path (lean and sampled steps, probes, samples, energies) over 24 steps,
    B = 5 scenes against the numba path on the first 3. State and statuses bitwise (same
    operations in the same order); recorded fields and probes bitwise (the same numpy
    products on both); energies and works to 1e-12: the CUDA path sums the energies with
    ``einsum`` and the works per node, the numba kernel in row order (round-off, ~n eps)."""
    from benchmarks.gpu_bench import load, main

    dt = load(suite_bundle)[1].problem.dt
    out = tmp_path / "stages.jsonl"
    main(["check", "--bundle", str(suite_bundle), "--emulate", "--B", "5", "--scenes", "3",
          "--steps", "24", "--sample-interval", str(3 * dt), "--json", str(out)])
    r = json.loads(out.read_text())
    assert r["emulated"] and r["scenes_compared"] == 3
    assert all(r["same_bits"].values()), r["same_bits"]
    diff = r["max_rel_diff"]
    assert diff["fields"] == 0.0 and diff["probes"] == 0.0
    assert diff["energies"] < 1e-12 and diff["work"] < 1e-12


FIELDS = ("u_r", "u_theta", "v_r", "v_theta", "r_r", "r_theta")


class _Kick:
    """Step hook: 1e4 m/s added to scene ``planted``'s velocity predictor after step ``at``."""

    def __init__(self, planted: int, at: int) -> None:
        self.planted, self.at = planted, at

    def after_step(self, stepper) -> None:
        if stepper.step_count == self.at:
            stepper.v_pred[:, self.planted] += 1e4


def _observed_run(data, target: str, spool_parent, planted: int, at: int):
    """68 steps of the batch of 4 scenes (the bundle's starts, tiled), sampled every 3rd
    step (several chunks of samples and a partial last one) through ``run_loop``; after
    step ``at``, 1e4 m/s is added to scene ``planted``'s velocity. Returns the batch,
    {scene: guard message} and {scene: samples taken when masked}."""
    from benchmarks.gpu_bench import batch_of

    batch, _ = batch_of(data, 4, target, 3, 68, spool_parent)
    batch.stepper.attach(_Kick(planted, at))
    batch.proceed()
    runs = batch.runs
    messages = {b: r.message for b, r in enumerate(runs) if r.status == "diverged"}
    masked_at = {b: r.recorder.n for b, r in enumerate(runs) if r.status == "diverged"}
    return batch, messages, masked_at


@pytest.mark.parametrize("device", ["emulated", pytest.param("cupy", marks=[
    pytest.mark.gpu, pytest.mark.skipif(cupy is None, reason="CuPy is not installed")])])
def test_async_gpu_spool_records_the_cpu_samples_and_masks_a_planted_blowup(
        problem_bundle, tmp_path, monkeypatch, device):
    """The GPU path's observers (device chunks copied on a stream of their own to pinned host
    memory, a writer thread, the energy guard on the host chunks, spooled to a file),
    emulated (the copies run late, as on a device) or on a GPU, against the CPU numba path,
    both the product's batch in ``run_loop``: a scene kicked to 1e4 m/s is reported with the
    same message (same sample time) and masked; every other scene ends bitwise equal and
    records the same statuses and probes bitwise, the same fields (bitwise emulated; 1e-12
    on a GPU, whose complex product may fuse multiply-adds) and energies to 1e-12 (the CUDA
    path sums them with ``einsum``, numba in row order: round-off); the kicked scene's
    record is the CPU's up to its blow-up (the GPU masks it later: its guard runs per
    chunk)."""
    from benchmarks.gpu_bench import load

    if device == "emulated":
        _emulate_cupy(monkeypatch)
    data = load(problem_bundle)
    planted = 1
    gpu = _observed_run(data, "gpu", tmp_path, planted, at=30)
    cpu = _observed_run(data, "cpu", tmp_path, planted, at=30)
    (gb, gmsg, gat), (cb, cmsg, cat) = gpu, cpu
    g, grec, c, crec = gb.stepper, gb.columns.recorder, cb.stepper, cb.columns.recorder
    assert set(cmsg) == {planted} and gmsg == cmsg, (gmsg, cmsg)
    assert gat[planted] >= cat[planted] and not g.active[planted]
    assert gb.columns.spool_dir is not None and crec.n == 23  # the GPU's record went to a file
    tol = device != "emulated"
    for b in range(4):
        n = cat[planted] if b == planted else grec.n
        ga, ca = grec.arrays(b, n), crec.arrays(b, n)
        for key in ("t", "status") + (() if tol else FIELDS):
            np.testing.assert_array_equal(ga[key], ca[key], err_msg=f"scene {b}: {key}")
        for key in ("energies",) + (FIELDS if tol else ()):
            scale = np.max(np.abs(ca[key]))
            assert np.max(np.abs(ga[key] - ca[key])) <= 1e-12 * scale, (b, key)
        if b != planted:
            np.testing.assert_array_equal(grec.probe_arrays(b)["probe_data"],
                                          crec.probe_arrays(b)["probe_data"])
            np.testing.assert_array_equal(sys.modules["cupy"].asnumpy(g.u[:, b]), c.u[:, b])
    assert grec.n == crec.n == 23 and grec.n_probe == crec.n_probe == 68


def test_suite_rate_stages_and_report_give_the_ratio_table(suite_bundle, tmp_path):
    """Two rate stages (emulated GPU and CPU numba, the observed path) and the report: the
    JSON holds both with the GPU's ratio to the CPU's rate, the table one row each."""
    from benchmarks.gpu_bench import load, main

    every = str(3 * load(suite_bundle)[1].problem.dt)
    out = tmp_path / "stages.jsonl"
    for target in ("gpu", "cpu"):
        main(["rate", "--bundle", str(suite_bundle), "--sample-interval", every, "--target",
              target, "--emulate", "--paths", "observed", "--B", "4", "--steps", "6",
              "--block", "3", "--json", str(out)])
    main(["report", str(out), "--out", str(tmp_path / "report")])
    summary = json.loads((tmp_path / "report" / "gpu_suite.json").read_text())
    gpu, cpu = sorted(summary["rates"], key=lambda r: r["target"] != "gpu")
    assert gpu["emulated"] and gpu["steps"] == cpu["steps"] == 6 and gpu["finite"]
    assert gpu["ratio_to_best_cpu_core"] == pytest.approx(
        gpu["scene_steps_per_s"] / cpu["scene_steps_per_s"], rel=1e-12)
    assert cpu["ratio_to_best_cpu_core"] == 1.0
    table = (tmp_path / "report" / "gpu_suite.md").read_text()
    assert "| gpu (emulated) | observed | 4 | 3 | 6 |" in table


def test_suite_census_stage_classifies_every_scene_and_agrees_with_the_cpu(suite_bundle,
                                                                          tmp_path):
    """The census stage, emulated: 6 scenes (the 3 starts twice) for 60 steps with the
    observers, each classified; the shares sum to 1 and the first 3 scenes run again on
    the CPU end bitwise equal with the same members."""
    from benchmarks.gpu_bench import load, main

    bp = load(suite_bundle)[1].problem
    out = tmp_path / "stages.jsonl"
    main(["census", "--bundle", str(suite_bundle), "--emulate", "--B", "6", "--end-time",
          str(60 * bp.dt), "--sample-interval", str(3 * bp.dt), "--scenes", "3",
          "--workers", "1", "--json", str(out)])
    r = json.loads(out.read_text())
    assert r["steps"] == 60 and r["scene_steps"] == 360
    assert sum(r["gpu"]["shares"].values()) == pytest.approx(1.0, abs=1e-12)
    assert r["subsample_same_bits"] and r["subsample_same_members"], r


def test_suite_script_plan_has_the_issue_sizes_and_refuses_bad_use():
    """``gpu_suite.sh --dry-run`` lists the GPU node's stages (N = 132 at B = 4096, N = 528
    at B = 1024, the kernel alone and with the observers, each against one CPU core, and the
    census of 4096 starts for 0.3 s); an unknown argument is one line and exit 2."""
    script = REPO / "benchmarks" / "gpu_suite.sh"
    plan = subprocess.run(["bash", str(script), "--dry-run"], capture_output=True, text=True)
    assert plan.returncode == 0, plan.stderr
    text = plan.stdout
    for stage in ("gpu N=132 B=4096", "gpu N=528 B=1024", "cpu N=132 B=256",
                  "cpu N=528 B=16", "census N=132"):
        assert stage in text, stage
    assert "taskset -c 0" in text and "--B 4096 --end-time 0.3" in text
    bad = subprocess.run(["bash", str(script), "--frobnicate"], capture_output=True,
                         text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1


# ------------------------------------------------------------------------------------------
# Without a GPU, `--backend gpu` is one line and exit 2, before any scene runs.


class _NoDevice:
    """A CuPy that imports but finds no device (no driver, or a machine without a GPU)."""

    class cuda:  # noqa: N801 - CuPy's name
        class runtime:  # noqa: N801
            @staticmethod
            def getDeviceCount():  # noqa: N802
                raise RuntimeError("cudaErrorNoDevice: no CUDA-capable device is detected")


@pytest.mark.skipif(cupy is not None, reason="CuPy is installed: the refusal is not reached")
@pytest.mark.parametrize("cupy_module, words", [(None, "needs CuPy"),
                                                 (_NoDevice, "finds no CUDA device")])
@pytest.mark.parametrize("command", [
    ["sweep", str(REPO / "sweeps" / "smoke4.toml"), "--batch", "auto"],
    ["attractors", str(REPO / "scenes" / "figure1_n132_damped.toml"), "--starts", "2"]])
def test_backend_gpu_without_a_gpu_is_one_line_and_exit_2(
        tmp_path, capsys, monkeypatch, cupy_module, words, command):
    pytest.importorskip("mpi4py")
    from stickslip.cli.main import main

    monkeypatch.setitem(sys.modules, "cupy", cupy_module)  # None: ``import cupy`` fails
    rc = main([*command, "-o", str(tmp_path / "s"), "--backend", "gpu"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and err[0].startswith("error: ") and words in err[0], err
    assert not (tmp_path / "s").exists()  # nothing ran
