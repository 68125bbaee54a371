"""Proof that a change of the code changed no number: the same runs before and after, compared.

    git worktree add /tmp/before <commit>     # the code before the change
    (cd /tmp/before && ./dev python3 benchmarks/same_bits.py run /tmp/bits_before)
    ./dev python3 benchmarks/same_bits.py run /tmp/bits_after
    ./dev python3 benchmarks/same_bits.py compare /tmp/bits_before /tmp/bits_after

``run DIR`` runs, from the repository it is called in, one small case of every path a
refactor of the explicit path can touch (``CASES``): single runs with the numba and numpy
kernels, implicit, damped (both kernels), Prakash-Clifton, the 1-2-1 filtered bound, fields,
a 3D tube (serial and ``mpirun -n 2``), a diverging run, damped runs (numba, numpy) and an
implicit run under ``mpirun -n 2``, a batched sweep, two censuses under ``mpirun -n 2``
(settle legs with batches of one, two and three), a census with kicks, and three
continuations (``CONTINUED``).
About 2 minutes on 2 cores.

``compare A B`` then checks every ``.npz`` array bitwise (shape, dtype, values; NaN equal to
NaN) and every JSON file equal after dropping what differs from run to run: wall times and
other timers (``TIMERS``, and a printed answer's ``time:`` line), dates and absolute paths,
and the write times inside the census caches' keys. It prints each difference and exits 1
if there is one.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

SMOKE = "scenes/smoke.toml"
DAMPED = "scenes/figure1_n132_damped.toml"
SHORT = ("--set", "time.end_time=0.01")
DAMPED_SHORT = ("--set", "time.end_time=0.004")
TUBE3D = "scenes/tube3d_figure3_damped.toml"
TUBE3D_SHORT = ("--set", "mesh.n_inner=32", "--set", "mesh.n_axial=3", "--set",
                "time.end_time=0.002")
CENSUS = ("--meshes", "36", "--end-time", "0.03", "--max-time", "0.1", "--yes-i-know")
#: name: (command line after ``stickslip``, ranks); ``{out}`` is the case's directory.
CASES: dict[str, tuple[tuple[str, ...], int]] = {
    "numba": (("run", SMOKE, *SHORT), 1),
    "numpy": (("run", SMOKE, *SHORT, "--set", 'time.kernel="numpy"'), 1),
    "implicit": (("run", SMOKE, *SHORT, "--set", "time.beta1=0.25", "--set",
                  "time.beta2=0.5", "--set", "time.dt_fraction=2"), 1),
    "damped": (("run", DAMPED, *DAMPED_SHORT), 1),
    "damped_numpy": (("run", DAMPED, *DAMPED_SHORT, "--set", 'time.kernel="numpy"'), 1),
    "prakash_clifton": (("run", SMOKE, *SHORT, "--set",
                         'friction.regularization="prakash-clifton"', "--set",
                         "friction.slip_length=2e-5", "--set",
                         "friction.reference_velocity=0.1"), 1),
    "filtered": (("run", SMOKE, *SHORT, "--set", 'friction.filter="1-2-1"'), 1),
    "fields": (("run", SMOKE, *SHORT, "--set", "output.fields=true"), 1),
    "diverging": (("run", SMOKE, *SHORT, "--set", "initial.amplitude=1e200"), 1),
    "mpi2": (("run", DAMPED, *DAMPED_SHORT), 2),
    "numpy_mpi2": (("run", DAMPED, *DAMPED_SHORT, "--set", 'time.kernel="numpy"'), 2),
    "implicit_mpi2": (("run", SMOKE, *SHORT, "--set", "time.beta1=0.25", "--set",
                       "time.beta2=0.5", "--set", "time.dt_fraction=2"), 2),
    "tube3d": (("run", TUBE3D, *TUBE3D_SHORT), 1),
    "tube3d_mpi2": (("run", TUBE3D, *TUBE3D_SHORT), 2),
    "sweep": (("sweep", "{sweep_file}"), 1),
    "census5": (("attractors", DAMPED, "--starts", "5", *CENSUS), 2),
    "census3": (("attractors", DAMPED, "--starts", "3", *CENSUS), 2),
    "census_kicks": (("attractors", SMOKE, "--starts", "3", "--meshes", "36", "--end-time",
                      "0.05", "--max-time", "0.1", "--set", "loading.omega=20", "--set",
                      "geometry.delta=0.005"), 1),
}
#: The runs continued from their checkpoints (numba, numpy, the 3D tube) and until when.
CONTINUED = {"damped": "0.006", "damped_numpy": "0.006", "tube3d": "0.003"}
SWEEP = """name = "same-bits"
base = "damped.toml"
group_size = 1
set = ["time.end_time = 0.004"]
[grid]
"loading.omega" = [50.0, 60.0, 70.0]
"""
#: JSON keys that hold timers, dates or paths: left out of the comparison.
TIMERS = re.compile(r"(wall|seconds|compile|first_call|_mus$|rss|elapsed|profile|^start$|"
                    r"^started$|^updated$|^finished|written|^date|sweep_file|^contact_s$|solves_s$|"
                    r"factorisation_s$|certification_s$|^kick_s$|^chaos_s$|^features_s$|"
                    r"^sweep_s$|^runs_s$|^loop_s$|^timing$|^eta)")
#: the census caches' keys carry the summary's write time: ``id@<time>@...``
STAMP = re.compile(r"@[0-9.]+@")


def run(out: Path) -> int:
    """Every case of ``CASES`` into ``out``; the exit status of each in ``out/status.json``."""
    if out.exists():
        raise SystemExit(f"error: {out} exists: give a new directory (the runs are never "
                         "written over an earlier proof)")
    out.mkdir(parents=True)
    (out / "damped.toml").write_text(Path(DAMPED).read_text())  # the sweep's base, beside it
    (out / "sweep.toml").write_text(SWEEP)
    status = {}
    for name, (args, ranks) in CASES.items():
        args = tuple(a.format(sweep_file=out / "sweep.toml") for a in args)
        cmd = (["mpirun", "-n", str(ranks)] if ranks > 1 else []) + [
            sys.executable, "-m", "stickslip.cli.main", *args, "-o", str(out / name)]
        with open(out / f"{name}.log", "w") as log:
            status[name] = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT).returncode
        print(f"{name}: exit {status[name]}", flush=True)
    for name, until in CONTINUED.items():
        subprocess.run([sys.executable, "-m", "stickslip.cli.main", "continue",
                        str(out / name), "--until", until], stdout=subprocess.DEVNULL,
                       check=True)
    (out / "status.json").write_text(json.dumps(status, indent=2))
    return 0


def _plain(value: object, roots: tuple[str, ...]) -> object:
    """``value`` without timers, with the roots of the two trees and the cache stamps
    replaced by placeholders."""
    if isinstance(value, dict):
        return {STAMP.sub("@T@", k): _plain(v, roots) for k, v in value.items()
                if not TIMERS.search(k)}
    if isinstance(value, list):
        return [_plain(v, roots) for v in value]
    if isinstance(value, str):  # a printed answer: its line of wall times left out
        for root in roots:
            value = value.replace(root, "ROOT")
        return "\n".join(x for x in value.split("\n") if not x.startswith("time: "))
    return value


def _differences(a: object, b: object, path: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)
                for d in _differences(a.get(k), b.get(k), f"{path}/{k}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) if x != y
                for d in _differences(x, y, f"{path}[{i}]")]
    return [f"{path}: {str(a)[:80]} != {str(b)[:80]}"]


def compare(a_dir: Path, b_dir: Path) -> int:
    """Every .npz array bitwise and every JSON file equal but timers (module docstring)."""
    roots = tuple(sorted({str(a_dir.resolve()), str(b_dir.resolve()), str(a_dir), str(b_dir)},
                         key=len, reverse=True))
    files_a = {p.relative_to(a_dir) for p in a_dir.rglob("*") if p.suffix in (".npz", ".json")}
    files_b = {p.relative_to(b_dir) for p in b_dir.rglob("*") if p.suffix in (".npz", ".json")}
    bad = [f"only in {a_dir if p in files_a else b_dir}: {p}" for p in sorted(files_a ^ files_b)]
    arrays = 0
    for rel in sorted(files_a & files_b):
        if rel.suffix == ".npz":
            with np.load(a_dir / rel) as x, np.load(b_dir / rel) as y:
                if sorted(x.files) != sorted(y.files):
                    bad.append(f"{rel}: arrays {sorted(set(x.files) ^ set(y.files))}")
                    continue
                for key in x.files:
                    arrays += 1
                    u, v = x[key], y[key]
                    if (u.dtype != v.dtype or u.shape != v.shape
                            or not np.array_equal(u, v, equal_nan=u.dtype.kind in "fc")):
                        bad.append(f"{rel}: {key} differs")
        else:
            ja = _plain(json.loads((a_dir / rel).read_text()), roots)
            jb = _plain(json.loads((b_dir / rel).read_text()), roots)
            bad += [f"{rel}{d}" for d in _differences(ja, jb)]
    for line in bad:
        print(line)
    n_json = sum(1 for p in files_a & files_b if p.suffix == ".json")
    print(f"{arrays} arrays and {n_json} JSON files compared: {len(bad)} difference(s)")
    return 1 if bad else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    sub.add_parser("run").add_argument("out", type=Path)
    cmp = sub.add_parser("compare")
    cmp.add_argument("before", type=Path)
    cmp.add_argument("after", type=Path)
    args = ap.parse_args()
    if args.what == "compare":
        for d in (args.before, args.after):
            if not d.is_dir():
                raise SystemExit(f"error: {d} is not a directory: give two trees of "
                                 "`same_bits.py run`")
        return compare(args.before, args.after)
    return run(args.out)


if __name__ == "__main__":
    sys.exit(main())
