"""The stepper protocol: what every time scheme offers the time loop.

A stepper advances the semi-discrete system M a + C v + K u = r (the contact forces r from
``solver.contact``) from time level n to n + 1. The time loop (``solver.run.Simulation``) only
calls the four methods below, for every scheme alike: the explicit Newmark step (numpy,
``solver.newmark``), its damped variant, the fused numba step (``solver.fused``), the implicit
Newmark step (``solver.implicit``) and the batched step of B scenes (``solver.ensemble``).

After ``step()``, ``u`` holds u_{n+1} while ``u_prev``, ``v``, ``a`` and ``ku`` hold time level
n (u_n, v_n, a_n, K u_n), the level the observers record; ``time`` is t_{n+1} and
``step_count`` is n + 1.

Step hooks are the observers that need every step (the probes' time histories, the contact
work of a numpy step, the Kelvin-Voigt work): ``attach(hook)`` registers an object with
``after_step(stepper)``, called after each step in the order of registration. ``advance``
runs them; a compiled stepper may run a hook it knows inside its compiled loop.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Stepper", "StepHook", "HookedStepper"]


@runtime_checkable
class StepHook(Protocol):
    """An observer called after every step (``Stepper.attach``)."""

    def after_step(self, stepper) -> None: ...


@runtime_checkable
class Stepper(Protocol):
    """A time scheme as the time loop sees it."""

    dt: float
    time: float
    step_count: int

    def set_state(self, u: np.ndarray, v: np.ndarray, a0: np.ndarray | None = None) -> None:
        """Initial displacement, velocity and (if known) acceleration at t = 0."""

    def step(self) -> None:
        """One step, u_n -> u_{n+1}, without the step hooks."""

    def advance(self, n: int, t_stop: float = math.inf) -> int:
        """Up to ``n`` steps with the step hooks after each; stops before a step once
        ``time >= t_stop``. Returns the number of steps taken."""

    def facts(self) -> dict:
        """The scheme's facts for the run summary: name, beta1, beta2, damping, kernel,
        contact time and the scheme's own counters."""


class HookedStepper:
    """The step hooks and the plain ``advance`` (``step`` then the hooks, n times) that the
    schemes share; a scheme with a compiled loop overrides ``advance``."""

    def _init_hooks(self) -> None:
        self.hooks: list[StepHook] = []

    def attach(self, hook: StepHook) -> None:
        """Call ``hook.after_step(self)`` after every step taken by ``advance``."""
        self.hooks.append(hook)

    def advance(self, n: int, t_stop: float = math.inf) -> int:
        hooks = self.hooks
        taken = 0
        while taken < n and not self.time >= t_stop:  # a NaN t_stop never stops
            self.step()
            for hook in hooks:
                hook.after_step(self)
            taken += 1
        return taken
