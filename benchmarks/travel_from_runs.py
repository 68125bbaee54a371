"""Does ``stickslip travel`` converge from every settled run, and does it agree with the run?

``./dev nice python3 benchmarks/travel_from_runs.py OUT [--make] [--solve] [--dt-limit]``

``--make`` writes three sweep files into OUT and runs them with ``stickslip sweep --batch
auto`` (batched transients, resumable: a second ``--make`` runs only what is missing):

* ``n132``: the damped Figure-1 scene (scenes/figure1_n132_damped.toml: β₂ = 1/2, η = 2 % at
  1.6 kHz, N = 132, dt = 0.9 dt_crit) at five scene points, each from five starts: random
  (modes 1 … 16, 0.1 d, seeds 0, 1, 2) and mode 4 and mode 8 bumps (0.1 d); 0.3 s;
* ``n264``: the same five points on N = 264, from random seed 0 and the mode-4 and mode-8
  bumps; 0.3 s;
* ``undamped``: the paper's undamped Figure-3 scene (scenes/figure3_n132.toml, β₂ = 0.6) from
  the mode-4 bump and random seeds 0, 1; 0.3 s.

The points (Ω rad/s, δ, f), fixed before any result was seen: the damped Figure-1 scene (40,
1e-3, 0.7) and the damped Figure-3 scene (50, 4e-4, 0.7) of the paper, and (60, 8e-4, 0.6),
(100, 5e-4, 0.5), (25, 1.5e-3, 0.8).

``--solve`` calls ``studies.travel.wave_from_run`` on every finished run and writes one JSON
line per run to OUT/travel_from_runs.jsonl (the run, the wave, their differences, the CPU
time of the solve) and prints the table: per run set, the runs whose end state is a rigid
travelling wave, the share of them that converges, the largest celerity, fraction, ψ and
amplitude differences, split by whether the wave crosses less or more than one node per
step. ``--dt-limit`` adds the Δt → 0 wave (``wave_from_run(dt_limit=True)``).
Exit status 1 if a rigid end state did not converge.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

POINTS = [(40.0, 1e-3, 0.7), (50.0, 4e-4, 0.7), (60.0, 8e-4, 0.6), (100.0, 5e-4, 0.5),
          (25.0, 1.5e-3, 0.8)]
STARTS_132 = [("random", 0), ("random", 1), ("random", 2), ("mode", 4), ("mode", 8)]
STARTS_264 = [("random", 0), ("mode", 4), ("mode", 8)]
STARTS_UNDAMPED = [("mode", 4), ("random", 0), ("random", 1)]


def _start(kind: str, value: int) -> dict:
    if kind == "random":
        return {"initial.perturbation": "random", "initial.seed": value,
                "initial.amplitude": 0.1}
    return {"initial.perturbation": "mode", "initial.mode": value, "initial.amplitude": 0.1}


def _toml_value(v) -> str:
    return json.dumps(v) if isinstance(v, str) else repr(v)


def sweep_file(name: str, base: str, sets: list[str], points: list[dict]) -> str:
    """A sweep file (``studies.sweep.spec``) with ``[[points]]``."""
    lines = [f'name = "{name}"', f'base = "{base}"', "group_size = 1", 'batch = "auto"',
             "set = [" + ", ".join(json.dumps(s) for s in sets) + "]"]
    for pt in points:
        lines.append("[[points]]")
        lines += [f'"{key}" = {_toml_value(v)}' for key, v in pt.items()]
    return "\n".join(lines) + "\n"


def sweeps() -> dict[str, str]:
    """The three sweep files (module doc), by name."""
    root = Path(__file__).resolve().parents[1] / "scenes"

    def damped(starts):
        return [{"loading.omega": om, "geometry.delta": de, "loading.f": f, **_start(*s)}
                for om, de, f in POINTS for s in starts]

    return {
        "n132": sweep_file("travel_n132", str(root / "figure1_n132_damped.toml"),
                           ["time.end_time=0.3"], damped(STARTS_132)),
        "n264": sweep_file("travel_n264", str(root / "figure1_n132_damped.toml"),
                           ["time.end_time=0.3", "mesh.n_inner=264"], damped(STARTS_264)),
        "undamped": sweep_file("travel_undamped", str(root / "figure3_n132.toml"),
                               ["time.end_time=0.3"],
                               [_start(*s) for s in STARTS_UNDAMPED]),
    }


def make(out: Path) -> int:
    """Write and run the sweeps (module doc); the exit status of the last failing sweep."""
    out.mkdir(parents=True, exist_ok=True)
    rc = 0
    for name, text in sweeps().items():
        path = out / f"{name}.toml"
        path.write_text(text)
        r = subprocess.run(["stickslip", "sweep", str(path), "--batch", "auto",
                            "--progress", "lines", "-o", str(out / name)], check=False)
        rc = rc or r.returncode
    return rc


def solve(out: Path, dt_limit: bool) -> int:
    """``wave_from_run`` on every finished run of OUT (module doc)."""
    from stickslip.studies.travel import NotRigidWave, wave_from_run

    rows = []
    for run in sorted(out.glob("*/runs/*")):
        if not (run / "samples.npz").is_file():
            continue
        t0 = time.process_time()
        row: dict = {"set": run.parent.parent.name, "run_dir": run.name}
        try:
            row.update(wave_from_run(run, dt_limit=dt_limit))
        except NotRigidWave as err:
            row.update(converged=None, message=str(err))
        except ValueError as err:  # no wave at all (steady sliding, diverged)
            row.update(converged=None, message=str(err))
        row["cpu_s"] = round(time.process_time() - t0, 2)
        rows.append(row)
        print(json.dumps(_short(row)), flush=True)
    from stickslip.solver.atomic import atomic_write_text

    atomic_write_text(out / "travel_from_runs.jsonl",
                      "".join(json.dumps(r, default=float) + "\n" for r in rows))
    print(table(rows))
    return 1 if any(r["converged"] is False for r in rows) else 0


def _short(row: dict) -> dict:
    keys = ("set", "run_dir", "converged", "k", "celerity_m_s", "samples", "frame_spread",
            "difference", "cpu_s", "message")
    return {k: row.get(k) for k in keys}


def table(rows: list[dict]) -> str:
    """Per run set and crossing (< or > one node per step): rigid runs, converged share, the
    largest differences (celerity and amplitude relative, fractions and ψ absolute)."""
    lines = ["set       crossing  runs rigid converged  max|dc/c|  max|dfrac|  max|dpsi|  "
             "max|dA/A|  cpu_s(median)"]
    for name in sorted({r["set"] for r in rows}):
        for fast in (False, True):
            sel = [r for r in rows if r["set"] == name and r.get("converged") is not None
                   and (r["node_passage_s"] < r["dt_s"]) == fast]
            if not sel:
                continue
            ok = [r for r in sel if r["converged"]]
            d = [r["difference"] for r in ok]

            def worst(key, d=d):
                return max((abs(x[key]) for x in d), default=float("nan"))

            cpu = sorted(r["cpu_s"] for r in ok)
            lines.append(
                f"{name:9s} {'>1 node' if fast else '<1 node':9s} "
                f"{sum(r['set'] == name for r in rows):4d} {len(sel):5d} {len(ok):9d}  "
                f"{worst('celerity_rel'):9.2e}  {worst('fractions_abs'):10.4f}  "
                f"{worst('psi_abs'):9.4f}  {worst('amplitude_rel'):9.2e}  "
                f"{cpu[len(cpu) // 2] if cpu else float('nan'):.2f}")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--make", action="store_true")
    ap.add_argument("--solve", action="store_true")
    ap.add_argument("--dt-limit", action="store_true")
    a = ap.parse_args()
    if not (a.make or a.solve):
        ap.error("give --make, --solve or both")
    rc = make(a.out) if a.make else 0
    return (solve(a.out, a.dt_limit) if a.solve else 0) or rc


if __name__ == "__main__":
    sys.exit(main())
