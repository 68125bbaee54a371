"""Certify a census's wave members from single CPU runs, and run chosen starts longer.

A census computed elsewhere (``benchmarks/gpu_census.py``: ``rows.jsonl``, one row per start,
with the ``scene`` of each row) names its members per scene and mesh the way ``stickslip
attractors`` does (``studies.attractors.classify.group_members`` over every row of one mesh,
celerity tolerance ``CELERITY_TOL``). For every wave member this script

1. reruns the member's first random start (lowest seed) as one ``stickslip run`` on the CPU,
   the same scene, mesh, start and end time (the start is rebuilt from its seed by
   ``solver.columns.initial_perturbation``), and classifies it with ``classify.start_row``: its
   class, member and celerity next to the census row's (relative difference);
2. certifies that run with ``studies.attractors.certify.certify``: the direct solver's wave at
   the run's step (residual, difference to the transient), its Δt → 0 value on that mesh and
   whether a transient started next to it keeps it (where the finer levels of the Δt → 0
   wave have none, the wave at the run's step stands; where the matched step exceeds
   Δt_crit, stability is tested at S' = ceil(τ/Δt): ``certify``'s own rules).

``--extend SCENE:N:MEMBER=COUNT`` (repeatable) also runs the COUNT lowest-seed random starts
of MEMBER (e.g. ``unsettled-k14-opposite-SSS``) at mesh N on to ``--extend-end-time`` and
classifies their end states with the census's classifier.

Results go to ``OUT/certificates.json`` (resumable: a finished run or certificate is not
computed again) and are printed as Markdown tables::

    ./dev python3 benchmarks/certify_census.py OUT/rows.jsonl --out runs/certify --meshes 132,264
    ./dev python3 benchmarks/certify_census.py OUT/rows.jsonl --out runs/certify --meshes 528 \\
        --dt-limit-max-size 2000 \\
        --extend figure1_n132_damped:528:unsettled-k14-opposite-SSS=2 \\
        --extend figure3_n132_damped:528:modulated-k11-opposite-SSS=1 \\
        --extend figure3_n132_damped:528:unsettled-k11-opposite-SSS=1
    ./dev python3 benchmarks/certify_census.py OUT/rows.jsonl --out runs/certify --table
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stickslip.studies.attractors.classify import (  # noqa: E402
    CELERITY_TOL,
    _radius,
    group_members,
    start_row,
)


def load_rows(path: Path) -> dict[tuple[str, int], list[dict]]:
    """The census rows by (scene, mesh), each mesh grouped into members as the census does."""
    by_mesh: dict[tuple[str, int], list[dict]] = {}
    for line in path.read_text().splitlines():
        if line.strip():
            row = json.loads(line)
            by_mesh.setdefault((row["scene"], int(row["n_inner"])), []).append(row)
    for rows in by_mesh.values():
        group_members(rows, CELERITY_TOL)
    return by_mesh


def first_starts(rows: list[dict], member: str, count: int = 1) -> list[dict]:
    """The ``count`` random starts of lowest seed whose end state is ``member``."""
    mine = [r for r in rows if r["start"] == "random" and r["member"] == member]
    return sorted(mine, key=lambda r: int(r["seed"]))[:count]


def run_start(scene: str, n: int, seed: int, end_time: float, run_dir: Path) -> dict:
    """One ``stickslip run`` of the random start ``seed`` (skipped if already finished)."""
    summary_path = run_dir / "summary.json"
    if summary_path.is_file():
        summary = json.loads(summary_path.read_text())
        if summary.get("status") == "completed" and abs(
                float(summary.get("sim_time_s", 0.0)) - end_time) < 1e-3:
            return summary
    cmd = ["stickslip", "run", str(REPO / "scenes" / f"{scene}.toml"),
           "--set", f"mesh.n_inner={n}", "--set", 'initial.perturbation="random"',
           "--set", f"initial.seed={seed}", "--set", f"time.end_time={end_time!r}",
           "-o", str(run_dir), "--force"]
    print("$", " ".join(cmd), flush=True)
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(cmd, check=True)
    return json.loads(summary_path.read_text())


def cpu_row(run_dir: Path, n: int, seed: int, summary: dict) -> dict:
    """The run's end state as a census row (``classify.start_row``), with its member."""
    params = {"mesh.n_inner": n, "initial.perturbation": "random", "initial.seed": seed,
              "initial.mode": None}
    row = start_row(run_dir, params, summary, summary.get("status", "failed"))
    group_members([row], CELERITY_TOL)
    return row


def relative(a: float | None, b: float | None) -> float | None:
    if a is None or b is None or not b:
        return None
    return float(a) / float(b) - 1.0


def finest_level_size(row: dict, radius: float = 1.0) -> int:
    """Rows of the dense Newton system at the Δt → 0 wave's finest level (4S points per
    node): 2·4S·N/p + 1, p = k where k divides 4S·N (the wave folded onto one wavelength,
    ``studies.travel.driver.folded``), else 1; S = round(τ/Δt), τ = 2πR/(N|c|) the node
    passage of the row's wave. Its cost grows as the cube."""
    n, k = int(row["n_inner"]), int(row["k"])
    tau = 2.0 * math.pi * radius / (n * abs(float(row["celerity_m_s"])))
    points = 4 * max(1, round(tau / float(row["dt_s"]))) * n
    return 2 * points // (k if points % k == 0 else 1) + 1


def certify_member(scene: str, n: int, census_row: dict, end_time: float, out: Path,
                   dt_limit: bool = True) -> dict:
    """Rerun, classify and certify one member's first start (module docstring, 1 and 2)."""
    from stickslip.studies.attractors.certify import certify

    seed = int(census_row["seed"])
    run_dir = out / scene / f"n{n}_seed{seed}"
    summary = run_start(scene, n, seed, end_time, run_dir)
    row = cpu_row(run_dir, n, seed, summary)
    t0 = time.perf_counter()
    cert = certify(run_dir, dt_limit=dt_limit)
    return {"scene": scene, "n_inner": n, "seed": seed, "member": census_row["member"],
            "census": _brief(census_row), "cpu": _brief(row),
            "celerity_rel": relative(row["celerity_m_s"], census_row["celerity_m_s"]),
            "spread_rel": relative(row["frame_spread"], census_row["frame_spread"]),
            "dt_s": summary.get("dt_s"), "steps": summary.get("steps"),
            "run_wall_s": summary.get("wall_time_s"),
            "certify_wall_s": time.perf_counter() - t0, "certificate": cert,
            "radius": _radius(run_dir)}


def extend_start(scene: str, n: int, census_row: dict, end_time: float, out: Path) -> dict:
    """Run one start on to ``end_time`` and classify it (module docstring, ``--extend``)."""
    seed = int(census_row["seed"])
    run_dir = out / scene / f"n{n}_seed{seed}_t{end_time:g}"
    summary = run_start(scene, n, seed, end_time, run_dir)
    row = cpu_row(run_dir, n, seed, summary)
    return {"scene": scene, "n_inner": n, "seed": seed, "end_time_s": end_time,
            "census": _brief(census_row), "longer": _brief(row), "dt_s": summary.get("dt_s"),
            "steps": summary.get("steps"), "run_wall_s": summary.get("wall_time_s")}


def _brief(row: dict) -> dict:
    return {k: row.get(k) for k in ("class", "member", "k", "direction", "regime",
                                    "celerity_m_s", "frequency_hz", "psi1", "psi2",
                                    "frame_spread", "spread_trend", "limit_cycle")}


def _fmt(x: float | None, spec: str) -> str:
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(
        x, spec)


def certificate_table(results: list[dict]) -> str:
    """Markdown: member, mesh, start, transient celerity census vs CPU, solver, Δt → 0."""
    lines = ["| scene | N | member | seed | c census (m/s) | CPU/census − 1 | c solver (m/s), "
             "S, h/Δt | residual | solver/run − 1 | c Δt→0 (m/s), order | run's Δt error | "
             "stable (drift) |", "|" + "---|" * 12]
    for r in sorted(results, key=lambda r: (r["scene"], r["n_inner"], r["member"])):
        cert = r["certificate"]
        at, lim = cert.get("at_dt", {}), cert.get("dt_to_0") or {}
        diff = at.get("difference") or {}
        if lim.get("celerity_m_s") is not None:
            limit = f"{lim['celerity_m_s']:.1f}, {_fmt(lim.get('order'), '.2f')}"
        else:
            limit = "no wave at 2S/4S" if lim.get("message") else "not computed"
        stable = {True: "yes", False: "no"}.get(cert.get("stable"), "–")
        if cert.get("drift"):
            stable += f" ({cert['drift']['celerity_rel']:.0e})"
        if cert.get("stability_samples"):
            stable += f", S' = {cert['stability_samples']}"
        if not at.get("converged"):
            stable = at.get("message", "no wave")[:60]
        rel = r["celerity_rel"]
        # h/Δt = τ/(S Δt), τ = 2πR/(N|c|): the solver's step against the run's
        tau = 2.0 * math.pi * r.get("radius", 1.0) / (
            r["n_inner"] * abs(float(r["census"]["celerity_m_s"])))
        ratio = tau / (at["samples"] * float(r["dt_s"])) if at.get("samples") else None
        lines.append(
            f"| {r['scene'].split('_')[0]} | {r['n_inner']} | {r['member']} | {r['seed']} | "
            f"{_fmt(r['census']['celerity_m_s'], '.2f')} | "
            f"{'0' if rel == 0.0 else _fmt(rel, '.0e')} | "
            f"{_fmt(at.get('celerity_m_s'), '.2f')}, {at.get('samples', '–')}, "
            f"{_fmt(ratio, '.2f')} | "
            f"{_fmt(at.get('residual'), '.0e')} | "
            f"{_fmt(_pct(diff.get('celerity_rel')), '+.2f')} % | {limit} | "
            f"{_fmt(_pct(lim.get('run_dt_error')), '+.2f')} % | {stable} |")
    return "\n".join(lines).replace("– %", "–")


def extend_table(results: list[dict]) -> str:
    """Markdown: the longer runs' end states (member, celerity, frame spread and its trend)
    next to the census's."""
    lines = ["| scene | N | seed | census, 2 s: member, c (m/s), spread, trend | t_end | "
             "longer run: member, c (m/s), spread, trend |", "|" + "---|" * 6]
    for r in results:
        cells = [f"{x['member']}, {_fmt(x['celerity_m_s'], '.2f')}, "
                 f"{_fmt(x['frame_spread'], '.3f')}, {_fmt(_pct(x['spread_trend']), '+.0f')} %"
                 for x in (r["census"], r["longer"])]
        lines.append(f"| {r['scene'].split('_')[0]} | {r['n_inner']} | {r['seed']} | "
                     f"{cells[0]} | {r['end_time_s']:g} s | {cells[1]} |")
    return "\n".join(lines)


def _pct(x: float | None) -> float | None:
    return None if x is None else 100.0 * x


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("rows", type=Path, help="the census rows (JSON lines, with 'scene')")
    p.add_argument("--out", type=Path, default=Path("runs/certify"), help="runs and results")
    p.add_argument("--meshes", default="132,264,528", help="meshes whose members to certify")
    p.add_argument("--end-time", type=float, default=2.0, help="the census's end time (s)")
    p.add_argument("--dt-limit-max-size", type=int, default=10**9,
                   help="largest dense Newton system (finest_level_size) of the Δt → 0 "
                   "wave's 4S level; members above it get the wave at the run's step only")
    p.add_argument("--extend", action="append", default=[], metavar="SCENE:N:MEMBER=COUNT",
                   help="run the COUNT lowest-seed starts of MEMBER at mesh N on (repeatable)")
    p.add_argument("--extend-end-time", type=float, default=4.0, help="their end time (s)")
    p.add_argument("--table", action="store_true", help="only print the tables of OUT")
    args = p.parse_args(argv)
    results_path = args.out / "certificates.json"
    done = json.loads(results_path.read_text()) if results_path.is_file() else {}
    if not args.table:
        by_mesh = load_rows(args.rows)
        meshes = [int(n) for n in args.meshes.split(",") if n]
        for (scene, n), rows in sorted(by_mesh.items(), key=lambda kv: (kv[0][1], kv[0][0])):
            if n not in meshes:
                continue
            waves = sorted({r["member"] for r in rows if r["class"] == "wave"
                            and r["start"] == "random"})
            for member in waves:
                key = f"{scene}:{n}:{member}"
                if key not in done:
                    row = first_starts(rows, member)[0]
                    size = finest_level_size(row)
                    done[key] = certify_member(scene, n, row, args.end_time, args.out,
                                               dt_limit=size <= args.dt_limit_max_size)
                    done[key]["finest_level_size"] = size
                    _save(results_path, done)
        for spec in args.extend:
            where, count = spec.rsplit("=", 1)
            scene, n, member = where.split(":", 2)
            for row in first_starts(by_mesh[(scene, int(n))], member, int(count)):
                key = f"extend:{scene}:{n}:{row['seed']}:{args.extend_end_time:g}"
                if key not in done:
                    done[key] = extend_start(scene, int(n), row, args.extend_end_time,
                                             args.out)
                    _save(results_path, done)
    certs = [v for k, v in done.items() if not k.startswith("extend:")]
    longer = [v for k, v in done.items() if k.startswith("extend:")]
    print(certificate_table(certs))
    if longer:
        print()
        print(extend_table(longer))
    return 0


def _save(path: Path, done: dict) -> None:
    from stickslip.solver.atomic import atomic_write_text

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(done, indent=1, default=str) + "\n")


if __name__ == "__main__":
    sys.exit(main())
