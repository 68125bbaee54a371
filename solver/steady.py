"""Discrete steady sliding state: the exact fixed point of the explicit scheme.

Steady sliding (paper section 2): the tube is at rest, every contact node is in contact
(u_r = d) and slips forward (the cylinder surface is faster), so the nodal contact force is
r = (p_i, f p_i) in the node's (e_r, e_theta) frame. At a fixed point of ``solver.newmark`` with
v = a = 0 this is K u = r with u = 0 on the outer circle — exactly the nodal problem that
``forms.steady.static_sliding`` solves (rotated nodal frames, one LU solve). This module adapts
its result to the solver's owned-dof arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stickslip.forms.steady import static_sliding
from stickslip.solver.problem import TubeProblem
from stickslip.solver.scene import STEADY_DIRECT_DOFS


@dataclass
class SteadyState:
    """Discrete steady sliding: owned dofs of u_e and the contact forces at owned nodes."""

    u: np.ndarray
    pressure: np.ndarray  # p_i = r_r,i / (int phi_i ds), Pa
    normal_force: np.ndarray  # r_r,i, N/m
    tangential_force: np.ndarray  # r_theta,i = f r_r,i


def solve_steady_sliding(problem: TubeProblem) -> SteadyState:
    """The discrete steady sliding state of ``problem`` (see module docstring)."""
    sc = problem.scene
    iterative = problem.surface is not None and problem.n_global_dofs > STEADY_DIRECT_DOFS
    st = static_sliding(problem.V, problem.tube, problem.material, sc.geometry.d, sc.loading.f,
                        held=problem.end_held, iterative=iterative)
    if np.any(st.normal_force <= 0.0):
        raise RuntimeError(
            "discrete steady sliding state has non-positive contact pressure at "
            f"{int(np.sum(st.normal_force <= 0.0))} nodes: the data admit no steady sliding"
        )
    return SteadyState(
        u=problem.owned_array(st.u),
        pressure=st.pressure,
        normal_force=st.normal_force,
        tangential_force=sc.loading.f * st.normal_force,
    )
