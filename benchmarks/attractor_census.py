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

The N = 528 rung of a 16-start census (the tutorial point, cap 4 s, certificates and the
chaos test; target 15 minutes on 2 cores): 41 minutes of wall time on the shared 2-core
machine (load 3 to 6), about 2000 CPU s over both ranks, so at least 17 minutes on an idle
one. Where it goes: 13 of 16 starts are unsettled at 0.3, 0.45 and 0.675 s and 10 at
1.01 s, so every start runs past 1 s (200 000 steps of Δt = 5.07 μs); the starts of two
members that did not return after their kick are continued to 1.5 s and certified again;
and each of the 2 starts unsettled at the cap gets a chaos test whose twin runs over the 13
windows of its last leg (1.3 s of two columns: 414 s for both). The target is not met.

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
import os
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
    args = ap.parse_args()
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
