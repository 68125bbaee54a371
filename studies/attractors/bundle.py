"""The census of a GPU node without dolfinx: ``stickslip attractors SCENE ... --bundle DIR``.

The same command runs twice where dolfinx is, around a runner on the node:

1. **prepare** (``write_bundle``; DIR has no ``manifest.json``): the census's starts as its
   sweep resolves them (``census.sweep_text``, ``studies.sweep.scene_for``: the same scenes
   and ids), one batch per mesh: ``Simulation.batch(scenes, build=False)`` builds the problem,
   dt and each start's u_0 (steady sliding + its bump) once, and ``solver.bundle`` writes
   them with a manifest carrying the base scene's SHA-256 (``solver.scene.files.scene_digest``);
2. **the node**: ``python3 -m stickslip.node DIR`` (``solver.bundle.run_bundle``: the batch of
   a sweep, from files, through the one time loop) writes ``DIR/results``;
3. **answer** (``import_results``; DIR's results present): each start's records become its
   run directory under the census's ``starts/runs/<id>`` (``studies.rundir.
   RunDirectory``, the driver of every run directory: scene.toml, samples.npz,
   checkpoint.npz, summary.json with the wave analysis; no final_field.npz). The census then
   goes on as ``run_census`` does after its sweep: settle-or-extend continues its unsettled
   starts here from their checkpoints, and ``collect`` featurises, groups and prints.

A bundle prepared for another scene point or start distribution is refused (its SHA-256 and
definition differ), as are results that are missing.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TextIO

import numpy as np

from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.bundle import (
    MANIFEST,
    BundleError,
    done,
    prepare_bundle,
    read_manifest,
    read_result,
)
from stickslip.solver.run import Profile
from stickslip.solver.scene import write_scene
from stickslip.solver.scene.files import scene_digest
from stickslip.studies.attractors.census import sweep_text
from stickslip.studies.rundir import RunDirectory
from stickslip.studies.rundir.ownership import claim
from stickslip.studies.sweep import load_sweep, scene_for

__all__ = ["BundleError", "NodeRun", "bundle_state", "import_results", "write_bundle"]


def _spec(census, directory: Path):  # noqa: ANN001, ANN202 - a SweepSpec
    """The census's sweep (``census.sweep_text`` on its base scene) in ``directory``."""
    base = census.base_scene()
    write_scene(base, directory / "base.toml")
    atomic_write_text(directory / "census.toml", sweep_text(census, base))
    return base, load_sweep(directory / "census.toml")


def bundle_state(census, directory: Path) -> str:  # noqa: ANN001
    """"new" (no manifest: prepare), "pending" (prepared, results missing) or "ready";
    BundleError where DIR holds a bundle of another census, or is something else."""
    directory = Path(directory)
    if not (directory / MANIFEST).exists():
        if directory.exists() and any(directory.iterdir()):
            raise BundleError(f"--bundle {directory}: not empty and no {MANIFEST}; give a new "
                              "or empty directory to prepare a bundle")
        return "new"
    manifest = read_manifest(directory)
    base = census.base_scene()
    wanted = json.loads(json.dumps(_definition(census, base)))  # as the manifest holds it
    if manifest.get("scene_sha256") != scene_digest(base) or \
            manifest.get("definition") != wanted:
        raise BundleError(f"--bundle {directory} was prepared for another scene point or "
                          "start distribution; use another --bundle directory")
    ids = [i for entry in manifest["batches"] for i in entry["ids"]]
    return "ready" if all(done(directory, i) for i in ids) else "pending"


def _definition(census, base) -> dict:  # noqa: ANN001
    """The census definition plus the meshes: what a bundle answers."""
    return {**census.definition(base), "meshes": census.labels(),
            "distribution": census.distribution.to_dict()}


def write_bundle(census, directory: Path, stream: TextIO | None = None) -> None:  # noqa: ANN001
    """Prepare the bundle of ``census`` in ``directory`` (needs dolfinx; module docstring):
    one batch per rung (``solver.bundle.prepare_bundle``)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    base, spec = _spec(census, directory)
    by_mesh: dict[tuple[int, int], list] = {}  # (N, the point's mesh.degree or 0)
    for task in spec.tasks:
        by_mesh.setdefault((task.params["mesh.n_inner"], task.params.get("mesh.degree", 0)),
                           []).append(task)
    groups = [([t.id for t in tasks], [scene_for(spec, t) for t in tasks])
              for _, tasks in sorted(by_mesh.items())]
    prepare_bundle(directory, groups, stream, scene_sha256=scene_digest(base),
                   scene_file=str(census.scene), definition=_definition(census, base))


class NodeRun:
    """A start that ran on the node, read back: what ``RunDirectory.save_member`` reads of
    a batch's ``solver.ensemble_run.SceneRun`` (scene, status, facts, records, checkpoint)."""

    def __init__(self, scene, directory: Path, start_id: str) -> None:  # noqa: ANN001
        result = read_result(directory, start_id)
        self.scene = scene
        self._facts = result.facts
        self.status, self.message = result.facts["status"], result.message
        self.backend = result.backend
        self.recorder = _Records(result.samples)
        # the probes travel inside the samples; the sampling check reads them from there
        self.probes = _Records({k: v for k, v in result.samples.items()
                                if k in ("probe_t", "probe_data")})
        self.state = result.state

    def facts(self) -> dict:
        return dict(self._facts)

    def final_field(self) -> None:
        """No final field: the node has no mesh to write it on."""
        return None


class _Records:
    def __init__(self, arrays: dict[str, np.ndarray]) -> None:
        self._arrays = arrays

    def arrays(self) -> dict[str, np.ndarray]:
        return dict(self._arrays)


def import_results(bundle: Path, spec, starts_dir: Path,  # noqa: ANN001
                   stream: TextIO | None = None) -> int:
    """Rank 0: each start of ``spec`` (the census's sweep) from the node's results into its
    run directory ``starts_dir/runs/<id>`` (claimed as a sweep's). Returns 0, or 1 if some
    start failed on the node."""
    from mpi4py import MPI

    owned = claim(starts_dir, "sweep", reuse=True)
    try:
        rc = 0
        batches = {i: entry for entry in read_manifest(bundle)["batches"]
                   for i in entry["ids"]}
        for task in spec.tasks:
            run = NodeRun(scene_for(spec, task), bundle, task.id)
            folder = starts_dir / "runs" / task.id
            member = RunDirectory(run.scene, folder)
            member.claim(True, MPI.COMM_SELF, in_place=True)
            member.release()
            member.start()
            batch = {"size": len(batches[task.id]["ids"]), "backend": run.backend,
                     "bundle": str(bundle)}
            member.save_member(run, Profile(), run.backend, {"batch": batch})
            rc = max(rc, int(run.status == "failed"))
        print(f"bundle: {len(spec.tasks)} starts read from {bundle}",
              file=stream or sys.stdout, flush=True)
    finally:
        owned.release()
    return rc
