"""One scene into a run directory: ``stickslip run``'s files, signals and ``summary.json``.

``run_scene`` builds a :class:`solver.run.Simulation`, lets it ``proceed``, then writes
``scene.toml``, ``samples.npz``, ``final_field.npz`` and ``summary.json`` (the run's facts plus
the wave analysis of ``postprocess.analysis``). Only rank 0 writes files; every write is atomic
(temporary file, then rename), so a run directory never holds a half-written file.

``directory`` (refuse, replace, swap), ``signals`` (interrupts by phase), ``scene_run``
(``run_scene``, the summary, the exit codes).
"""

from solver.atomic import atomic_save_npz
from studies.output import output_root, process_alive
from studies.rundir.directory import (
    RunDir,
    RunDirError,
    commit_run_dir,
    discard_run_dir,
    is_run_dir,
    prepare_run_dir,
)
from studies.rundir.scene_run import (
    EXIT_CODES,
    _print_summary,
    peak_rss_mb,
    run_scene,
    scene_warnings,
    summarise,
)
from studies.rundir.signals import RunSignals

__all__ = [
    "EXIT_CODES",
    "RunDir",
    "RunDirError",
    "RunSignals",
    "_print_summary",
    "atomic_save_npz",
    "commit_run_dir",
    "discard_run_dir",
    "is_run_dir",
    "output_root",
    "peak_rss_mb",
    "prepare_run_dir",
    "process_alive",
    "run_scene",
    "scene_warnings",
    "summarise",
]
