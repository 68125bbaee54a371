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

The GPU side (the same batch on CuPy) is benchmarks/gpu_bench.py's (docs/gpu.md).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

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
    args = ap.parse_args()
    if args.rounds < 1:
        ap.error(f"--rounds {args.rounds}: give at least 1")
    os.environ.setdefault("OMPI_MCA_osc", "^ucx")
    if args.end_time is not None and args.end_time <= 0.0:
        ap.error(f"--end-time {args.end_time}: give a positive time in seconds")
    cpu_table(args.maps, args.ranks, args.rounds, args.end_time)


if __name__ == "__main__":
    main()
