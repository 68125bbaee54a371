"""The stepper protocol: what every time scheme offers the time loop (the steppers import it,
the scheme registry ``solver.schemes.select`` builds them).

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

__all__ = ["BatchStepper", "Stepper", "StepHook", "HookedStepper", "copy_state", "put_state",
           "to_host"]


@runtime_checkable
class StepHook(Protocol):
    """An observer called after every step (``Stepper.attach``)."""

    def after_step(self, stepper) -> None: ...


@runtime_checkable
class Stepper(Protocol):
    """A time scheme as its callers see it: the time loop (``solver.run.run_loop``), the
    observers (the arrays of level n), the checkpoint and the run's facts."""

    dt: float
    time: float
    step_count: int
    damped: bool
    """Kelvin-Voigt damping is on (the damping work is observed)."""
    u: np.ndarray
    """u_{n+1} after a step."""
    u_prev: np.ndarray
    """u_n after a step (with ``v``, ``a``, ``ku``: the level the observers record)."""
    v: np.ndarray
    ku: np.ndarray

    def attach(self, hook: StepHook) -> None:
        """Call ``hook.after_step(self)`` after every step taken by ``advance``."""

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

    def state(self) -> dict[str, np.ndarray]:
        """What the next step reads, as host copies (the clock ``time``, ``step_count`` and
        the arrays of the last level): a checkpoint that ``restore`` continues bitwise."""

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Take up ``state`` (of ``state()``, same scene and ranks) after ``set_state``."""


@runtime_checkable
class BatchStepper(Protocol):
    """B scenes' columns (n, B) stepped as one (``solver.ensemble.BatchedExplicit``), as a
    batch's columns see them (``solver.ensemble_run.BatchColumns``) besides the time loop's
    ``advance``, ``time`` and ``step_count``: the columns still stepped, where the records
    live, and checkpoints, kicks and host copies per column (b)."""

    B: int
    m: int
    """Contact nodes."""
    active: np.ndarray
    """(B,) bool: the columns still stepped (``mask`` clears one)."""
    host_records: bool
    """The records can stay whole in host memory (a CPU's arrays), else spooled in chunks."""
    full_state_at: object
    """level -> bool: the levels whose v, a and K u a sample reads (others step lean)."""

    def set_state(self, u: np.ndarray, v: np.ndarray) -> None: ...
    def attach(self, hook: StepHook) -> None: ...
    def keep_nodes(self, nodes: np.ndarray) -> None: ...
    def mask(self, b: int) -> None: ...
    def host_state(self) -> dict[str, np.ndarray]: ...
    def state(self, b: int, host: dict[str, np.ndarray] | None = None
              ) -> dict[str, np.ndarray]: ...
    def restore(self, states: list[dict[str, np.ndarray]]) -> None: ...
    def kick(self, b: int, du: np.ndarray, dv: np.ndarray) -> None: ...
    def host_column(self, name: str, b: int) -> np.ndarray: ...
    def facts(self) -> dict: ...


def copy_state(obj, names: tuple[str, ...], clock: bool = False) -> dict[str, np.ndarray]:
    """Host copies of ``obj``'s arrays ``names`` (a device array is copied to the host), and
    with ``clock`` a stepper's ``time`` and ``step_count``: a ``state()``."""
    out = {name: np.array(to_host(getattr(obj, name))) for name in names}
    if clock:
        out["time"] = np.float64(obj.time)
        out["step_count"] = np.int64(obj.step_count)
    return out


def put_state(obj, state: dict[str, np.ndarray], names: tuple[str, ...]) -> None:
    """Write ``state[name]`` into ``obj``'s array ``name`` in place, for each of ``names``,
    and set its clock; the shapes must match (a checkpoint of another mesh or partition is
    refused with ValueError)."""
    for name in names:
        target = getattr(obj, name)
        value = np.asarray(state[name])
        if value.shape != target.shape:
            raise ValueError(f"checkpoint array {name!r} has shape {value.shape}, the run "
                             f"{target.shape}: not this scene's mesh or partition")
        if isinstance(target, np.ndarray):
            target[...] = value
        else:  # a CuPy array: one host-to-device copy
            target.set(np.ascontiguousarray(value, dtype=target.dtype))
    if "step_count" in state:
        obj.time = float(state["time"])
        obj.step_count = int(state["step_count"])


def to_host(array):
    """A numpy view or copy of a numpy or CuPy array (a device array is copied)."""
    return array.get() if hasattr(array, "get") else array


class HookedStepper:
    """The step hooks and the plain ``advance`` (``step`` then the hooks, n times) that the
    schemes share; a scheme with a compiled loop overrides ``advance`` and
    ``compiled_loop``."""

    kernel: str = "numpy"
    damped: bool = False
    compiled_loop: bool = False

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
