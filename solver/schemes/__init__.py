"""Time schemes: the stepper protocol (``protocol``) and the one module that chooses a
scene's scheme, time step and kernel (``select``). The schemes themselves are
``solver.newmark`` (explicit numpy, damped), ``solver.fused`` (explicit numba),
``solver.implicit`` (implicit Newmark) and ``solver.ensemble`` (B scenes at once).

The names of ``select`` are served lazily (PEP 562), so that a scheme module can import
``solver.schemes.protocol`` without importing ``select``, which imports the schemes.
"""

from solver.schemes.protocol import HookedStepper, StepHook, Stepper

__all__ = [
    "HookedStepper", "StepHook", "Stepper", "STEP_WARNING", "batchable",
    "contact_work_observer", "damping_advice", "make_explicit", "make_stepper",
    "resolve_kernel", "shortest_wave_period", "stability_advice", "time_step",
]


def __getattr__(name: str):
    if name in __all__:
        from solver.schemes import select

        return getattr(select, name)
    raise AttributeError(f"module 'solver.schemes' has no attribute {name!r}")
