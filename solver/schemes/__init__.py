"""Time schemes: the stepper protocol (``protocol``) and the scheme registry (``select``:
``SCHEMES``, ``add_scheme``, ``for_scene``), the one module that knows a scene's scheme, time
step, kernel and backend. The steppers themselves are ``solver.newmark`` (explicit numpy,
damped), ``solver.fused`` (explicit numba), ``solver.implicit`` (implicit Newmark) and
``solver.ensemble`` (B scenes at once).

The names of ``select`` are served lazily (PEP 562), so that a scheme module can import
``solver.schemes.protocol`` without importing ``select``, which imports the schemes.
"""

from stickslip.solver.schemes.protocol import HookedStepper, StepHook, Stepper

__all__ = [
    "HookedStepper", "StepHook", "Stepper", "SCHEMES", "add_scheme", "for_scene",
    "STEP_WARNING", "batchable", "check_backend", "damping_advice", "make_explicit",
    "resolve_kernel", "shortest_wave_period", "stability_advice", "time_step",
]


def __getattr__(name: str):
    if name in __all__:
        from stickslip.solver.schemes import select

        return getattr(select, name)
    raise AttributeError(f"module 'solver.schemes' has no attribute {name!r}")
