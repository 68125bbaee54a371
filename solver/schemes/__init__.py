"""Time schemes: the scheme registry (``select``: ``SCHEMES``, ``add_scheme``, ``for_scene``),
the one module that knows a scene's scheme, time step, kernel and backend. The steppers
themselves are ``solver.ensemble`` (the explicit step of B scenes at once, with its numpy,
numba and CUDA kernels; one scene is a batch of one, ``solver.scene_explicit``) and
``solver.implicit`` (implicit Newmark); what each
offers the time loop is the protocol of ``solver.stepper``, beside them (the registry imports
the steppers, never the other way).
"""

from stickslip.solver.schemes.select import (
    SCHEMES,
    STEP_WARNING,
    add_scheme,
    batchable,
    check_backend,
    damping_advice,
    for_scene,
    resolve_kernel,
    shortest_wave_period,
    stability_advice,
    time_step,
    unsteppable,
)

__all__ = [
    "SCHEMES", "add_scheme", "for_scene", "STEP_WARNING", "batchable", "check_backend",
    "damping_advice", "resolve_kernel", "unsteppable", "shortest_wave_period",
    "stability_advice", "time_step",
]
