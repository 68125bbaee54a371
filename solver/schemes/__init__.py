"""Time schemes: the scheme registry (``select``: ``SCHEMES``, ``add_scheme``, ``for_scene``),
the one module that knows a scene's scheme, time step, kernel and backend. The steppers
themselves are ``solver.newmark`` (explicit numpy, damped), ``solver.fused`` (explicit numba),
``solver.implicit`` (implicit Newmark) and ``solver.ensemble`` (B scenes at once); what each
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
    make_explicit,
    resolve_kernel,
    shortest_wave_period,
    stability_advice,
    time_step,
    unsteppable,
)

__all__ = [
    "SCHEMES", "add_scheme", "for_scene", "STEP_WARNING", "batchable", "check_backend",
    "damping_advice", "make_explicit", "resolve_kernel", "unsteppable", "shortest_wave_period",
    "stability_advice", "time_step",
]
