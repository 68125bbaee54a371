"""Throughput of the batched ensemble against today's per-scene sweep.

CPU, side by side in one run (needs dolfinx; ~10 min on 2 busy cores)::

    ./dev python3 benchmarks/ensemble.py [--maps 132 528] [--ranks 1 2] [--rounds 3] [--end-time T]

runs the same regime map three times with ``stickslip sweep``: today's sweep (``--batch
off`` with ``time.kernel = "numpy"``, the reference step), the fused step alone (``--batch
off``) and batched (``--batch auto``), on 1 and 2 ranks: a 64-scene map at
N = 132 (8 Omega x 8 delta, 0.02 s each) and a 16-scene map at N = 528 (4 x 4, 0.004 s);
``--end-time 0.3`` runs every scene for 0.3 s, the length of the repository's regime map
(sweeps/omega_delta.toml), over which one-time costs (numba's load, ~0.3-0.6 s a process)
are spread as in production.
It prints scene-steps per second end to end (the whole command: start-up, meshes, steady
states, time loops, analysis, files) and of the time loops alone (from the summaries'
profiles), with the ratios last. Targets: batched >= 8x per-scene at N = 132, >= 2x at 528.

Without dolfinx (a GPU node), from a dumped problem::

    ./dev python3 benchmarks/ensemble.py --dump DIR [--n 132 528]     # here: DIR/problem_nN.npz
    python3 benchmarks/ensemble.py --npz DIR/problem_n132.npz --B 4096 --backend gpu

The npz holds K (local CSR), the lumped mass, the contact nodes and frames, dt, beta2 and the
steady states + perturbations of a few scenes (their d, R Omega dt, f), tiled to B columns.
``--npz`` times the batched step (integrator + contact + contact work, state on the device)
and checks it against the CPU numba kernel on the same scenes (max |difference|; 0 = same
bits). Without ``--observe`` every step is a lean one (v, a, K u not stored, as an unsampled
step of a sweep); ``--full`` stores them at every step (as a sampled step); ``--observe``
adds the batch observers (samples every ``every`` steps, probes every step). Peak RSS of the
process is in the ``--json`` lines (``peak_rss_mb``, CPU): one process per B, e.g.
``--npz DIR/problem_n132.npz --B 1024 --steps 300 --observe --check 0 --json rss.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

MAPS = {  # N: (omega values, delta values, end_time)
    132: ([10.0, 20.0, 35.0, 50.0, 70.0, 100.0, 140.0, 200.0],
          [2e-4, 3e-4, 4e-4, 6e-4, 8e-4, 1e-3, 1.5e-3, 2e-3], 0.02),
    528: ([20.0, 50.0, 100.0, 200.0], [3e-4, 4e-4, 8e-4, 1.5e-3], 0.004),
}


# ------------------------------------------------------------------------------ CPU sweeps


def _sweep_file(directory: Path, n: int, kernel: str, end_time: float | None = None) -> Path:
    omegas, deltas, end = MAPS[n]
    end = end_time or end
    text = (f'name = "bench_n{n}"\nbase = "{REPO / "scenes/figure3_n132.toml"}"\n'
            f'set = ["mesh.n_inner = {n}", "time.end_time = {end}", \'time.kernel = "{kernel}"\']\n'
            '[grid]\n'
            f'"loading.omega" = {omegas}\n"geometry.delta" = {deltas}\n'
            '[map]\nsemianalytic = false\n')
    path = directory / f"bench_n{n}_{kernel}.toml"
    path.write_text(text)
    return path


def _run_sweep(sweep: Path, out: Path, ranks: int, batch: str) -> dict:
    cmd = ["stickslip", "sweep", str(sweep), "-o", str(out), "--batch", batch,
           "--progress", "lines"]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
    wall = time.perf_counter() - t0
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    steps = loop = rss = 0.0
    seen_loops: set = set()
    first_calls: set = set()  # one value per process (fused) or batch: the numba load
    for s_path in (out / "runs").glob("*/summary.json"):
        s = json.loads(s_path.read_text())
        steps += s.get("steps", 0)
        first_calls.add(s.get("scheme", {}).get("kernel_first_call_s") or 0.0)
        prof = s.get("profile_s", {})
        key = (prof.get("time-loop"), prof.get("mesh+assembly"))  # a batch shares its profile
        if key not in seen_loops:
            seen_loops.add(key)
            loop += prof.get("time-loop", 0.0)
        rss = max(rss, s.get("peak_rss_mb", 0.0))
    return {"wall": wall, "steps": steps, "loop": loop, "first_call": sum(first_calls),
            "rss": rss, "n": len(list((out / "runs").iterdir()))}


#: The three ways to run a map: today's sweep (numpy step, one scene after the other), the
#: fused step one scene after the other, and batches of the fused step.
VARIANTS = (("today", "numpy", "off"), ("fused", "auto", "off"), ("batched", "auto", "auto"))


def cpu_table(maps: list[int], ranks: list[int], rounds: int = 1,
              end_time: float | None = None) -> None:
    """The table; with ``rounds`` > 1 the three variants run in turn ``rounds`` times and each
    rate is the best of its rounds (this VM's speed drifts up to 1.5x between runs of the same
    code, docs/performance.md, so that one variant does not get all of a slow phase)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="ensemble-bench-") as tmp:
        tmp_path = Path(tmp)
        for n in maps:
            for r in ranks:
                res: dict[str, list[dict]] = {name: [] for name, _, _ in VARIANTS}
                for k in range(rounds):
                    for name, kernel, batch in VARIANTS:
                        sweep = _sweep_file(tmp_path, n, kernel, end_time)
                        out = tmp_path / f"n{n}_r{r}_{name}_{k}"
                        res[name].append(_run_sweep(sweep, out, r, batch))
                        print(f"  N = {n}, {r} rank(s), {name}, round {k + 1}: "
                              f"{res[name][-1]}", flush=True)
                rows.append((n, res["today"][0]["n"], r, end_time or MAPS[n][2], res))
    print("\nscene-steps per second: whole sweep command (e2e), time loops (loop, per core) "
          "and time loops without the numba kernels' one-time load/compile (steady: the "
          "summaries' scheme.kernel_first_call_s, once per process or batch); ratios "
          "batched / today")
    print(f"{'N':>5} {'scenes':>6} {'end s':>5} {'ranks':>5} {'today e2e':>10} {'fused e2e':>10} "
          f"{'batch e2e':>10} {'today loop':>10} {'fused loop':>10} {'batch loop':>10} "
          f"{'target':>6} {'e2e ratio':>9} {'loop ratio':>10} {'steady ratio':>12}")
    for n, ns, r, end, res in rows:
        e = {k: max(v["steps"] / v["wall"] for v in vs) for k, vs in res.items()}
        lo = {k: max(v["steps"] / v["loop"] for v in vs) for k, vs in res.items()}
        st = {k: max(v["steps"] / max(v["loop"] - v["first_call"], 1e-9) for v in vs)
              for k, vs in res.items()}
        print(f"{n:5d} {ns:6d} {end:5.3g} {r:5d} {e['today']:10.0f} {e['fused']:10.0f}"
              f" {e['batched']:10.0f}"
              f" {lo['today']:10.0f} {lo['fused']:10.0f} {lo['batched']:10.0f}"
              f" {8 if n < 528 else 2:6d} {e['batched'] / e['today']:9.2f}"
              f" {lo['batched'] / lo['today']:10.2f} {st['batched'] / st['today']:12.2f}")


# ------------------------------------------------------------------------------ npz mode


def dump(directory: Path, sizes: list[int], n_scenes: int = 8) -> None:
    """Write DIR/problem_nN.npz: the shared problem + n_scenes scenes' initial states."""
    from mpi4py import MPI

    from solver.ensemble import BatchedProblem
    from solver.run import Simulation
    from solver.scene import load_scene

    directory.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(15)
    for n in sizes:
        u0, d, slide, f = [], [], [], []
        bp = None
        for k in range(n_scenes):
            omega = float(rng.choice(MAPS[132][0]))
            delta = float(rng.choice(MAPS[132][1]))
            sc = load_scene(REPO / "scenes/figure3_n132.toml", [
                f"mesh.n_inner={n}", f"loading.omega={omega}", f"geometry.delta={delta}",
                f"loading.f={0.5 + 0.05 * k}", 'initial.perturbation="random"',
                f"initial.seed={k}", "output.progress=false"])
            sim = Simulation(sc, MPI.COMM_SELF)
            if bp is None:
                bp = BatchedProblem.from_problem(sim.problem, sim.dt, sc.time.beta2)
            u0.append(sim.steady.u + sim.perturbation())
            d.append(sc.geometry.d)
            slide.append(sc.geometry.R * omega * sim.dt)
            f.append(sc.loading.f)
        path = directory / f"problem_n{n}.npz"
        bp.save(path, u0=np.stack(u0, axis=1), d=np.array(d), slide=np.array(slide),
                f=np.array(f),
                every=np.array(max(1, int(round(1e-4 / sim.dt)))))
        print(f"{path}: n = {bp.n} dofs, nnz = {bp.data.size}, {bp.cx.size} contact nodes, "
              f"dt = {bp.dt:.4g} s, {n_scenes} scenes", flush=True)


def run_npz(path: Path, B: int, steps: int, backend: str, kernel: str, observe: bool,
            check: int, full: bool = False) -> dict:
    from benchmarks.gpu_bench import ensemble, host, load, probe_slot, synchronize, tile
    from solver.ensemble import array_namespace

    bp, extra = load(path)
    xp = array_namespace(backend)
    every = int(extra["every"])
    spool = Path(tempfile.mkdtemp(prefix="ensemble-spool-")) if observe else None
    obs = {"every": every, "max_samples": steps // every + 8, "max_steps": steps + 8,
           "probe_nodes": [probe_slot(bp)], "spool_dir": spool} if observe else None
    try:
        integ, _, advance = ensemble(bp, tile(extra["d"], B), tile(extra["slide"], B),
                                     tile(extra["f"], B), tile(extra["u0"], B), xp=xp,
                                     kernel=kernel, observe=obs, diag=full)
        t0 = time.perf_counter()
        advance(1)
        synchronize(xp)
        first = time.perf_counter() - t0
        advance(9)  # warm-up
        synchronize(xp)
        t0, c0 = time.perf_counter(), time.process_time()
        advance(steps)
        synchronize(xp)
        seconds = time.perf_counter() - t0
        cpu = time.process_time() - c0  # this process's CPU time: not its waits on a busy VM
    finally:
        if spool is not None:
            shutil.rmtree(spool, ignore_errors=True)
    out = {"backend": backend, "kernel": kernel, "n": bp.n, "nnz": int(bp.data.size), "B": B,
           "full": full, "steps": steps, "seconds": seconds, "first_s": first, "observe": observe,
           "scene_steps_per_s": B * steps / seconds,
           "us_per_scene_step": seconds / (B * steps) * 1e6,
           "cpu_us_per_scene_step": cpu / (B * steps) * 1e6}
    if check:
        s0 = min(B, extra["u0"].shape[1])
        ref, _, ref_advance = ensemble(bp, extra["d"][:s0], extra["slide"][:s0],
                                       extra["f"][:s0], extra["u0"][:, :s0], xp=np,
                                       kernel="numba", diag=True)
        ref_advance(integ.step_count)
        u = host(integ.u[:, :s0])
        st = host(integ.status[:, :s0])
        scale = float(np.max(np.abs(ref.u)))
        out["check_max_abs_diff_rel"] = float(np.max(np.abs(u - ref.u))) / scale
        out["check_same_bits"] = bool(np.array_equal(u, ref.u))
        out["check_status_equal"] = bool(np.array_equal(st, ref.status))
        w = integ.work_totals()[:, :s0]
        out["check_work_rel"] = float(np.max(np.abs(w - ref.work_totals()))
                                      / max(float(np.max(np.abs(ref.work_totals()))), 1e-300))
    if backend == "cpu":
        out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=int, nargs="+", default=[132, 528], choices=sorted(MAPS))
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--rounds", type=int, default=1,
                    help="run the three variants in turn this many times; best rate of each")
    ap.add_argument("--end-time", type=float, default=None,
                    help="simulated time of every scene of the maps (default: 0.02 s at "
                         "N = 132, 0.004 s at 528; the repository's regime map, "
                         "sweeps/omega_delta.toml, runs 0.3 s)")
    ap.add_argument("--dump", type=Path, help="write DIR/problem_nN.npz (needs dolfinx)")
    ap.add_argument("--n", type=int, nargs="+", default=[132, 528])
    ap.add_argument("--npz", type=Path, nargs="+", help="time the batch from dumped problems")
    ap.add_argument("--B", type=int, nargs="+", default=[64])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--backend", choices=("cpu", "gpu"), default="cpu")
    ap.add_argument("--kernel", choices=("numba", "cuda", "xp"), default=None)
    ap.add_argument("--observe", action="store_true")
    ap.add_argument("--check", type=int, default=1, help="compare with the CPU numba kernel")
    ap.add_argument("--full", action="store_true",
                    help="store v, a, K u at every step (diag = True), as a sampled step")
    ap.add_argument("--json", type=Path, help="append the npz results to this file")
    args = ap.parse_args()
    if args.rounds < 1:
        ap.error(f"--rounds {args.rounds}: give at least 1")
    if args.dump:
        dump(args.dump, args.n)
        return
    if args.npz:
        kernel = args.kernel or ("numba" if args.backend == "cpu" else "cuda")
        print(f"{'N file':>24} {'kernel':>6} {'full':>5} {'B':>6} {'steps':>6} {'1st s':>6} "
              f"{'us/scene-step':>13} {'same bits':>9} {'rel diff':>9} {'scene-steps/s':>14} "
              f"{'cpu us':>8}")
        for path in args.npz:
            for B in args.B:
                r = run_npz(path, B, args.steps, args.backend, kernel, args.observe, args.check,
                            args.full)
                if args.json:
                    with open(args.json, "a") as fh:
                        fh.write(json.dumps(r) + "\n")
                print(f"{path.name:>24} {kernel:>6} {str(args.full):>5} {B:6d} {args.steps:6d} "
                      f"{r['first_s']:6.2f} "
                      f"{r['us_per_scene_step']:13.4f} {str(r.get('check_same_bits', '-')):>9} "
                      f"{r.get('check_max_abs_diff_rel', float('nan')):9.1e} "
                      f"{r['scene_steps_per_s']:14.4g} {r['cpu_us_per_scene_step']:8.2f}",
                      flush=True)
        return
    os.environ.setdefault("OMPI_MCA_osc", "^ucx")
    if args.end_time is not None and args.end_time <= 0.0:
        ap.error(f"--end-time {args.end_time}: give a positive time in seconds")
    cpu_table(args.maps, args.ranks, args.rounds, args.end_time)


if __name__ == "__main__":
    main()
