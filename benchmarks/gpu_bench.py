"""The stages of the GPU benchmark suite (benchmarks/gpu_suite.sh runs them; docs/gpu.md).

Each stage is one process that appends one JSON line per measurement to ``--json``; ``report``
turns the lines into ``gpu_suite.json`` and the table ``gpu_suite.md``. The stages run from
the bundles of ``prepare`` (``solver.bundle``: the batch's layout, starts and scenes, made
where dolfinx is, e.g. ``./dev``), so the GPU node needs numpy, numba and CuPy only::

    ./dev python3 benchmarks/gpu_bench.py prepare build/gpu_suite       # here, once
    python3 benchmarks/gpu_bench.py env --json J
    python3 benchmarks/gpu_bench.py rate --bundle B --target gpu --B 4096 --json J
    python3 benchmarks/gpu_bench.py check --bundle B --B 4096 --json J
    python3 benchmarks/gpu_bench.py census --bundle build/gpu_suite/census_n132 --json J
    python3 benchmarks/gpu_bench.py report J --out DIR

Every path is the product's: the bundle's scenes and starts tiled to B columns, built as a
sweep's batch (``solver.run.Simulation.batch(scenes, prepared=...)``, the node's
runner's batch) and stepped by ``solver.run.run_loop``. Paths (``rate --paths``, timed in
turn in one process):

* ``kernel``: the scheme's batched stepper alone (``build_batch``), every step lean (v, a,
  K u not stored: an unsampled step);
* ``observed``: the batch: lean steps, a full step on each sampled level, the probes every
  step, the samples (fields, status, energies) and the health check every ``every`` steps
  (the scenes' sample_interval, 1e-4 s); the record spooled to disk on the GPU and kept in
  memory on the CPU, as the sweep does;
* ``coarse``: the same as ``observed`` at a coarse cadence (``--coarse-interval``, 1e-3 s).

On the GPU the observers copy their chunks to pinned host memory on a stream of their own
and write them from a thread (``solver.ensemble_observers._DeviceSpool``): ``spool_wait_s``
in a rate record is the time the loop waited for those copies and writes. Each timed block
ends when its full chunks are on the host and written (``BatchRecorder.drain``), so that no
path's disk work runs on in another path's time.

``--target cpu`` is the batched numba kernel on one core (the best CPU path), ``gpu`` the
CUDA kernel through CuPy. ``--emulate`` replaces CuPy by benchmarks/gpu_emulate.py (the CUDA
source compiled for the CPU), so that every GPU stage runs here, slowly, as a rehearsal.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

# The classification runs in one process per core (fork): each must use one BLAS thread, or
# 16 processes x 16 OpenBLAS threads oversubscribe a GPU node's cores (set before numpy loads
# its BLAS; a value given by the caller is kept).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

#: The timed paths (``rate --paths``), in the report's order.
PATHS = ("kernel", "observed", "coarse")
#: Records that are sums over the nodes (CuPy's reductions add in another order than numba's).
SUMMED = ("energies", "work", "initial_energy", "energy_bound")
#: The census point: the paper's Figure-3 scene (undamped, as a batch is), random starts.
CENSUS_SCENE = "scenes/figure3_n132.toml"


# --------------------------------------------------------------- the product's batch, tiled


def load(path: Path):
    """(scenes, layout, starts) of the first batch of the bundle ``path`` (``prepare``)."""
    from stickslip.solver.bundle import load_batch, read_manifest

    return load_batch(path, read_manifest(path)["batches"][0])


def tiled(data, B: int, every: int, steps: int):
    """The bundle's scenes and starts as B columns (column b: start b mod S), each run for
    ``steps`` steps and sampled every ``every``: (scenes, ``BatchStarts``)."""
    from stickslip.solver.ensemble_run import BatchStarts

    scenes, layout, starts = data
    dt = layout.problem.dt
    timed = [sc.with_overrides(f"time.end_time={steps * dt!r}", "time.max_steps=0",
                               f"output.sample_interval={every * dt!r}") for sc in scenes]
    cols = np.arange(B) % len(scenes)
    return [timed[c] for c in cols], BatchStarts(starts.u0[:, cols],
                                                 starts.steady_pressure[cols])


def batch_of(data, B: int, target: str, every: int, steps: int, spool_parent=None):
    """The batch of B tiled columns on ``target`` (the backend: cpu, gpu) and
    ``advance(k)``: k steps of ``solver.run.run_loop`` with the batch's observers."""
    from stickslip.solver.run import Simulation, run_loop

    scenes, starts = tiled(data, B, every, steps)
    batch = Simulation.batch(scenes, backend=target, spool_parent=spool_parent,
                             prepared=(data[1], starts))

    def advance(k: int) -> None:
        run_loop(batch.stepper, batch.observers, math.inf, batch.stepper.step_count + k)

    return batch, advance


def finish(batch) -> None:
    """After a loop stopped by steps: the record written out, and the scenes the guard
    found in its last chunks (GPU) masked (as ``Simulation.proceed`` ends)."""
    batch.diverge(batch.columns.close())


def stepper_of(data, B: int, target: str):
    """The scheme's batched stepper alone (no observers) of B tiled columns, and
    ``advance(k)``: k lean steps."""
    from stickslip.solver.contact import ContactLaw
    from stickslip.solver.schemes.select import for_scene

    scenes, starts = tiled(data, B, 1, 1)
    bp = data[1].problem
    laws = [ContactLaw.from_scene(sc, bp.dt) for sc in scenes]
    stepper = for_scene(scenes[0]).build_batch(bp, laws, target, scenes[0].damping.tau)
    stepper.set_state(starts.u0, np.zeros_like(starts.u0))
    return stepper, lambda k: stepper.advance(k, math.inf)


# ----------------------------------------------------------------------------- helpers


def namespace(target: str, emulate: bool):
    """numpy for the CPU; CuPy (or its CPU emulation) for the GPU."""
    if target == "cpu":
        return np
    if emulate:
        from benchmarks import gpu_emulate

        return gpu_emulate.install()
    import cupy

    return cupy


def synchronize(xp) -> None:
    if xp is not np:
        xp.cuda.Device().synchronize()


def host(a) -> np.ndarray:
    return np.asarray(a.get() if hasattr(a, "get") else a)


def cadence(args, data) -> int:
    """Steps between samples: ``--sample-interval`` (s) when given, else the scenes' (the
    sweep's 1e-4 s)."""
    dt = data[1].problem.dt
    interval = args.sample_interval or data[0][0].output.sample_interval
    return max(1, int(round(interval / dt)))


def dram_bytes_per_scene_step(n: int, m: int, every: int, observed: bool) -> float:
    """Bytes the step must move to and from device memory per scene, each array element read
    or written once (K is shared by the B scenes and stays in cache):

        lean step  32 n + 113 m   reads u_n, v~_n; writes u_{n+1}, v~_{n+1} (4 x 8 n); contact
                                  nodes: r_r, r_t, r_x, r_y, status written (33 m), z_prev read
                                  and written (32 m), the 3 works read and written (48 m)
        full step  + 24 n         v_n, a_n, K u_n written as well
        sample     + 48 n + 65 m  energies: v m v (v read, scratch written and read, v read)
                                  and u K u (u, K u read); fields (6 x 8 m), status (m),
                                  gathers of u, v, r_r, r_t at the contact nodes (6 x 8 m read
                                  counted as 16 m: the rows are short)

    ``observed``: a full step and a sample every ``every`` steps, lean steps between (the probes,
    4 doubles per step, are left out). The implied bandwidth is this times scene-steps/s.
    """
    lean = 32.0 * n + 113.0 * m
    if not observed:
        return lean
    return lean + (24.0 * n + 48.0 * n + 65.0 * m) / max(1, every)


def emit(path: Path | None, record: dict) -> None:
    line = json.dumps(record)
    print(line, flush=True)
    if path is not None:
        with open(path, "a") as fh:
            fh.write(line + "\n")


# ------------------------------------------------------------------------------ stages


def stage_env(args) -> None:
    """Device name and peak memory bandwidth (2 x memory clock x bus width / 8, from the
    device's attributes), a device-to-device copy's bandwidth, the host CPU, versions."""
    out = {"stage": "env", "python": platform.python_version(), "numpy": np.__version__,
           "cpu": _cpu_model(), "cpu_count": os.cpu_count()}
    try:
        import numba

        out["numba"] = numba.__version__
    except ImportError as err:  # the CPU stages fail; check and census compare with "xp"
        out["numba"] = f"does not import: {err}"
    try:
        xp = namespace("gpu", args.emulate)
        out["emulated"] = bool(getattr(xp, "EMULATED", False))
        out.update(_device_facts(xp))
    except Exception as err:  # no CuPy or no device: the CPU stages still run
        out["gpu_error"] = f"{type(err).__name__}: {err}"
    emit(args.json, out)


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def _device_facts(xp) -> dict:
    rt = xp.cuda.runtime
    props = rt.getDeviceProperties(0)
    name = props.get("name", b"?")
    out = {"device": name.decode() if isinstance(name, bytes) else str(name),
           "device_memory_gb": props.get("totalGlobalMem", 0) / 1e9,
           "cupy": getattr(xp, "__version__", "emulated")}
    # memory clock (kHz) and bus width (bits): cudaDevAttrMemoryClockRate = 36,
    # cudaDevAttrGlobalMemoryBusWidth = 37 (properties first; CUDA 13 dropped the clock there)
    try:
        clock = props.get("memoryClockRate") or rt.deviceGetAttribute(36, 0)
        width = props.get("memoryBusWidth") or rt.deviceGetAttribute(37, 0)
    except Exception as err:  # the copy below still gives an achievable bandwidth
        clock = width = 0
        out["attribute_error"] = f"{type(err).__name__}: {err}"
    out["memory_clock_khz"], out["memory_bus_bits"] = int(clock), int(width)
    out["peak_bandwidth_gb_s"] = 2.0 * clock * 1e3 * width / 8 / 1e9 if clock and width else None
    if not getattr(xp, "EMULATED", False):
        a = xp.ones(1 << 28, dtype=np.uint8)  # 256 MiB
        b = xp.empty_like(a)
        b[...] = a
        synchronize(xp)
        t0 = time.perf_counter()
        for _ in range(20):
            b[...] = a
        synchronize(xp)
        out["copy_bandwidth_gb_s"] = 20 * 2 * a.nbytes / (time.perf_counter() - t0) / 1e9
    return out


def stage_rate(args) -> None:
    """Scene-steps per second of the ``--paths`` on one target at one B, side by side: one
    batch per path, a warm-up block each (compile), then rounds of one ``--block`` per path
    in turn until ``--steps`` are done or ``--seconds`` have passed, so that a drift of the
    machine's speed falls on every path alike. One record per path."""
    xp = namespace(args.target, args.emulate)
    data = load(args.bundle)
    bp = data[1].problem
    every = {"kernel": cadence(args, data), "observed": cadence(args, data),
             "coarse": max(1, int(round(args.coarse_interval / bp.dt)))}
    paths = args.paths or list(PATHS)
    block, B = args.block, args.B
    total = 2 * block + args.steps + 1  # warm-up, the timed steps, a last block past --steps
    spool = Path(tempfile.mkdtemp(prefix="gpu-bench-spool-", dir=args.spool_dir))
    runs = {}
    try:
        for path in paths:
            if path == "kernel":
                stepper, advance = stepper_of(data, B, args.target)
                batch = None
            else:
                batch, advance = batch_of(data, B, args.target, every[path], total, spool)
                stepper = batch.stepper
            t0 = time.perf_counter()
            advance(block)
            synchronize(xp)
            runs[path] = {"stepper": stepper, "batch": batch, "advance": advance,
                          "first": time.perf_counter() - t0, "steps": 0, "seconds": 0.0,
                          "cpu": 0.0}
        t_start = time.perf_counter()
        while min(r["steps"] for r in runs.values()) < args.steps and (
                time.perf_counter() - t_start < args.seconds or not runs[paths[0]]["steps"]):
            for r in runs.values():
                t0, c0 = time.perf_counter(), time.process_time()
                r["advance"](block)
                if r["batch"] is not None:  # the block's copies and writes are in its time
                    r["batch"].columns.recorder.drain()
                synchronize(xp)
                r["seconds"] += time.perf_counter() - t0
                r["cpu"] += time.process_time() - c0
                r["steps"] += block
        for r in runs.values():
            if r["batch"] is not None:
                t0 = time.perf_counter()
                finish(r["batch"])
                r["close_s"] = time.perf_counter() - t0
                r["spool_wait_s"] = r["batch"].columns.recorder.wait_s
            r["active"] = int(np.sum(r["stepper"].active))
            r["finite"] = bool(np.all(np.isfinite(host(r["stepper"].u))))
    finally:
        shutil.rmtree(spool, ignore_errors=True)
    n, m = bp.n, int(bp.cx.size)
    for path, r in runs.items():
        rate = B * r["steps"] / r["seconds"]
        bytes_ss = dram_bytes_per_scene_step(n, m, every[path], path != "kernel")
        emit(args.json, {
            "stage": "rate", "target": args.target,
            "emulated": bool(getattr(xp, "EMULATED", False)), "path": path, "N": m, "n": n,
            "B": B, "every": every[path] if path != "kernel" else None, "steps": r["steps"],
            "seconds": r["seconds"], "warmup_s": r["first"], "scene_steps_per_s": rate,
            "us_per_scene_step": 1e6 / rate,
            "cpu_us_per_scene_step": 1e6 * r["cpu"] / (B * r["steps"]),
            "dram_bytes_per_scene_step": bytes_ss, "implied_gb_s": bytes_ss * rate / 1e9,
            "active_scenes": r["active"], "finite": r["finite"],
            "spool_wait_s": r.get("spool_wait_s"), "close_s": r.get("close_s"),
            "side_by_side": list(paths)})


def stage_check(args) -> None:
    """The observed path on the GPU (B scenes) against the CPU numba path on the first
    ``--scenes`` of them, ``--steps`` steps: state, statuses and recorded samples."""
    xp = namespace("gpu", args.emulate)
    data = load(args.bundle)
    every = cadence(args, data)
    S = min(args.scenes, args.B)
    runs = {}
    spool = Path(tempfile.mkdtemp(prefix="gpu-bench-spool-", dir=args.spool_dir))
    try:  # the GPU's record is spooled there: compared before it goes
        for target, B in (("gpu", args.B), ("cpu", S)):
            batch, _ = batch_of(data, B, target, every, args.steps, spool)
            batch.proceed()
            runs[target] = batch
        out = _compare(runs["gpu"], runs["cpu"], S)
    finally:
        shutil.rmtree(spool, ignore_errors=True)
    emit(args.json, {"stage": "check", "emulated": bool(getattr(xp, "EMULATED", False)),
                     "N": int(data[1].problem.cx.size), "B": args.B, "scenes_compared": S,
                     "reference": "numba", "steps": args.steps, **out})


def _compare(gpu, cpu, S: int) -> dict:
    """The first S columns of two batches: state, statuses, samples, probes, works."""
    (g, grec), (c, crec) = (gpu.stepper, gpu.columns.recorder), (cpu.stepper, cpu.columns.recorder)
    u_g = host(g.u)[:, :S]
    same = {"u": np.array_equal(u_g, c.u),
            "v_pred": np.array_equal(host(g.v_pred)[:, :S], c.v_pred),
            "status": np.array_equal(host(g.status)[:, :S], c.status)}
    fields = max(_rel(grec.arrays(b)[k], crec.arrays(b)[k])
                 for b in range(S) for k in ("u_r", "u_theta", "v_r", "v_theta", "r_r"))
    energies = max(_rel(grec.arrays(b)["energies"][:, :2], crec.arrays(b)["energies"][:, :2])
                   for b in range(S))
    probes = max(_rel(grec.probe_arrays(b)["probe_data"], crec.probe_arrays(b)["probe_data"])
                 for b in range(S))
    work = _rel(g.work_totals()[:, :S], c.work_totals())
    return {"same_bits": same, "max_rel_diff": {"fields": fields, "energies": energies,
                                                "probes": probes, "work": work},
            "u_rel_diff": _rel(u_g, c.u)}


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| / max |b| (0 when both are zero)."""
    scale = float(np.max(np.abs(b))) if b.size else 0.0
    return float(np.max(np.abs(a - b))) / scale if scale > 0 else float(np.max(np.abs(a)))


def stage_census(args) -> None:
    """The census of ``--B`` starts (the bundle's starts, tiled) for ``--end-time`` seconds
    on the GPU with the observers, then the classification of every scene
    (``postprocess.analysis.analyse``: regime, mode, direction), its members and shares,
    and the first ``--scenes`` starts again on the CPU: state bitwise, same members."""
    xp = namespace(args.target, args.emulate)
    data = load(args.bundle)
    dt = data[1].problem.dt
    steps = int(round(args.end_time / dt))
    every = max(1, int(round(args.sample_interval / dt)))
    B, starts = args.B, len(data[0])
    S = min(args.scenes, B, starts)
    out: dict = {"stage": "census", "target": args.target,
                 "emulated": bool(getattr(xp, "EMULATED", False)),
                 "N": int(data[1].problem.cx.size), "B": B, "starts": starts,
                 "end_time": args.end_time, "steps": steps, "every": every,
                 "scene_steps": B * steps}
    labels, u, out[args.target] = _census_run(data, B, args.target, steps, every, args)
    if not args.skip_cpu:
        try:  # the CPU's side must not cost the GPU's result
            lab_c, u_c, out["cpu-subsample"] = _census_run(data, S, "cpu", steps, every, args)
            out["cpu-subsample"]["kernel"] = "numba"
            out["subsample_same_bits"] = bool(np.array_equal(u[:, :S], u_c))
            out["subsample_same_members"] = labels[:S] == lab_c
        except Exception as err:
            out["cpu_subsample_error"] = f"{type(err).__name__}: {err}"
    emit(args.json, out)


def _census_run(data, nb: int, target: str, steps: int, every: int, args):
    """One census batch of ``nb`` scenes: (members, final u on the host, timings/shares)."""
    spool = Path(tempfile.mkdtemp(prefix="gpu-census-spool-", dir=args.spool_dir))
    try:
        t0 = time.perf_counter()
        batch, _ = batch_of(data, nb, target, every, steps, spool)
        batch.proceed()
        synchronize(batch.stepper.xp)
        loop = time.perf_counter() - t0
        t0 = time.perf_counter()
        d = np.array([sc.geometry.d for sc in batch.scenes])
        labels = classify_all(batch.columns.recorder, batch.stepper.active, d,
                              float(batch.scenes[0].geometry.R), args.workers)
        classify = time.perf_counter() - t0
        return labels, host(batch.stepper.u), {
            "loop_s": loop, "classify_s": classify, "total_s": loop + classify,
            "scene_steps_per_s": nb * steps / loop,
            "shares": {k: v / nb for k, v in Counter(labels).most_common()}}
    finally:
        shutil.rmtree(spool, ignore_errors=True)


_CLASSIFY: dict = {}  # the recorder and scene data, inherited by the forked workers


def classify_all(rec, active: np.ndarray, d: np.ndarray, radius: float,
                 workers: int) -> list[str]:
    """Every scene's member, ``workers`` processes (``forked_map``)."""
    _CLASSIFY.update(rec=rec, active=np.asarray(active), d=d, radius=radius)
    return forked_map(_classify, d.size, workers)


def forked_map(fn, count: int, workers: int) -> list:
    """[fn(0), …, fn(count − 1)] in ``workers`` forked processes, in this one where
    ``workers`` ≤ 1. The workers inherit what ``fn`` reads (module state set before the
    call: the records, host arrays or spool files) and never touch the device."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    if workers <= 1:
        return [fn(i) for i in range(count)]
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(workers, mp_context=ctx) as pool:
        return list(pool.map(fn, range(count), chunksize=max(1, count // (4 * workers))))


def _classify(b: int) -> str:
    """Scene b's member: regime, dominant mode k and direction of travel."""
    from stickslip.postprocess.analysis import analyse

    c = _CLASSIFY
    if not c["active"][b]:
        return "diverged"
    a = c["rec"].arrays(b)
    try:
        w = analyse(a["t"], a["theta"], a["u_r"], a["u_theta"], a["status"], d=float(c["d"][b]),
                    radius=c["radius"])
    except ValueError as err:
        return f"unclassified ({err})"
    return f"{w.regime} k={w.mode} {w.direction}"


def stage_cli(args) -> None:
    """The census from the command line: ``stickslip attractors`` of ``--starts`` random
    starts at the census point, first leg only (``--max-time`` = ``--end-time``), on
    ``--backend``; its exit status, wall time, the classes' shares from attractors.json and
    the last line of its standard error."""
    import subprocess

    out_dir = Path(tempfile.mkdtemp(prefix="gpu-bench-cli-", dir=args.spool_dir))
    t = repr(args.end_time)
    cmd = ["stickslip", "attractors", str(REPO / CENSUS_SCENE), "--starts", str(args.starts),
           "--end-time", t, "--max-time", t, "--set",
           f"output.sample_interval={args.sample_interval!r}", "--no-certify", "--backend",
           args.backend, "--progress", "lines", "-o", str(out_dir / "census")]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
    seconds = time.perf_counter() - t0
    answer = out_dir / "census" / "attractors.json"
    counts = json.loads(answer.read_text())["counts"] if answer.exists() else {}
    err = proc.stderr.strip().splitlines()
    emit(args.json, {"stage": "cli", "command": " ".join(cmd[:2] + [CENSUS_SCENE] + cmd[3:-1]),
                     "backend": args.backend, "starts": args.starts, "end_time": args.end_time,
                     "rc": proc.returncode, "seconds": seconds,
                     "stderr_lines": len(err), "stderr_last": err[-1] if err else "",
                     "shares": {k: v / max(1, sum(counts.values()))
                                for k, v in sorted(counts.items())}})
    shutil.rmtree(out_dir, ignore_errors=True)


def stage_node(args) -> None:
    """The product's node runner, ``python3 -m stickslip.node DIR``, on a census bundle
    (``stickslip attractors ... --bundle DIR``) with ``--backend gpu`` and with ``--backend
    cpu`` (``--backends``), each on its own copy: exit statuses, wall times, and every
    start's records compared (samples and checkpoint state bitwise but for the energies and
    works, whose reductions sum in another order on the GPU: their largest relative
    difference), with each start's u_r samples' SHA-256 for a check against another
    machine."""
    import hashlib
    import subprocess

    work = Path(tempfile.mkdtemp(prefix="gpu-bench-node-", dir=args.spool_dir))
    record: dict = {"stage": "node", "bundle": args.bundle.name}
    try:
        dirs = {}
        for k, backend in enumerate(args.backends):
            d = dirs[k] = work / f"{k}-{backend}"
            shutil.copytree(args.bundle, d, ignore=shutil.ignore_patterns("results"))
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "stickslip.node", str(d),
                                   "--backend", backend], capture_output=True, text=True,
                                  cwd=REPO)
            record[f"{k}-{backend}"] = {"rc": proc.returncode,
                                        "seconds": time.perf_counter() - t0,
                                        "stdout": proc.stdout.strip().splitlines(),
                                        "stderr_last": proc.stderr.strip()[-300:]}
            if proc.returncode != 0:
                return
        ids = sorted(p.name for p in (dirs[1] / "results").iterdir())
        differ, hashes, rel = [], {}, {}
        for start in ids:
            a, b = (dirs[k] / "results" / start for k in (0, 1))
            for name in ("samples.npz", "state.npz"):
                if (a / name).exists() or (b / name).exists():
                    differ += [f"{start}/{name}:{d}" for d in _npz_differences(
                        a / name, b / name, rel)]
            with np.load(b / "samples.npz") as zb:
                hashes[start] = hashlib.sha256(zb["u_r"].tobytes()).hexdigest()
            fa, fb = (json.loads((x / "facts.json").read_text()) for x in (a, b))
            if fa["message"] != fb["message"]:
                differ.append(f"{start}/facts.json:message")
        record.update({"starts": len(ids), "differ": differ, "max_rel_diff": rel,
                       "u_r_sha256": hashes})
    finally:
        shutil.rmtree(work, ignore_errors=True)
        emit(args.json, record)


def _npz_differences(path_a: Path, path_b: Path, rel: dict[str, float]) -> list[str]:
    """The arrays of ``path_b`` that ``path_a`` lacks or holds with other bits (each array
    read once), but the kernel's name and the sums over the nodes (``SUMMED``), whose
    largest relative difference goes into ``rel`` instead."""
    out = []
    with np.load(path_a) as za, np.load(path_b) as zb:
        for key in zb.files:
            leaf = key.rsplit("/", 1)[-1]
            if leaf == "kernel":
                continue
            y = zb[key]
            x = za[key] if key in za.files else None
            if x is not None and np.array_equal(x, y):
                continue
            if x is not None and x.shape != y.shape:
                out.append(f"{key} {x.shape} against {y.shape}")
            elif x is not None and leaf.startswith(SUMMED):
                rel[key] = max(rel.get(key, 0.0), _rel(x, y))
            else:
                out.append(key)
    return out


def stage_pytest(args) -> None:
    """tests/test_gpu.py on this node, from the bundle (``STICKSLIP_GPU_BUNDLE``): the
    CUDA kernel through CuPy bitwise against numba, and the CPU emulation's tests."""
    import subprocess

    env = dict(os.environ, STICKSLIP_GPU_BUNDLE=str(args.bundle.resolve()))
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "tests/test_gpu.py"], capture_output=True, text=True, cwd=REPO,
                          env=env)
    lines = proc.stdout.strip().splitlines()
    emit(args.json, {"stage": "pytest", "rc": proc.returncode,
                     "seconds": time.perf_counter() - t0,
                     "summary": lines[-1] if lines else proc.stderr.strip()[-300:],
                     "failures": [ln for ln in lines if ln.startswith(("FAILED", "ERROR"))]})


def stage_prepare(args) -> None:
    """The bundles (``solver.bundle.prepare_bundle``; needs dolfinx): DIR/problem_nN, 8
    scenes of the regime map of benchmarks/ensemble.py (Ω, δ, f drawn, random starts,
    samples every 1e-4 s), and DIR/census_n132, ``--starts`` random starts (seeds 0, 1, ...)
    of the census point."""
    from benchmarks.ensemble import MAPS
    from stickslip.solver.bundle import prepare_bundle
    from stickslip.solver.scene import load_scene

    rng = np.random.default_rng(15)
    for n in args.n:
        scenes = [load_scene(REPO / CENSUS_SCENE, [
            f"mesh.n_inner={n}", f"loading.omega={float(rng.choice(MAPS[132][0]))}",
            f"geometry.delta={float(rng.choice(MAPS[132][1]))}", f"loading.f={0.5 + 0.05 * k}",
            'initial.perturbation="random"', f"initial.seed={k}", "output.progress=false",
            "output.sample_interval=1e-4"]) for k in range(8)]
        prepare_bundle(args.directory / f"problem_n{n}",
                       [([f"map{k}" for k in range(8)], scenes)])
    scenes = [load_scene(REPO / CENSUS_SCENE, ['initial.perturbation="random"',
                                               f"initial.seed={seed}", "output.progress=false"])
              for seed in range(args.starts)]
    prepare_bundle(args.directory / "census_n132",
                   [([f"seed{seed}" for seed in range(args.starts)], scenes)])


# ------------------------------------------------------------------------------ report


def stage_report(args) -> None:
    """``gpu_suite.json`` (every record, and the ratios) and ``gpu_suite.md`` (the table)."""
    records = [json.loads(line) for p in args.jsonl if p.exists()
               for line in p.read_text().splitlines() if line.strip()]
    env = next((r for r in records if r["stage"] == "env"), {})
    rates = [r for r in records if r["stage"] == "rate"]
    peak = env.get("peak_bandwidth_gb_s")
    def key(r: dict) -> tuple:
        return r["N"], r["path"], r["every"]

    best_cpu = {}  # (N, path, cadence) -> the CPU run with the most scene-steps/s (its best B)
    for r in rates:
        if r["target"] == "cpu" and (key(r) not in best_cpu or r["scene_steps_per_s"]
                                     > best_cpu[key(r)]["scene_steps_per_s"]):
            best_cpu[key(r)] = r
    kernel = {(r["N"], r["target"], r["B"]): r for r in rates if r["path"] == "kernel"}
    rows = []
    for r in sorted(rates, key=lambda r: (r["N"], r["target"] != "gpu", r["B"],
                                       PATHS.index(r["path"]))):
        cpu = best_cpu.get(key(r))
        r["ratio_to_best_cpu_core"] = (r["scene_steps_per_s"] / cpu["scene_steps_per_s"]
                                       if cpu else None)
        k = kernel.get((r["N"], r["target"], r["B"]))  # the observers' cost: wall, CPU time
        r["time_over_kernel"] = k["scene_steps_per_s"] / r["scene_steps_per_s"] if k else None
        r["cpu_time_over_kernel"] = (r["cpu_us_per_scene_step"] / k["cpu_us_per_scene_step"]
                                     if k else None)
        r["fraction_of_peak"] = r["implied_gb_s"] / peak if peak and r["target"] == "gpu" \
            else None
        rows.append(r)
    summary = {"env": env, "rates": rows,
               "checks": [r for r in records if r["stage"] == "check"],
               "census": [r for r in records if r["stage"] == "census"],
               "cli": [r for r in records if r["stage"] == "cli"],
               "pytest": [r for r in records if r["stage"] == "pytest"],
               "skipped": [r for r in records if r["stage"] == "skipped"]}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "gpu_suite.json").write_text(json.dumps(summary, indent=1))
    text = _table(summary, peak)
    (args.out / "gpu_suite.md").write_text(text)
    print(text)


def _fmt(x, spec: str) -> str:
    return "-" if x is None else format(x, spec)


def _table(s: dict, peak) -> str:
    env = s["env"]
    lines = [f"device: {env.get('device', env.get('gpu_error', '?'))}; host CPU: "
             f"{env.get('cpu', '?')}; peak bandwidth {_fmt(peak, '.0f')} GB/s, copy "
             f"{_fmt(env.get('copy_bandwidth_gb_s'), '.0f')} GB/s", "",
             "| N | target | path | B | every | steps | scene-steps/s | µs/scene-step | "
             "CPU µs/scene-step | this / kernel (wall, CPU) | x best CPU core | "
             "implied GB/s | of peak |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in s["rates"]:
        target = r["target"] + (" (emulated)" if r.get("emulated") else "")
        lines.append(
            f"| {r['N']} | {target} | {r['path']} | {r['B']} | {r['every'] or '-'} | "
            f"{r['steps']} | "
            f"{r['scene_steps_per_s']:.3g} | {r['us_per_scene_step']:.4g} | "
            f"{r['cpu_us_per_scene_step']:.4g} | {_fmt(r['time_over_kernel'], '.3g')}, "
            f"{_fmt(r['cpu_time_over_kernel'], '.3g')} | "
            f"{_fmt(r['ratio_to_best_cpu_core'], '.3g')} | {r['implied_gb_s']:.3g} | "
            f"{_fmt(r['fraction_of_peak'], '.0%')} |")
    waits = [f"N = {r['N']} {r['path']} {r['spool_wait_s']:.2f} s (close {r['close_s']:.2f} s)"
             for r in s["rates"] if r["target"] == "gpu" and r.get("spool_wait_s") is not None]
    if waits:
        lines.append("\nGPU observers, the loop's waits for the chunks' copies and writes in "
                     "the timed blocks: " + "; ".join(waits))
    for c in s["checks"]:
        lines.append(f"\ncheck N = {c['N']}, B = {c['B']}, {c['steps']} steps, first "
                     f"{c['scenes_compared']} scenes against the CPU ({c['reference']}): same bits "
                     f"{c['same_bits']}; max rel. diff {c['max_rel_diff']}")
    for c in s["census"]:
        main = c.get(c["target"], {})
        lines.append(f"\ncensus N = {c['N']}: {c['B']} scenes ({c['starts']} starts), "
                     f"{c['end_time']} s, {c['scene_steps']:.3g} scene-steps on "
                     f"{c['target']}: loop {_fmt(main.get('loop_s'), '.1f')} s + classify "
                     f"{_fmt(main.get('classify_s'), '.1f')} s = "
                     f"{_fmt(main.get('total_s'), '.1f')} s; shares {main.get('shares')}; "
                     f"CPU subsample: same bits {c.get('subsample_same_bits')}, same members "
                     f"{c.get('subsample_same_members')} {c.get('cpu_subsample_error', '')}")
    for c in s["cli"]:
        lines.append(f"\nCLI: `{c['command']}`: exit {c['rc']}, {c['seconds']:.1f} s, shares "
                     f"{c['shares']}; stderr: {c['stderr_lines']} line(s), last "
                     f"{c['stderr_last']!r}")
    for c in s["pytest"]:
        lines.append(f"\ntests/test_gpu.py: exit {c['rc']}, {c['summary']} {c['failures']}")
    for c in s["skipped"]:
        lines.append(f"\nskipped {c['what']}: {c['why']}")
    return "\n".join(lines) + "\n"


# -------------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="stage", required=True)
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--json", type=Path, help="append the records to this file")
    common.add_argument("--emulate", action="store_true",
                        help="the CUDA source compiled for the CPU instead of CuPy")
    common.add_argument("--spool-dir", type=Path, default=None,
                        help="where spooled records go (default: the temp directory)")
    p = sub.add_parser("prepare", help="write the bundles (needs dolfinx)")
    p.add_argument("directory", type=Path)
    p.add_argument("--n", type=int, nargs="+", default=[132, 528])
    p.add_argument("--starts", type=int, default=256, help="census starts")
    sub.add_parser("env", parents=[common], help="device and host facts")
    p = sub.add_parser("rate", parents=[common], help="scene-steps/s of one path")
    p.add_argument("--bundle", type=Path, required=True)
    p.add_argument("--target", choices=("cpu", "gpu"), required=True)
    p.add_argument("--paths", nargs="+", choices=PATHS, default=None,
                   help="kernel alone; with the observers at the sweep's cadence (record "
                        "spooled to disk on the GPU); at the coarse cadence (timed in turn, "
                        "side by side; default: all)")
    p.add_argument("--B", type=int, required=True)
    p.add_argument("--steps", type=int, default=2000, help="timed steps per path at most")
    p.add_argument("--seconds", type=float, default=20.0, help="timed seconds at most")
    p.add_argument("--block", type=int, default=100, help="steps per path and round")
    p.add_argument("--sample-interval", type=float, default=0.0,
                   help="s between samples (default: the scenes', the sweep's 1e-4 s)")
    p.add_argument("--coarse-interval", type=float, default=1e-3,
                   help="s between samples of the coarse path")
    p = sub.add_parser("check", parents=[common], help="GPU against CPU, observed path")
    p.add_argument("--bundle", type=Path, required=True)
    p.add_argument("--B", type=int, default=4096)
    p.add_argument("--scenes", type=int, default=8)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--sample-interval", type=float, default=0.0)
    p = sub.add_parser("census", parents=[common], help="census loop + classification")
    p.add_argument("--bundle", type=Path, required=True)
    p.add_argument("--target", choices=("cpu", "gpu"), default="gpu")
    p.add_argument("--B", type=int, default=4096)
    p.add_argument("--end-time", type=float, default=0.3)
    p.add_argument("--sample-interval", type=float, default=1e-3,
                   help="s between samples (coarse: the record of 4096 scenes must fit)")
    p.add_argument("--scenes", type=int, default=8, help="CPU subsample")
    p.add_argument("--skip-cpu", action="store_true")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                   help="processes that classify the scenes")
    p = sub.add_parser("cli", parents=[common], help="the census by `stickslip attractors`")
    p.add_argument("--starts", type=int, default=4096)
    p.add_argument("--end-time", type=float, default=0.3)
    p.add_argument("--sample-interval", type=float, default=1e-3)
    p.add_argument("--backend", choices=("cpu", "gpu"), default="gpu")
    p = sub.add_parser("node", parents=[common],
                       help="python3 -m stickslip.node on a bundle, GPU against CPU")
    p.add_argument("--bundle", type=Path, required=True)
    p.add_argument("--backends", nargs=2, choices=("gpu", "cpu"), default=["gpu", "cpu"],
                   help="the two runs compared (cpu cpu: a rehearsal without a GPU)")
    p = sub.add_parser("pytest", parents=[common], help="tests/test_gpu.py on this node")
    p.add_argument("--bundle", type=Path, required=True)
    p = sub.add_parser("report", help="gpu_suite.json + gpu_suite.md from the records")
    p.add_argument("jsonl", type=Path, nargs="+")
    p.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    {"prepare": stage_prepare, "env": stage_env, "rate": stage_rate, "check": stage_check,
     "census": stage_census, "cli": stage_cli, "node": stage_node, "pytest": stage_pytest,
     "report": stage_report}[args.stage](args)


if __name__ == "__main__":
    main()
