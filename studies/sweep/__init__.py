"""Parameter studies: a sweep file -> scene variants -> run directories -> a table and a map.

``spec`` (the file format), ``schedule`` (MPI groups, shared counter, resume),
``table`` (``sweep.{csv,json}``), ``regime_map`` (the plot).
"""

from stickslip.studies.sweep.regime_map import existence_grid, plot_sweep
from stickslip.studies.sweep.schedule import run_sweep
from stickslip.studies.sweep.spec import (
    FINAL_STATUSES,
    REGIMES,
    MapSpec,
    SweepError,
    SweepSpec,
    Task,
    load_sweep,
    scene_for,
)
from stickslip.studies.sweep.table import is_sweep_dir, read_table, task_state, write_table

__all__ = [
    "FINAL_STATUSES",
    "REGIMES",
    "MapSpec",
    "SweepError",
    "SweepSpec",
    "Task",
    "existence_grid",
    "is_sweep_dir",
    "load_sweep",
    "plot_sweep",
    "read_table",
    "run_sweep",
    "scene_for",
    "task_state",
    "write_table",
]
