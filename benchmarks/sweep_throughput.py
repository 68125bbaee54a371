"""Sweep throughput: the same batch of scenes with ``mpirun -n 1`` and ``mpirun -n 2``.

    ./dev python3 benchmarks/sweep_throughput.py [--scenes 12] [--end-time 1.0] [--repeat 3]

Writes a sweep of ``--scenes`` variants of scenes/figure3_n36.toml (Omega varied, so every
scene has the same cost: 36 contact nodes, 216 dofs, 1 s = 12939 steps), runs it with
each rank count into a fresh directory and prints: end-to-end wall time of the whole command
(mpirun + Python start-up + every scene), the time of the sweep loop itself (from the table's
``last_session``), scenes per hour, the mean wall time of one scene, and the speed-up over the
first rank count. Target: >= 1.8x from 1 to 2 ranks on a 2-core machine.
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


def sweep_text(n: int, end_time: float) -> str:
    omegas = ", ".join(f"{10.0 + 5.0 * i:.1f}" for i in range(n))
    return (f'name = "throughput"\nbase = "{REPO / "scenes" / "figure3_n36.toml"}"\n'
            f'set = ["time.end_time = {end_time}"]\n[grid]\n"loading.omega" = [{omegas}]\n'
            '[map]\nsemianalytic = false\n')


def run(ranks: int, sweep: Path, out: Path) -> dict:
    cmd = ["mpirun", "-n", str(ranks), sys.executable, "-m", "stickslip.cli.main", "sweep", str(sweep),
           "-o", str(out), "--progress", "lines"]
    env = dict(os.environ, PYTHONPATH=str(REPO))
    t0 = time.perf_counter()
    res = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if res.returncode != 0:
        raise SystemExit(f"sweep on {ranks} rank(s) failed:\n{res.stdout}\n{res.stderr}")
    meta = json.loads((out / "sweep.json").read_text())
    rows = meta["rows"]
    sess = meta["last_session"]
    scene_walls = [r["wall_time_s"] for r in rows]
    return {
        "ranks": ranks,
        "scenes": len(rows),
        "end_to_end_s": wall,
        "loop_s": sess["finished"] - sess["started"],
        "mean_scene_s": sum(scene_walls) / len(scene_walls),
        "steps": rows[0]["steps"],
        "dofs": rows[0]["dofs"],
        "scenes_per_hour": 3600.0 * len(rows) / wall,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=12)
    ap.add_argument("--end-time", type=float, default=1.0)
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=1,
                    help="alternate the rank counts this many times and keep each one's "
                         "fastest run (a shared machine: other jobs only ever slow a run down)")
    ap.add_argument("--json", help="also write the results here")
    args = ap.parse_args()
    load = os.getloadavg()
    print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on "
          f"{os.cpu_count()} cores")
    runs: dict[int, list[dict]] = {p: [] for p in args.ranks}
    with tempfile.TemporaryDirectory(prefix="sweep_throughput_") as tmp:
        sweep = Path(tmp) / "throughput.toml"
        sweep.write_text(sweep_text(args.scenes, args.end_time))
        for i in range(args.repeat):
            for p in args.ranks:
                runs[p].append(run(p, sweep, Path(tmp) / f"n{p}_{i}"))
    for p, rs in runs.items():
        print(f"  {p} rank(s), end-to-end s of each run: "
              + ", ".join(f"{r['end_to_end_s']:.1f}" for r in rs))
    results = [min(rs, key=lambda r: r["end_to_end_s"]) for rs in runs.values()]
    ref = results[0]
    print(f"{args.scenes} scenes, {ref['dofs']} dofs, {ref['steps']} steps each")
    print(f"{'ranks':>5} {'end-to-end s':>12} {'loop s':>8} {'scene s':>8} {'scenes/h':>9} "
          f"{'speed-up e2e':>12} {'speed-up loop':>13}")
    for r in results:
        print(f"{r['ranks']:5d} {r['end_to_end_s']:12.1f} {r['loop_s']:8.1f} "
              f"{r['mean_scene_s']:8.2f} {r['scenes_per_hour']:9.0f} "
              f"{ref['end_to_end_s'] / r['end_to_end_s']:12.2f} "
              f"{ref['loop_s'] / r['loop_s']:13.2f}")
    load = os.getloadavg()
    print(f"load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
