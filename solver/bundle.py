"""Batches from files: what a node without dolfinx or MPI runs (``python3 -m stickslip.node``).

A bundle directory holds ``manifest.json`` (its kind and format, the SHA-256 of the scene it
was prepared for, and its batches: each one's file, start ids and resolved scenes) and one
``batch_NNN.npz`` per batch: the ``solver.ensemble_run.BatchLayout`` (K, M, dt, the
samples' and probes' layout) and the ``BatchStarts`` (u_0 of every start, built with
dolfinx where the bundle was prepared: ``studies.attractors.bundle``).

``run_bundle`` runs each batch as ``Simulation.batch(scenes, prepared=...)``, the batch a sweep
runs, through the one time loop (``solver.run.run_loop``), on a backend of the scheme
registry (``solver.schemes.select.BACKENDS``), and writes each start's records to
``results/<id>/``: ``samples.npz`` (the samples and probes, as a run directory's),
``state.npz`` (its checkpoint, where it ended at a whole time level) and last ``facts.json``
(``SceneRun.facts()``, status and message). A rerun skips the starts whose ``facts.json`` is
there; a batch killed before its files were written runs again. This module imports neither
dolfinx, nor mpi4py, nor petsc4py (tests/test_bundle.py).
"""

from __future__ import annotations

import json
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from stickslip.solver.atomic import atomic_save_npz, atomic_write_text
from stickslip.solver.ensemble_run import BatchLayout, BatchStarts
from stickslip.solver.run import Simulation
from stickslip.solver.scene import scene_from_dict, scene_to_dict
from stickslip.solver.schemes.select import batchable, check_backend

__all__ = ["KIND", "MANIFEST", "RESULTS", "BundleError", "NodeResult", "done", "load_batch",
           "prepare_bundle", "read_manifest", "read_result", "run_bundle"]

KIND = "stickslip-bundle"
FORMAT = 1
MANIFEST = "manifest.json"
RESULTS = "results"


class BundleError(ValueError):
    """A bundle that cannot be used (the message names the path and the fix)."""


def prepare_bundle(directory: str | Path, groups: list[tuple[list[str], list]],
                   stream: TextIO | None = None, **meta: object) -> dict:
    """Write a bundle (needs dolfinx): per group (start ids, their scenes, which must share
    a batch: ``solver.schemes.select.batchable``), ``Simulation.batch(scenes, build=False)``'s
    layout and starts to ``batch_NNN.npz``; then ``manifest.json`` with ``meta``. Returns the
    manifest. BundleError where a scene cannot run in a batch or its steady state fails."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    batches = []
    for i, (ids, scenes) in enumerate(groups):
        if not batchable(scenes[0]):
            raise BundleError(f"{scenes[0].name}: this scene cannot run in a batch (the "
                              "implicit scheme, field output or time.kernel = \"numpy\"); "
                              "run it where dolfinx is")
        batch = Simulation.batch(scenes, build=False)
        if batch.failures:
            k, err = next(iter(batch.failures.items()))
            raise BundleError(f"{scenes[k].name}: steady sliding failed ({err}); fix the "
                              "scene")
        name = f"batch_{i:03d}.npz"
        starts = batch.columns.starts
        atomic_save_npz(directory / name, {**batch.columns.layout.arrays(), "u0": starts.u0,
                                           "steady_pressure": starts.steady_pressure},
                        compress=False)
        n_inner = scenes[0].mesh.n_inner
        batches.append({"file": name, "n_inner": n_inner, "ids": list(ids),
                        "scenes": [scene_to_dict(sc) for sc in scenes]})
        print(f"bundle: N = {n_inner}: {len(ids)} starts, {batch.columns.layout.dofs} dofs, "
              f"dt = {batch.dt:.4g} s, {batch.planned_steps()} steps -> {directory / name}",
              file=stream or sys.stdout, flush=True)
    manifest = {"kind": KIND, "format": FORMAT, **meta, "batches": batches}
    atomic_write_text(directory / MANIFEST, json.dumps(manifest, indent=1) + "\n")
    return manifest


def load_batch(directory: str | Path, entry: dict) -> tuple[list, BatchLayout, BatchStarts]:
    """(scenes, layout, starts) of one batch of the manifest (``entry``)."""
    path = Path(directory) / entry["file"]
    try:
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError) as err:
        raise BundleError(f"{path}: unreadable ({err}); prepare the bundle again") from None
    starts = BatchStarts(arrays.pop("u0"), arrays.pop("steady_pressure"))
    return ([scene_from_dict(d) for d in entry["scenes"]], BatchLayout.from_arrays(arrays),
            starts)


def read_manifest(directory: Path) -> dict:
    """The bundle's manifest (BundleError naming the fix if it is missing or not one)."""
    path = Path(directory) / MANIFEST
    try:
        manifest = json.loads(path.read_text())
    except FileNotFoundError:
        raise BundleError(f"{path} not found: prepare the bundle with `stickslip attractors "
                          "SCENE ... --bundle DIR` where dolfinx is") from None
    except (OSError, ValueError) as err:
        raise BundleError(f"{path}: unreadable ({err}); prepare the bundle again") from None
    if not isinstance(manifest, dict) or manifest.get("kind") != KIND \
            or manifest.get("format") != FORMAT:
        raise BundleError(f"{path} is not a stickslip bundle of format {FORMAT}; prepare the "
                          "bundle again with this version")
    return manifest


def done(directory: Path, start_id: str) -> bool:
    """True once the start's results are complete (its facts.json is written last)."""
    return (Path(directory) / RESULTS / start_id / "facts.json").is_file()


def run_bundle(directory: str | Path, backend: str = "gpu",
               stream: TextIO | None = None) -> int:
    """Run every batch of the bundle whose results are not all there; returns 0.

    Raises ``BundleError`` (a bundle that is not one), ValueError or ImportError (a backend
    this machine cannot use: ``solver.schemes.select.check_backend``)."""
    directory = Path(directory)
    manifest = read_manifest(directory)
    check_backend(backend)
    batches = manifest["batches"]
    for i, entry in enumerate(batches):
        ids = entry["ids"]
        head = f"batch {i + 1}/{len(batches)} (N = {entry['n_inner']}, {len(ids)} starts)"
        if all(done(directory, s) for s in ids):
            print(f"{head}: done already", file=stream or sys.stdout, flush=True)
            continue
        scenes, layout, starts = load_batch(directory, entry)
        t0 = time.perf_counter()
        batch = Simulation.batch(scenes, backend=backend, spool_parent=directory,
                                 prepared=(layout, starts), progress=stream or sys.stdout)
        try:
            batch.proceed()
            for start_id, run in zip(ids, batch.runs, strict=True):
                _write_result(directory / RESULTS / start_id, run, backend)
        finally:
            if batch.columns.spool_dir is not None:  # now in each samples.npz
                shutil.rmtree(batch.columns.spool_dir, ignore_errors=True)
        seconds = time.perf_counter() - t0
        statuses = [run.status for run in batch.runs]
        counts = ", ".join(f"{statuses.count(s)} {s}" for s in sorted(set(statuses)))
        steps = batch.stepper.step_count
        print(f"{head}: {steps} steps in {seconds:.1f} s ({len(ids) * steps / seconds:.3g} "
              f"scene-steps/s, {backend}): {counts}", file=stream or sys.stdout, flush=True)
    return 0


@dataclass
class NodeResult:
    """One start's records, read back from ``results/<id>/``."""

    facts: dict
    message: str
    backend: str
    samples: dict[str, np.ndarray]
    state: dict[str, np.ndarray] | None


def read_result(directory: str | Path, start_id: str) -> NodeResult:
    """The records of one start (BundleError naming the fix where they are missing)."""
    folder = Path(directory) / RESULTS / start_id
    if not done(directory, start_id):
        raise BundleError(f"{folder}: no results; run `python3 -m stickslip.node "
                          f"{directory}` on the node and copy {Path(directory) / RESULTS} "
                          "back")
    data = json.loads((folder / "facts.json").read_text())
    with np.load(folder / "samples.npz") as z:
        samples = {k: z[k] for k in z.files}
    state = None
    if (folder / "state.npz").is_file():
        with np.load(folder / "state.npz") as z:
            state = {k: z[k] for k in z.files}
    return NodeResult(data["facts"], data["message"], data["backend"], samples, state)


def _write_result(folder: Path, run, backend: str) -> None:
    """One start's records (``SceneRun``): samples.npz, state.npz, then facts.json."""
    folder.mkdir(parents=True, exist_ok=True)
    arrays = run.recorder.arrays()
    arrays.update(run.probes.arrays() or {})
    atomic_save_npz(folder / "samples.npz", arrays)
    if run.state is not None:
        atomic_save_npz(folder / "state.npz", run.state, compress=False)
    else:
        (folder / "state.npz").unlink(missing_ok=True)
    facts = {"facts": run.facts(), "message": run.message, "backend": backend}
    atomic_write_text(folder / "facts.json",
                      json.dumps(facts, indent=1, default=_plain) + "\n")


def _plain(value):  # noqa: ANN001, ANN202
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
