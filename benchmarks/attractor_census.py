"""Attractor census timing: end to end, and the scene-steps per second it achieves.

    ./dev python3 benchmarks/attractor_census.py [--scene figure1_n132_damped]
        [--starts 64] [--meshes 132,264] [--end-time 0.3] [--max-time 4.0]
        [--set KEY=VALUE ...] [--ranks 1] [--no-certify] [-o DIR]
    ./dev python3 benchmarks/attractor_census.py --from DIR   # a finished census directory
    ./dev python3 benchmarks/attractor_census.py --spreads DIR [DIR ...]   # feature spreads
    ./dev python3 benchmarks/attractor_census.py --samples DIR   # deflated vs stored samples

Runs ``stickslip attractors`` (under ``mpirun -n RANKS``) into a fresh directory (or reads
DIR) and prints one JSON line: the command's wall time (start-up, every start, the analysis),
the sweep loop's own time (``last_session`` of sweep.json; the session that finished the
census), the number of starts and their scene-steps (Σ steps over the starts) per mesh, and
scene-steps per second = Σ steps / Σ per-start wall time (the rate of the runs themselves) and
Σ steps / the loop's time (the census's rate, all ranks together; the one to quote: a
batched start carries its whole batch's wall time, so the first rate undercounts batches).
With settle-or-extend (the default) each record also gives per mesh the class counts, the
simulated time the extension added, the settle times (median, largest), and the load
average of the machine before and after (a shared machine makes a timing pessimistic) and
the CPU time of the command and its processes (``cpu_s``: user + system, all ranks; the
measure to compare on a shared machine, where the wall time depends on the others' load).
Targets on a 2-core machine (``--ranks 2``): the tutorial's census (16 starts, N = 132 and
264, 0.3 s first leg, settle-or-extend, certificates) in ≤ 3 minutes:

    ./dev python3 benchmarks/attractor_census.py --starts 16 --ranks 2

and 64 starts of the public point in ≤ 10 minutes:

    ./dev python3 benchmarks/attractor_census.py --starts 64 --ranks 2 \
        --set loading.omega=60 --set geometry.delta=8e-4 --set loading.f=0.6

Around the time loop, a census leg spends its CPU time on: solving each continued batch's
steady state and building its mesh, K and ω_max again (now skipped: ``restore``
overwrites the start, and the mesh, K and layout of the leg before are kept in the
process, ``studies.rundir.continuation.BUILT``); joining a continued start's earlier and
new samples for each of the writer's three reads (now once); a sample's ~20 and a step's
3 small numpy copies (now compiled, ``solver._sample_kernels``: per step of the whole loop
15 % less CPU for one N = 132 start, 12 % for a batch of 8 at N = 264, 5 % for 8 at
N = 132); and rewriting each continued start's whole samples.npz at every leg and reading
it back (the largest part left: ~10 % of a tutorial census's CPU, more where many starts
run to the cap). Side by side, one run each on one 2-core machine shared with a CI loop
(load average 4 to 6 throughout, numba's cache warm), ``cpu_s`` with the code without
and with these changes: the tutorial census 314.7 s and 267.7 s (0.85; wall 361 s and
289 s); the 64 starts of the public point to ``--max-time 0.45 --no-certify`` (the first
leg and one extension of all 128 starts, batches of 32) 332.7 s and 290.2 s (0.87).
Both answers, and every start's and kick's samples, checkpoint and final field, are
bitwise the same (compared array by array).

Measured on the idle 2-core development machine (load average below 1.7 throughout), with
these changes: the tutorial census 150.5 s wall (target 180 s; 258.6 CPU s; the time loop
129.1 s, certificates 19.6 s of which kicks 9.8 s), the 64 starts of the public point with
settle-or-extend and certificates 422.8 s wall (target 600 s; 765.9 CPU s; the time loop
396.8 s, certificates 24.3 s of which kicks 16.3 s; every start settled, 8 attractors at
N = 132 and 4 at N = 264).

The N = 528 rung of a 16-start census (cap 4 s, certificates, the chaos test; target 15
minutes on 2 cores), ``./dev mpirun -n 2 stickslip attractors scenes/figure1_n132_damped.toml
--starts 16 --meshes 528 -o DIR --yes-i-know`` on the idle machine: the tutorial point in
12 min 9 s (5.23 M scene-steps), the public point P in 23 min 53 s (8.00 M). P's rung is
bound by its steps: its multi-wave starts drift for seconds, and its tail legs run one to
three starts. ``--step-bound LOG --dt DT`` reads the census's printed legs (``settle:
continuing …``) and sums, leg by leg, the steps of the busier rank at the measured cost of
a step of its batch (``STEP_US``, N = 528, ``benchmarks/small_batches.py``): a lower bound
of the time loop on two ranks, before any certificate, overhead or idle rank. For P it is
949 s (15.8 minutes; 7.999 M scene-steps, as the census counted), and its certificates
took 177 s more: no schedule of these legs on this kernel reaches 15 minutes there.

``--samples DIR`` compares, side by side on the starts of a finished census, the CPU time
of writing each start's samples.npz deflated (``solver.atomic.NPZ_LEVEL``, what a batch
member wrote before) and stored (what the census's starts write now: every leg of
settle-or-extend rewrites a start's whole record, and reads it back), and of reading both
back; the same arrays either way, so the census's answer cannot change.

``--spreads`` prints the measured spreads behind the grouping tolerances
(``studies.attractors.features``): per mesh and settled member reached by two or more
starts, the largest spread across its starts of each listed component's celerity
(relative) and share (absolute) and of the zone fractions; per start, the largest change of
the same between its two consecutive windows, for the settled and for the unsettled starts;
and the gaps between members of one mesh that share the dominant component.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def measure(out: Path) -> dict:
    """Scene-steps and times of a census directory (its attractors.json and sweep.json)."""
    answer = json.loads((out / "attractors.json").read_text())
    sweep = json.loads((out / "starts" / "sweep.json").read_text())
    per_mesh: dict[str, dict] = {}
    first_leg = float(answer["scene"]["time"]["end_time"])
    for r in answer["starts"]:
        m = per_mesh.setdefault(str(r["n_inner"]), {"starts": 0, "steps": 0, "run_s": 0.0,
                                                    "classes": {}, "extended_sim_s": 0.0,
                                                    "settle_s": []})
        m["starts"] += 1
        m["steps"] += int(r["steps"] or 0)
        m["run_s"] += float(r["wall_time_s"] or 0.0)
        m["classes"][r["class"]] = m["classes"].get(r["class"], 0) + 1
        m["extended_sim_s"] += max(0.0, float(r.get("sim_time_s") or 0.0) - first_leg)
        if r.get("settle_time_s") is not None:
            m["settle_s"].append(float(r["settle_time_s"]))
    for m in per_mesh.values():
        m["steps_per_s"] = m["steps"] / m["run_s"] if m["run_s"] else None
        settle = sorted(m.pop("settle_s"))
        m["settle_s_median"] = settle[len(settle) // 2] if settle else None
        m["settle_s_max"] = settle[-1] if settle else None
    session = sweep.get("last_session") or {}
    loop_s = (session.get("finished", 0.0) - session.get("started", 0.0)) or None
    steps = sum(m["steps"] for m in per_mesh.values())
    run_s = sum(m["run_s"] for m in per_mesh.values())
    return {"census": str(out), "starts": len(answer["starts"]), "scene_steps": steps,
            "runs_s": run_s, "scene_steps_per_s_runs": steps / run_s if run_s else None,
            "loop_s": loop_s, "ranks": session.get("ranks"),
            "scene_steps_per_s_loop": steps / loop_s if loop_s else None,
            "pending_at_last_session": session.get("pending_at_start"),
            "counts": answer["counts"], "timing": answer.get("timing"),
            "per_mesh": per_mesh}


def samples_ab(out: Path) -> dict:
    """CPU seconds to write and read back every start's samples deflated and stored
    (module docstring), with the bytes of each; one start after the other, side by side."""
    import numpy as np

    from stickslip.solver.atomic import atomic_save_npz

    totals = {f"{how}_{what}": 0.0 for how in ("deflated", "stored")
              for what in ("write_cpu_s", "read_cpu_s", "bytes")}
    runs = sorted((out / "starts" / "runs").glob("*/samples.npz"))
    with tempfile.TemporaryDirectory(dir=out) as tmp:
        for path in runs:
            with np.load(path) as z:
                arrays = {k: z[k] for k in z.files}
            for how, compress in (("deflated", True), ("stored", False)):
                target = Path(tmp) / f"{how}.npz"
                t0 = time.process_time()
                atomic_save_npz(target, arrays, compress=compress)
                t1 = time.process_time()
                with np.load(target) as z:
                    _ = [z[k] for k in z.files]
                totals[f"{how}_write_cpu_s"] += t1 - t0
                totals[f"{how}_read_cpu_s"] += time.process_time() - t1
                totals[f"{how}_bytes"] += target.stat().st_size
    write_ratio = totals["deflated_write_cpu_s"] / max(totals["stored_write_cpu_s"], 1e-9)
    read_ratio = totals["deflated_read_cpu_s"] / max(totals["stored_read_cpu_s"], 1e-9)
    return {"census": str(out), "starts": len(runs), **totals,
            "write_cpu_ratio_deflated_over_stored": write_ratio,
            "read_cpu_ratio_deflated_over_stored": read_ratio,
            "size_ratio_stored_over_deflated": totals["stored_bytes"] / max(
                totals["deflated_bytes"], 1), "load": os.getloadavg()}


def _feature_values(features: dict) -> dict:
    """{(k, direction): (celerity, share)} of the listed components, and the fractions."""
    comps = {(c["k"], c["direction"]): (c["celerity_m_s"], c["share"])
             for c in features["components"] if not c["weak"]}
    return {"components": comps, "fractions": features.get("fractions") or {},
            "rms": features.get("rms_amplitude_m")}


def _spread(values: list[dict]) -> dict:
    """Largest relative celerity spread, absolute share spread, absolute fraction spread."""
    cel = share = frac = 0.0
    keys = set().union(*(v["components"] for v in values))
    for key in keys:
        have = [v["components"][key] for v in values if key in v["components"]]
        cs = [c for c, _ in have if c is not None]
        if len(cs) > 1:
            cel = max(cel, (max(cs) - min(cs)) / abs(sum(cs) / len(cs)))
        ss = [s for _, s in have]
        if len(ss) > 1:
            share = max(share, max(ss) - min(ss))
    for zone in ("separation", "stick", "slip"):
        fs = [v["fractions"][zone] for v in values if zone in v["fractions"]]
        if len(fs) > 1:
            frac = max(frac, max(fs) - min(fs))
    rms = [v["rms"] for v in values if v.get("rms")]
    rms_rel = (max(rms) - min(rms)) / max(rms) if len(rms) > 1 else 0.0
    return {"celerity_rel": cel, "share_abs": share, "fraction_abs": frac, "rms_rel": rms_rel}


def spreads(out: Path) -> dict:
    """The measured spreads behind the tolerances (module docstring) of one census."""
    answer = json.loads((out / "attractors.json").read_text())
    res: dict = {"census": str(out), "meshes": {}}
    for n in answer["members"]:
        rows = [r for r in answer["starts"] if str(r["n_inner"]) == n and r.get("features")]
        members: dict[str, list[dict]] = {}
        for r in rows:
            if r["class"] in ("wave", "multi-wave", "transient"):
                members.setdefault(r["member"], []).append(r)
        across = {m: {"starts": len(rs), **_spread([_feature_values(r["features"])
                                                     for r in rs])}
                  for m, rs in members.items() if len(rs) > 1}
        windows: dict[str, dict] = {}
        for label, classes in (("settled", ("wave", "multi-wave", "transient")),
                               ("unsettled", ("unsettled",))):
            per = [_spread([_feature_values(r["features_before"]),
                            _feature_values(r["features"])])
                   for r in rows if r["class"] in classes and r.get("features_before")]
            windows[label] = {q: max((p[q] for p in per), default=None)
                              for q in ("celerity_rel", "share_abs", "fraction_abs",
                                        "rms_rel")}
            windows[label]["starts"] = len(per)
        gaps = []
        by_dominant: dict[tuple, list[dict]] = {}
        for rs in members.values():
            top = rs[0]["features"]["components"][0]
            by_dominant.setdefault((top["k"], top["direction"]), []).append(rs[0])
        for key, firsts in by_dominant.items():
            for i, a in enumerate(firsts):
                for b in firsts[i + 1:]:
                    gaps.append({"dominant": f"k{key[0]} {key[1]}", "members": [
                        a["member"], b["member"]], **_spread([_feature_values(a["features"]),
                                                              _feature_values(b["features"])])})
        res["meshes"][n] = {"across_starts": across, "between_windows": windows,
                            "between_members": gaps}
    return res


#: µs per step of a batch of B columns at N = 528 (damped tutorial scene, this 2-core
#: machine: ``benchmarks/small_batches.py``, µs per scene-step × B); B between two
#: measured widths takes the wider one's per-scene cost (smaller: the bound stays a bound).
STEP_US = {1: 244.0, 2: 2 * 264.0, 3: 3 * 230.0, 4: 4 * 169.0, 8: 8 * 130.0}


def step_us(width: int) -> float:
    """µs per step of a batch of ``width`` columns (``STEP_US``)."""
    wider = min((b for b in STEP_US if b >= width), default=max(STEP_US))
    return STEP_US[wider] / wider * width


def step_bound(log: Path, dt: float, ranks: int = 2, starts: int = 16) -> dict:
    """A lower bound of a census's time loop on ``ranks`` ranks from its printed output
    ``log``: the first leg (``starts`` starts, as many per rank as fit, to the first
    continuation's start time) and every ``settle: continuing`` leg, each costing the
    steps of its busier rank at ``step_us`` of that rank's batch. A leg whose starts stand
    at different times runs one batch per end time: its fewest scene-steps (one start per
    printed span, the others on the shortest) over the ranks at the cost of a batch of one,
    the cheapest per column there."""
    legs = []
    first_end = None
    for line in log.read_text().splitlines():
        m = re.match(r"settle: continuing (\d+) start\(s\).*?\) (.*)$", line)
        if not m:
            continue
        n = int(m.group(1))
        spans = [(float(a), float(b)) for a, b in re.findall(r"([\d.]+) -> ([\d.]+) s",
                                                                 m.group(2))]
        first_end = spans[0][0] if first_end is None else first_end
        if len(spans) == 1:
            steps = (spans[0][1] - spans[0][0]) / dt
            seconds = steps * step_us(math.ceil(n / ranks)) * 1e-6
            legs.append({"starts": n, "span_s": spans[0], "scene_steps": n * steps,
                         "bound_s": seconds})
        else:  # one start on each span, the others on the shortest (the fewest steps)
            lengths = sorted(b - a for a, b in spans)
            steps = (sum(lengths) + (n - len(spans)) * lengths[0]) / dt
            legs.append({"starts": n, "span_s": spans, "scene_steps": steps,
                         "bound_s": steps / ranks * step_us(1) * 1e-6})
    if first_end is None:
        raise SystemExit(f"{log}: no 'settle: continuing' line (a census's printed output)")
    first = first_end / dt
    legs.insert(0, {"starts": starts, "span_s": (0.0, first_end), "scene_steps": starts * first,
                    "bound_s": first * step_us(math.ceil(starts / ranks)) * 1e-6})
    return {"legs": legs, "scene_steps": sum(g["scene_steps"] for g in legs),
            "bound_s": sum(g["bound_s"] for g in legs), "step_us": STEP_US, "dt_s": dt}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="figure1_n132_damped")
    ap.add_argument("--starts", type=int, default=64)
    ap.add_argument("--meshes", default="132,264")
    ap.add_argument("--end-time", type=float, default=0.3)
    ap.add_argument("--max-time", type=float, default=None)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--no-certify", action="store_true")
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("-o", "--output", help="census directory (default: a fresh temporary one)")
    ap.add_argument("--from", dest="existing", help="measure a finished census directory")
    ap.add_argument("--samples", metavar="DIR",
                    help="CPU time of deflated vs stored samples of a finished census")
    ap.add_argument("--spreads", nargs="+", metavar="DIR",
                    help="print the feature spreads of finished census directories")
    ap.add_argument("--step-bound", metavar="LOG",
                    help="the time loop's lower bound from a census's printed output")
    ap.add_argument("--dt", type=float, default=5.068e-6,
                    help="the rung's step (s), with --step-bound (default: N = 528's)")
    args = ap.parse_args()
    if args.step_bound:
        print(json.dumps(step_bound(Path(args.step_bound), args.dt, args.ranks)))
        return
    if args.spreads:
        for d in args.spreads:
            print(json.dumps(spreads(Path(d)), indent=1))
        return
    if args.samples:
        print(json.dumps(samples_ab(Path(args.samples))))
        return
    if args.existing:
        print(json.dumps(measure(Path(args.existing))))
        return
    out = Path(args.output) if args.output else Path(tempfile.mkdtemp(prefix="census-"))
    cmd = [sys.executable, "-m", "stickslip.cli.main", "attractors", args.scene, "--starts",
           str(args.starts), "--meshes", args.meshes, "--end-time", str(args.end_time),
           "-o", str(out / "census"), "--progress", "lines"]
    cmd += [a for kv in args.set for a in ("--set", kv)]
    if args.max_time is not None:
        cmd += ["--max-time", str(args.max_time)]
    if args.no_certify:
        cmd.append("--no-certify")
    if args.ranks > 1:
        cmd = ["mpirun", "-n", str(args.ranks), *cmd]
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)  # the command and its ranks
    if res.returncode not in (0, 1):
        sys.exit(f"census failed ({res.returncode}): {res.stderr.strip()[-500:]}")
    rec = measure(out / "census")
    rec.update(wall_s=wall, cpu_s=usage.ru_utime + usage.ru_stime,
               command=" ".join(cmd[cmd.index("attractors"):]),
               load_before=load_before, load_after=os.getloadavg(), cpus=os.cpu_count())
    print(json.dumps(rec))


if __name__ == "__main__":
    main()
