"""The time loop needs no MPI: ``solver.run.run_loop`` and the batch's stepper and observers
import and run where mpi4py (and the FE stack) is not installed, e.g. a GPU node that runs a
prepared batch, so that such a node runs the one loop of every run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

SCRIPT = """
import sys


class NoFEStack:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("mpi4py", "petsc4py", "dolfinx", "ufl", "basix"):
            raise ImportError(f"{name} is not installed here")
        return None


sys.meta_path.insert(0, NoFEStack())
import numpy as np

import stickslip.solver.ensemble  # noqa: F401 (used as solver.ensemble)
import stickslip.solver.ensemble_observers  # noqa: F401 (used as solver.ensemble_observers)
import stickslip.solver.run  # noqa: F401 (used as solver.run)
from stickslip import solver
from stickslip.solver.ensemble import BatchedProblem
from stickslip.solver.observers import Cadence
from stickslip.solver.run import run_loop
from stickslip.solver.scene_explicit import operator_stepper


class Count:
    cadence = Cadence(3)
    levels = []

    def due(self, level):
        return self.cadence.at(level)

    def observe(self, stepper):
        self.levels.append(stepper.step_count - 1)
        return ""


bp = BatchedProblem.without_matrix(np.ones(2), np.ones(2), 0.1, 0.5)
stepper = operator_stepper(bp, lambda u, out: np.multiply(u, 4.0, out=out))
stepper.set_state(np.ones(2), np.zeros(2))
reason = run_loop(stepper, [Count()], t_stop=1.0 - 1e-12, step_stop=float("inf"))
print(reason, stepper.step_count, Count.levels)
"""


def test_run_loop_runs_without_mpi4py():
    """With mpi4py, PETSc and dolfinx unimportable, the loop steps an explicit Newmark oscillator to
    t = 1 (10 steps of 0.1) and the observer sees levels 0, 3, 6, 9 of its cadence."""
    out = subprocess.run([sys.executable, "-c", SCRIPT], cwd=REPO, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split("\n")[0] == "end_time 10 [0, 3, 6, 9]"
