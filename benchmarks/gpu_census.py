"""An attractor census on a GPU node that has no dolfinx: the batches of
``stickslip attractors``, run from files, classified there, answered here.

``stickslip attractors`` runs every start of a census as a scene of a sweep, with run
directories. A GPU node of this project has CuPy and numba but no FEniCSx, so this script
splits the same computation in three:

``prepare DIR SCENE...`` (here, where dolfinx is: ``./dev``)
    For each scene and mesh of the ladder: the batch's shared data (K, M, the contact nodes,
    dt, ``solver.ensemble.BatchedProblem``), steady sliding, the contact law's constants, the
    Kelvin-Voigt time, the recorder's layout (samples every ``output.sample_interval``, the
    probes), the dof coordinates and the clamped dofs, and the starts (the census's
    ``StartDistribution``: seeds, or mode k). The starts themselves are rebuilt on the node
    from the coordinates (``start_fields``: the bump of ``solver.run.initial_perturbation``,
    evaluated as ``TubeProblem.radial_field`` does), which keeps the files small; ``prepare``
    checks them against dolfinx's interpolation here (``max_start_diff``, round-off).
    ``DIR/SCENE/census.json`` is the census definition of ``stickslip attractors``.

``run DIR --out OUT`` (the node)
    Each batch through the project's one time loop (``solver.run.run_loop``) with the
    sweep's batch observers (``solver.ensemble_run.ProbeHook``, ``BatchSampling``: probes
    every step, samples, the energy guard, a blow-up masked and counted ``diverged``); every
    start's summary exactly as a run directory's (``postprocess.analysis.analyse``, as
    ``studies.rundir.scene_run.summarise``), its frame spread and trend, and its row
    (``studies.attractors.classify.end_state_row``) to ``OUT/rows.jsonl``, one write per
    batch; a rerun (after a kill) skips the batches whose rows are there. ``--check``
    first runs a few starts of the first batch on the CUDA kernel and on the numba kernel
    and compares the states bit for bit.

``answer DIR OUT --into CENSUS_DIR`` (here)
    ``studies.attractors.census.answer_of`` on the rows: members, shares with Wilson
    intervals, the ladder, the printed summary; ``attractors.json``, ``attractors.csv``,
    ``members.csv`` as ``stickslip attractors`` writes them.

Example (docs/attractors.md, "Census of the damped paper scenes")::

    ./dev python3 benchmarks/gpu_census.py prepare build/gpu_census \\
        scenes/figure1_n132_damped.toml scenes/figure3_n132_damped.toml \\
        --meshes 132,264,528 --starts 64 --structured 1:12 --end-time 2.0
    python3 benchmarks/gpu_census.py run build/gpu_census --out OUT --check   # GPU node
    ./dev python3 benchmarks/gpu_census.py answer build/gpu_census OUT --into runs/census
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

# The classification runs in one process per core (fork): each must use one BLAS thread, or
# 16 processes x 16 OpenBLAS threads oversubscribe a GPU node's cores (set before numpy loads
# its BLAS; a value given by the caller is kept).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


class CensusOffloadError(Exception):
    """Bad input of a stage (the message names the value and the fix)."""


# ------------------------------------------------------------------------ the starts


def start_fields(coords: np.ndarray, clamped: np.ndarray, R: float, xi: float, d: float,
                 start: dict, amplitude: float, n_modes: int) -> np.ndarray:
    """The bump of one start at the dofs, interleaved (x, y): A(θ) X(r) e_r with
    X(r) = (ξ² R / r − r / R) / (ξ² − 1) (paper eq. [1]) and A(θ) of
    ``solver.run.initial_perturbation`` ("mode": A d (1 + cos kθ)/2; "random": A d Σ_k w_k
    (1 + cos(kθ + φ_k))/2 from ``numpy.random.default_rng(seed)``), zero on clamped dofs;
    the operations of ``TubeProblem.radial_field``."""
    x, y = coords[:, 0], coords[:, 1]
    r = np.hypot(x, y)
    theta = np.arctan2(y, x)
    amp = amplitude * d
    if start["initial.perturbation"] == "mode":
        k = start["initial.mode"]
        a = amp * 0.5 * (1.0 + np.cos(k * theta))
    else:
        rng = np.random.default_rng(start["initial.seed"])
        ks = np.arange(1, n_modes + 1)
        weights = rng.uniform(0.0, 1.0, ks.size)
        phases = rng.uniform(0.0, 2 * np.pi, ks.size)
        weights /= weights.sum()
        s = np.zeros_like(theta)
        for k, w, ph in zip(ks, weights, phases, strict=True):
            s += w * 0.5 * (1.0 + np.cos(k * theta + ph))
        a = amp * s
    radial = a * (xi**2 * R / r - r / R) / (xi**2 - 1.0)
    out = np.empty(2 * x.size)
    out[0::2] = radial * x / r
    out[1::2] = radial * y / r
    out[clamped] = 0.0
    return out


# ----------------------------------------------------------------------- prepare (here)


def stage_prepare(args) -> None:
    from mpi4py import MPI

    from solver.contact import ContactLaw
    from solver.ensemble import BatchedProblem
    from solver.observers import InnerCircleRecorder, ProbeRecorder
    from solver.run import Simulation, initial_perturbation, planned_steps
    from studies.attractors.census import Census
    from studies.attractors.starts import StartDistribution, parse_meshes, parse_structured
    from studies.sweep.spec import _task_id

    meshes = parse_meshes(args.meshes)
    dist = StartDistribution(starts=args.starts, structured=parse_structured(args.structured))
    for scene_file in args.scenes:
        census = Census(Path(scene_file), meshes, dist,
                        overrides=(f"time.end_time={args.end_time!r}",))
        base = census.base_scene()
        out = args.directory / base.name
        out.mkdir(parents=True, exist_ok=True)
        meta = {"kind": "stickslip-attractors", "definition": census.definition(base),
                "scene_file": str(scene_file), "overrides": list(census.overrides),
                "meshes": list(meshes), "distribution": dist.to_dict(),
                "celerity_tol": census.celerity_tol, "spread_tol": census.spread_tol}
        (out / "census.json").write_text(json.dumps(meta, indent=1) + "\n")
        for n in meshes:
            points = dist.points((n,))
            scene = base.with_overrides(f"mesh.n_inner={n}", "output.progress=false")
            sim = Simulation(scene, MPI.COMM_SELF)
            p, sc = sim.problem, sim.scene
            law = ContactLaw.from_scene(sc, sim.dt)
            if not law.nodal_coulomb:
                raise SystemExit(f"{scene_file}: friction variant {law.variant!r} has no CUDA "
                                 "kernel; the census runs nodal Coulomb friction on the GPU")
            bp = BatchedProblem.from_problem(p, sim.dt, sc.time.beta2)
            shape = InnerCircleRecorder(p, sim.projection, None, 1, max_samples=0)
            probes = ProbeRecorder(p, sim.projection, sc.output.probes_deg, 0)
            coords = p.V.tabulate_dof_coordinates()[: p.n_owned // 2, :2]
            # the node rebuilds the starts: check the rebuild against dolfinx here
            diff = 0.0
            for point in points[:3] + points[-2:]:
                sc_k = sc.with_overrides(*(f"{k}={json.dumps(v)}" for k, v in point.items()))
                mine = start_fields(coords, p.clamped, sc.geometry.R, sc.geometry.xi,
                                    sc.geometry.d, point, dist.amplitude, dist.n_modes)
                diff = max(diff, float(np.max(np.abs(mine - initial_perturbation(p, sc_k)))))
            every = max(1, int(round(sc.output.sample_interval / sim.dt)))
            # the ids of the census's own sweep tasks
            ids = [_task_id(q, {k: k.rsplit(".", 1)[-1] for k in q}) for q in points]
            facts = {"scene": sc.name, "n_inner": n, "dt": sim.dt, "tau": sc.damping.tau,
                     "steps": planned_steps(sc, sim.dt), "every": every,
                     "end_time": sc.time.end_time, "d": sc.geometry.d, "R": sc.geometry.R,
                     "xi": sc.geometry.xi, "amplitude": dist.amplitude,
                     "n_modes": dist.n_modes, "points": points, "ids": ids,
                     "max_start_diff": diff}
            bp.save(out / f"batch_n{n}.npz", steady=sim.steady.u, coords=coords,
                    clamped=np.asarray(p.clamped, dtype=np.int64),
                    law=np.array([law.d, law.slide, law.f]),
                    perm=np.asarray(shape.perm), theta_sorted=np.asarray(shape.theta),
                    ds=np.asarray(shape.ds), probe_nodes=np.asarray(probes.index),
                    probe_pc=np.asarray(probes.phase_conj),
                    probe_deg=np.asarray(probes.angles), facts=np.array(json.dumps(facts)))
            print(f"{out.name} N = {n}: n = {bp.n} dofs, dt = {sim.dt:.4g} s, "
                  f"{facts['steps']} steps, {len(points)} starts, start rebuild "
                  f"max |diff| = {diff:.2g} m", flush=True)


# ---------------------------------------------------------------------------- run (node)


def _mpi_or_stub() -> None:
    """``solver.run`` imports mpi4py; a node without an MPI library gets a stand-in module
    (a batch runs on one process and never calls MPI)."""
    try:
        from mpi4py import MPI  # noqa: F401
    except Exception:  # no mpi4py, or no libmpi behind it
        import types

        mpi = types.ModuleType("mpi4py.MPI")
        mpi.COMM_SELF = mpi.COMM_WORLD = None
        mpi.DOUBLE = mpi.INT = None
        pkg = types.ModuleType("mpi4py")
        pkg.MPI = mpi
        sys.modules["mpi4py"], sys.modules["mpi4py.MPI"] = pkg, mpi


class _Start:
    """What a masked (diverged) start keeps: ``BatchSampling`` calls ``finish``."""

    def __init__(self) -> None:
        self.status, self.steps, self.message = "completed", 0, ""

    def finish(self, batch, b: int, status: str, stop: str = "") -> None:
        self.status, self.steps = status, batch.stepper.step_count


class _Batch:
    """The part of ``solver.ensemble_run.BatchSimulation`` that its observers read."""

    def __init__(self, stepper, recorder, count: int) -> None:
        self.stepper, self.recorder = stepper, recorder
        self.runs = [_Start() for _ in range(count)]
        self.live = list(range(count))
        self.max_wall, self.t_start = None, time.perf_counter()


def load_batch(path: Path):
    from solver.ensemble import BatchedProblem

    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    facts = json.loads(str(arrays.pop("facts")))
    bp = BatchedProblem(**{k: arrays[k] for k in BatchedProblem.FIELDS})
    return bp, arrays, facts


def batch_starts(arrays: dict, facts: dict, which: slice = slice(None)) -> np.ndarray:
    cols = [arrays["steady"] + start_fields(arrays["coords"], arrays["clamped"], facts["R"],
                                            facts["xi"], facts["d"], q, facts["amplitude"],
                                            facts["n_modes"])
            for q in facts["points"][which]]
    return np.stack(cols, axis=1)


def run_batch(bp, arrays: dict, facts: dict, xp, kernel: str, u0: np.ndarray,
              steps: int | None = None):
    """The starts ``u0`` (n, B) through ``solver.run.run_loop`` with the sweep's batch
    observers; returns (stepper, recorder, batch, loop seconds)."""
    _mpi_or_stub()
    from solver.ensemble import BatchedExplicit
    from solver.ensemble_observers import BatchRecorder
    from solver.ensemble_run import BatchSampling, ProbeHook
    from solver.run import run_loop

    B = u0.shape[1]
    law = arrays["law"]
    stepper = BatchedExplicit(bp, np.full(B, law[0]), np.full(B, law[1]), np.full(B, law[2]),
                              xp=xp, kernel=kernel, tau=facts["tau"])
    stepper.set_state(u0, np.zeros_like(u0))
    steps = facts["steps"] if steps is None else steps
    every = facts["every"]
    rec = BatchRecorder(stepper, mass=bp.mass, perm=arrays["perm"],
                        theta=arrays["theta_sorted"], ds=arrays["ds"], every=every,
                        max_samples=steps // every + 2, max_steps=steps,
                        probe_nodes=arrays["probe_nodes"], probe_pc=arrays["probe_pc"],
                        probe_deg=arrays["probe_deg"], spool_dir=None)
    stepper.keep_nodes(arrays["probe_nodes"])
    stepper.full_state_at = rec.due
    stepper.attach(ProbeHook(rec))
    batch = _Batch(stepper, rec, B)
    t0 = time.perf_counter()
    end = steps * bp.dt
    sampling = BatchSampling(batch)
    run_loop(stepper, [sampling], end - 1e-12 * end, steps)
    if xp is not np:
        xp.cuda.Device().synchronize()
    sampling.diverge(rec.close(), stepper)  # a GPU's guard: the last chunks of samples
    return stepper, rec, batch, time.perf_counter() - t0


_ROWS: dict = {}  # the records of a batch, inherited by forked classifying workers


def _row(b: int) -> dict:
    from postprocess.analysis import analyse
    from studies.attractors.classify import end_state_features, end_state_row

    c = _ROWS
    facts, start = c["facts"], c["batch"].runs[b]
    point = facts["points"][b]
    summary = {"dt_s": facts["dt"], "steps": start.steps or facts["steps"]}
    spread = (math.nan, math.nan, math.nan)
    features = None
    status = start.status
    if status == "completed":
        a = c["rec"].arrays(b)
        try:
            w = analyse(a["t"], a["theta"], a["u_r"], a["u_theta"], a["status"],
                        d=facts["d"], radius=facts["R"])
            summary.update(regime=w.regime, mode=w.mode, celerity_m_s=w.celerity_m_s,
                           frequency_hz=w.frequency_hz, fractions=w.fractions,
                           amplitude_m=w.amplitude_m, limit_cycle=w.limit_cycle,
                           analysis_window_s=w.window_s, psi1=w.psi1, psi2=w.psi2,
                           direction=w.direction)
            if w.regime != "steady-sliding":  # the census's features, probe included
                features, spread = end_state_features({**a, **c["rec"].probe_arrays(b)},
                                                      summary, facts["R"])
        except ValueError as err:
            status, summary["message"] = "failed", f"analysis: {err}"
    else:
        summary["message"] = start.message or "energy guard: blow-up"
    row = end_state_row(facts["ids"][b], {"mesh.n_inner": facts["n_inner"], **point},
                        summary, status, spread, c["spread_tol"], features=features)
    return row


def classify_batch(rec, batch, facts: dict, spread_tol: float, workers: int) -> list[dict]:
    from benchmarks.gpu_bench import forked_map

    _ROWS.update(rec=rec, batch=batch, facts=facts, spread_tol=spread_tol)
    return forked_map(_row, len(batch.runs), workers)


def namespace(args):
    """(xp, kernel) of ``--target`` (``gpu_bench.namespace``)."""
    from benchmarks.gpu_bench import namespace as array_namespace

    kernel = "numba" if args.target == "cpu" else "cuda"
    try:
        return array_namespace(args.target, args.emulate), kernel
    except ImportError as err:
        raise CensusOffloadError(f"--target {args.target}: {err}; on a machine without CuPy "
                                 "use --target cpu, or --emulate to rehearse") from None


def stage_run(args) -> None:
    args.out.mkdir(parents=True, exist_ok=True)
    rows_path = args.out / "rows.jsonl"
    log = args.out / "batches.jsonl"
    batches = sorted(args.directory.glob("*/batch_n*.npz"),
                     key=lambda p: (p.parent.name, int(p.stem.split("_n")[1])))
    if not batches:
        raise CensusOffloadError(f"{args.directory}: no batch files (*/batch_nN.npz); make "
                                 "them with 'gpu_census.py prepare' where dolfinx is")
    done = _batches_done(rows_path)
    xp, kernel = namespace(args)
    if args.check:
        try:  # the check must not cost the census
            _check(batches[0], xp, args)
        except Exception as err:
            print(json.dumps({"check_error": f"{type(err).__name__}: {err}"}), flush=True)
    for path in batches:
        census = json.loads((path.parent / "census.json").read_text())
        bp, arrays, facts = load_batch(path)
        if (facts["scene"], facts["n_inner"]) in done:  # a rerun resumes after the last batch
            print(f"{facts['scene']} N = {facts['n_inner']}: in {rows_path} already", flush=True)
            continue
        steps = args.max_steps or facts["steps"]
        facts["points"] = facts["points"][:args.max_starts or None]
        u0 = batch_starts(arrays, facts)
        stepper, rec, batch, loop_s = run_batch(bp, arrays, facts, xp, kernel, u0, steps)
        facts["steps"] = steps
        t0 = time.perf_counter()
        rows = classify_batch(rec, batch, facts, census["spread_tol"], args.workers)
        classify_s = time.perf_counter() - t0
        with open(rows_path, "a") as fh:  # one write per batch: a batch's rows or none
            fh.write("".join(json.dumps({"scene": facts["scene"], **r}, default=_plain) + "\n"
                             for r in rows))
        record = {"scene": facts["scene"], "N": facts["n_inner"], "n": bp.n,
                  "B": u0.shape[1], "steps": steps, "dt": bp.dt, "loop_s": loop_s,
                  "classify_s": classify_s,
                  "scene_steps_per_s": u0.shape[1] * steps / loop_s,
                  "classes": {c: sum(r["class"] == c for r in rows)
                              for c in sorted({r["class"] for r in rows})},
                  "target": args.target, "emulated": bool(getattr(xp, "EMULATED", False))}
        with open(log, "a") as fh:
            fh.write(json.dumps(record) + "\n")
        print(json.dumps(record), flush=True)
        del stepper, rec, batch


def _batches_done(rows_path: Path) -> set[tuple[str, int]]:
    """(scene, N) of the batches whose rows are in ``rows_path`` (whole lines only: a line
    cut by a kill is not a row, and its batch runs again)."""
    done = set()
    if rows_path.is_file():
        for line in rows_path.read_text().splitlines():
            try:
                r = json.loads(line)
            except ValueError:
                continue
            done.add((r["scene"], r["n_inner"]))
    return done


def _check(path: Path, xp, args) -> None:
    """A few starts of one batch on the CUDA kernel and on numba: the same bits?"""
    bp, arrays, facts = load_batch(path)
    u0 = batch_starts(arrays, facts, slice(0, args.check_starts))
    out = {"check": path.parent.name + "/" + path.name, "starts": u0.shape[1],
           "steps": args.check_steps}
    states = {}
    for name, x, kern in (("gpu", xp, "cuda"), ("cpu", np, "numba")):
        t0 = time.perf_counter()
        stepper, rec, _, _ = run_batch(bp, arrays, facts, x, kern, u0, args.check_steps)
        u = stepper.u
        states[name] = (np.asarray(u.get() if hasattr(u, "get") else u),
                        rec.arrays(0)["u_r"], rec.probe_arrays(0)["probe_data"])
        out[f"{name}_s"] = time.perf_counter() - t0
    (ug, rg, pg), (uc, rc, pc) = states["gpu"], states["cpu"]
    out.update(same_u=bool(np.array_equal(ug, uc)), same_samples=bool(np.array_equal(rg, rc)),
               same_probes=bool(np.array_equal(pg, pc)),
               max_rel_u=float(np.max(np.abs(ug - uc)) / np.max(np.abs(uc))))
    with open(args.out / "batches.jsonl", "a") as fh:
        fh.write(json.dumps(out) + "\n")
    print(json.dumps(out), flush=True)


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


# ---------------------------------------------------------------------------- answer (here)


def stage_answer(args) -> None:
    from studies.attractors.census import answer_of, write_outputs

    rows_path = args.out / "rows.jsonl"
    if not rows_path.is_file():
        raise CensusOffloadError(f"{rows_path} not found: give the --out directory of "
                                 "'gpu_census.py run'")
    rows = [json.loads(line) for line in rows_path.read_text().splitlines() if line.strip()]
    for census_json in sorted(args.directory.glob("*/census.json")):
        scene = census_json.parent.name
        meta = json.loads(census_json.read_text())
        mine = [{k: v for k, v in r.items() if k != "scene"} for r in rows
                if r["scene"] == scene]
        if not mine:
            continue
        answer = answer_of(meta, mine)
        dest = args.into / scene
        dest.mkdir(parents=True, exist_ok=True)
        (dest / "census.json").write_text(census_json.read_text())
        write_outputs(dest, answer)
        print(f"== {scene}: {dest}\n{answer['text']}", flush=True)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="stage", required=True)
    p = sub.add_parser("prepare", help="the batches' files (needs dolfinx)")
    p.add_argument("directory", type=Path)
    p.add_argument("scenes", nargs="+")
    p.add_argument("--meshes", default="132,264,528")
    p.add_argument("--starts", type=int, default=64)
    p.add_argument("--structured", default="1:12")
    p.add_argument("--end-time", type=float, default=2.0)
    p = sub.add_parser("run", help="every batch, classified (the GPU node)")
    p.add_argument("directory", type=Path)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--target", choices=("gpu", "cpu"), default="gpu")
    p.add_argument("--emulate", action="store_true",
                   help="the CUDA source compiled for the CPU instead of CuPy (rehearsal)")
    p.add_argument("--check", action="store_true", help="CUDA against numba first, bitwise")
    p.add_argument("--check-starts", type=int, default=4)
    p.add_argument("--check-steps", type=int, default=400)
    p.add_argument("--max-steps", type=int, default=0, help="rehearsal: fewer steps")
    p.add_argument("--max-starts", type=int, default=0, help="rehearsal: fewer starts")
    p.add_argument("--workers", type=int, default=min(16, os.cpu_count() or 1))
    p = sub.add_parser("answer", help="the census answer from the rows (here)")
    p.add_argument("directory", type=Path)
    p.add_argument("out", type=Path)
    p.add_argument("--into", type=Path, required=True)
    args = ap.parse_args(argv)
    stage = {"prepare": stage_prepare, "run": stage_run, "answer": stage_answer}[args.stage]
    try:
        stage(args)
    except (CensusOffloadError, ImportError, ValueError, OSError) as err:  # exit 2
        print(f"error: {err}", file=sys.stderr)
        raise SystemExit(2) from None


if __name__ == "__main__":
    main()
