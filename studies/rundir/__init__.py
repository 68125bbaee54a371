"""One scene into a run directory: ``stickslip run``'s files, signals and ``summary.json``.

``run_scene`` builds a :class:`solver.run.Simulation`, lets it ``proceed``, then writes
``scene.toml``, ``samples.npz``, ``final_field.npz`` and ``summary.json`` (the run's facts plus
the wave analysis of ``postprocess.analysis``). Only rank 0 writes files; every write is atomic
(temporary file, then rename), so a run directory never holds a half-written file.

``ownership`` (which directories stickslip may write or replace: every command),
``readers`` (every file stickslip reads back, validated), ``directory`` (a run's directory),
``signals`` (interrupts by phase), ``scene_run`` (``run_scene``, the exit codes), ``writer``
(``RunDirectory``, the driver of every run directory, and a run's files and summary: the same
for a single run, a batch member and a continued run),
``checkpoint`` (a run's checkpoint.npz), ``continuation`` (``continue_run``,
``continue_batch``: a run or batch members continued from their checkpoints).

Names are imported on first use, so ``studies.rundir.ownership`` and ``readers`` stay light
(no MPI, no dolfinx) for the commands that only read or check.
"""

from __future__ import annotations

import importlib

_WHERE = {
    "atomic_save_npz": "stickslip.solver.atomic",
    "output_root": "stickslip.studies.output",
    "process_alive": "stickslip.studies.output",
    "RunDir": "stickslip.studies.rundir.directory",
    "RunDirError": "stickslip.studies.rundir.directory",
    "commit_run_dir": "stickslip.studies.rundir.directory",
    "discard_run_dir": "stickslip.studies.rundir.directory",
    "is_run_dir": "stickslip.studies.rundir.directory",
    "prepare_run_dir": "stickslip.studies.rundir.directory",
    "EXIT_CODES": "stickslip.studies.rundir.scene_run",
    "run_scene": "stickslip.studies.rundir.scene_run",
    "scene_warnings": "stickslip.studies.rundir.scene_run",
    "RunDirectory": "stickslip.studies.rundir.writer",
    "RunOutputs": "stickslip.studies.rundir.writer",
    "peak_rss_mb": "stickslip.studies.rundir.writer",
    "print_summary": "stickslip.studies.rundir.writer",
    "running_summary": "stickslip.studies.rundir.writer",
    "summarise": "stickslip.studies.rundir.writer",
    "write_run_files": "stickslip.studies.rundir.writer",
    "CHECKPOINT": "stickslip.studies.rundir.checkpoint",
    "read_checkpoint": "stickslip.studies.rundir.checkpoint",
    "continue_batch": "stickslip.studies.rundir.continuation",
    "continue_run": "stickslip.studies.rundir.continuation",
    "RunSignals": "stickslip.studies.rundir.signals",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):  # noqa: ANN202 - PEP 562 lazy attributes
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'studies.rundir' has no attribute {name!r}")
