"""The one place that chooses the time scheme of a scene: time step, stepper, contact step.

Every branch on ``time.beta1`` (explicit or implicit) and on the kernel (numpy, numba,
batched) that decides what runs lives in this module (tests/test_architecture.py checks it).
The scene's ``time`` table picks the scheme:

* ``beta1 = 0``: the paper's explicit Newmark (``solver.newmark.Newmark``) with the
  forward-increment (Carpenter-Taylor-Katona) nodal contact projection; stable for
  dt <= dt_crit = sqrt(2 / beta2) / omega_max, so ``0 < dt_fraction <= 1``;
* ``beta1 > 0``: implicit Newmark (``solver.implicit.ImplicitNewmark``) with the active-set
  contact solve on the Schur complement; unconditionally stable for 2 beta1 >= beta2 >= 1/2
  (e.g. beta1 = 1/4, beta2 = 1/2), so ``dt_fraction`` (still in units of the explicit limit)
  may exceed 1.

``time_step`` also prints advice (rank 0, stderr; a message, never an error) when the explicit
step is tiny compared with the waves the mesh can carry, or the run needs more than
``STEP_WARNING`` steps: the implicit scheme is then the better choice.
"""

from __future__ import annotations

import math
import sys
from time import perf_counter

import numpy as np

from solver.contact import ContactLaw, make_projection
from solver.errors import StepTooLarge
from solver.newmark import Newmark, critical_time_step
from solver.scene import Scene

STEP_WARNING = 1_000_000
"""Planned steps above which ``time_step`` suggests a cheaper setting."""
STEPS_PER_WAVE_WARNING = 15.0
"""Explicit steps per period of the shortest contact-mesh shear wave above which the explicit
step is "tiny": its size is set by stiff modes (pressure waves at nu -> 1/2, thin elements), not
by the waves of interest (ratio ~5 at nu = 0.3, xi = 1.25; ~21 at nu = 0.49; docs/stability.md)."""


def shortest_wave_period(scene: Scene) -> float:
    """Period 2 h / c_s of the shortest wave (length 2h, h = 2 pi R / n_inner) that the contact
    circle resolves, travelling at the shear speed c_s = sqrt(E / (2 (1 + nu) rho))."""
    m, g = scene.material, scene.geometry
    c_s = m.wave_speed / math.sqrt(2.0 * (1.0 + m.nu))
    h = 2.0 * math.pi * g.R / scene.mesh.n_inner
    return 2.0 * h / c_s


def stability_advice(scene: Scene, dt: float, dt_crit: float) -> str | None:
    """A warning text when the scene's step is impractical, else None (see module docstring)."""
    ts = scene.time
    steps = ts.end_time / dt
    if ts.max_steps:
        steps = min(steps, ts.max_steps)
    per_wave = shortest_wave_period(scene) / dt_crit
    notes = []
    if ts.beta1 == 0.0 and per_wave > STEPS_PER_WAVE_WARNING:
        notes.append(
            f"the explicit stability limit dt_crit = {dt_crit:.3g} s is {per_wave:.0f} times "
            f"smaller than the period of the shortest shear wave on the contact mesh "
            f"({shortest_wave_period(scene):.3g} s): stiff modes (nu = {scene.material.nu}, "
            f"xi = {scene.geometry.xi}) set the step, not the waves"
        )
    if steps > STEP_WARNING:
        notes.append(f"{steps:.3g} time steps planned (> {STEP_WARNING:.0e})")
    if not notes:
        return None
    text = "warning: " + "; ".join(notes) + "."
    if ts.beta1 == 0.0:
        text += (" Consider the implicit scheme: --set time.beta1=0.25 --set time.beta2=0.5 "
                 f"--set time.dt_fraction={max(2.0, per_wave / 4):.0f} "
                 "(unconditionally stable; see docs/stability.md and docs/accuracy.md)")
    return text


def _rank0() -> bool:
    try:
        from mpi4py import MPI

        return MPI.COMM_WORLD.rank == 0
    except ImportError:  # pragma: no cover - mpi4py is part of the stack
        return True


def time_step(scene: Scene, omega_max: float) -> tuple[float, float]:
    """(dt, dt_crit) for ``scene``: a fixed ``time.dt`` (checked) or ``dt_fraction * dt_crit``.

    dt_crit is always the EXPLICIT limit sqrt(2 / beta2) / omega_max, the unit of
    ``time.dt_fraction`` for both schemes; for an explicit scene with Kelvin-Voigt damping it
    is the damped explicit limit (``critical_time_step``). Implicit schemes with
    2 beta1 < beta2 are only conditionally stable: their own limit is checked too.
    """
    ts = scene.time
    # explicit: the damped limit is the unit of dt_fraction; the implicit scheme treats the
    # damping implicitly, so its unit stays the undamped explicit limit
    tau = scene.damping.tau if ts.beta1 == 0.0 else 0.0
    dt_crit = critical_time_step(omega_max, 0.0, ts.beta2, tau)
    limit = critical_time_step(omega_max, ts.beta1, ts.beta2, tau)
    dt = ts.dt if ts.dt > 0.0 else ts.dt_fraction * dt_crit
    if dt > limit:
        what = "explicit" if ts.beta1 == 0.0 else f"beta1 = {ts.beta1}, beta2 = {ts.beta2}"
        rule = ("sqrt(2/beta2)/omega_max" if ts.beta1 == 0.0
                else "1/(omega_max sqrt(beta2/2 - beta1))")
        if ts.beta1 == 0.0 and tau > 0.0:
            rule = "4/(omega_max^2 (tau + sqrt(tau^2 + 8 beta2/omega_max^2)))"
        raise StepTooLarge(
            f"time.dt = {dt:.4g} s is above the {what} stability limit "
            f"dt_crit = {rule} = {limit:.4g} s "
            f"(omega_max = {omega_max:.4g} rad/s, beta2 = {ts.beta2}). Use "
            f"time.dt <= {limit:.4g}, or time.dt = 0 with time.dt_fraction <= "
            f"{limit / dt_crit:.4g}"
            + ("" if ts.beta1 == 0.0 else ", or 2 beta1 >= beta2 (unconditionally stable)")
        )
    advice = stability_advice(scene, dt, dt_crit)
    damped = damping_advice(scene, omega_max)
    if damped:
        advice = f"{advice}\n{damped}" if advice else damped
    if advice and _rank0():
        print(advice, file=sys.stderr, flush=True)
    return dt, dt_crit


DAMPED_STEP_WARNING = 1e-3
"""Ratio damped / undamped explicit limit below which the implicit scheme is recommended."""


def damping_advice(scene: Scene, omega_max: float) -> str | None:
    """A warning when Kelvin-Voigt damping collapses the explicit step (ratio < 1e-3)."""
    tau = scene.damping.tau
    if scene.time.beta1 != 0.0 or tau <= 0.0:
        return None
    b2 = scene.time.beta2
    ratio = critical_time_step(omega_max, 0.0, b2, tau) / critical_time_step(omega_max, 0.0, b2)
    if ratio >= DAMPED_STEP_WARNING:
        return None
    zeta = 0.5 * tau * omega_max
    return (f"warning: damping tau = {tau:.3g} s gives zeta = tau omega_max / 2 = {zeta:.3g} at "
            f"the highest mode, which cuts the explicit stability limit to {ratio:.2g} x its "
            "undamped value (< 1e-3). Use the implicit scheme, which treats the damping "
            "implicitly and is unconditionally stable: --set time.beta1=0.25 "
            "--set time.beta2=0.5 --set time.dt_fraction=1")


def numba_available() -> bool:
    """True when numba imports (Debian's python3-numba is in the apt list)."""
    from solver.fused import numba_available as available

    return available()


#: The friction variants (``ContactLaw.variant``) that the fused and batched kernels have.
KERNEL_VARIANTS = ("nodal", "prakash-clifton", "constant-time")


def resolve_kernel(scene: Scene) -> str:
    """The step kernel a scene runs with: ``"numba"`` or ``"numpy"``. THE fallback rule.

    * the implicit scheme (time.beta1 > 0) has no fused step: "numpy" (it is not a stiffness
      product; ``time.kernel`` is ignored there);
    * physics the fused kernel does not implement (a friction variant not in
      ``KERNEL_VARIANTS``: the 1-2-1 filtered bound) falls back to "numpy"; Kelvin-Voigt
      ``[damping]`` and the regularised bounds (Prakash-Clifton, constant time) are in the
      fused and batched kernels (the numpy step's operations, to round-off);
    * ``time.kernel = "auto"``: "numba" when numba imports, else "numpy";
    * ``time.kernel = "numba"`` without numba: ValueError naming the fix.
    """
    ts = scene.time
    if ts.beta1 > 0.0:
        return "numpy"
    if ContactLaw.variant_of(scene) not in KERNEL_VARIANTS:
        return "numpy"  # the filtered projection, or a variant the kernels do not know
    requested = ts.kernel
    if requested == "numpy":
        return "numpy"
    if numba_available():
        return "numba"
    if requested == "numba":
        raise ValueError("time.kernel = \"numba\" but numba does not import: install "
                         "python3-numba (apt) or set time.kernel = \"numpy\"")
    return "numpy"


def batchable(scene: Scene) -> bool:
    """True when ``scene`` can run as a column of the batched explicit step
    (``solver.ensemble``): the explicit scheme with the fused numba kernel's physics, no field
    output."""
    if scene.time.beta1 > 0.0 or scene.output.fields:
        return False
    try:
        return resolve_kernel(scene) == "numba"
    except ValueError:
        return False


def make_explicit(problem, scene: Scene, dt: float):
    """The numpy explicit stepper of ``scene``: ``Newmark``, or ``DampedNewmark`` when the
    scene has Kelvin-Voigt damping (the undamped step then stays exactly the plain one)."""
    ts, tau = scene.time, scene.damping.tau
    if tau > 0.0:
        from solver.newmark import DampedNewmark

        return DampedNewmark(problem.stiffness_mult(), problem.inv_mass, dt, ts.beta1,
                             ts.beta2, tau=tau)
    return Newmark(problem.stiffness_mult(), problem.inv_mass, dt, ts.beta1, ts.beta2)


def make_stepper(problem, scene: Scene, dt: float):
    """(stepper, contact) for the scene's scheme; both follow ``solver.schemes.protocol``.

    The contact object exposes ``out`` (ContactArrays: r_r, r_t, status), ``slide``,
    ``nodes`` and ``_polar`` as the observers use them; the stepper exposes ``u``, ``u_prev``,
    ``v``, ``a``, ``ku``, ``time``, ``dt``, ``step_count``. After a step, ``u`` is u_{n+1}
    and everything else (``u_prev``, ``v``, ``a``, ``ku``, ``out``) is time level n, for
    every scheme.
    """
    ts = scene.time
    law = ContactLaw.from_scene(scene, dt)
    if ts.beta1 > 0.0:
        from solver.implicit import ImplicitContact, ImplicitNewmark

        contact = ImplicitContact(problem.nodes, law.d, law.f, law.surface_speed,
                                  problem.comm)
        stepper = ImplicitNewmark(problem.K, problem.mass, problem.clamped, dt, ts.beta1,
                                  ts.beta2, contact, problem.comm, tau=scene.damping.tau)
        return stepper, contact
    projection = make_projection(problem, law)
    if resolve_kernel(scene) == "numba":
        from solver.fused import FusedNewmark

        return (FusedNewmark(problem, dt, ts.beta2, projection, tau=scene.damping.tau),
                projection)
    stepper = make_explicit(problem, scene, dt)  # damped or plain numpy step
    stepper.contact = TimedContact(projection)
    return stepper, projection


def make_batched_stepper(problem, laws: list[ContactLaw], backend: str = "cpu",
                         tau: float = 0.0):
    """The batched explicit stepper of scenes that share ``problem`` (K, M, the contact
    nodes), dt, beta_2 and the Kelvin-Voigt time ``tau`` (0: undamped), each with its own
    contact law: numba on the CPU, the CUDA kernel through CuPy on the GPU
    (``solver.ensemble``)."""
    from solver.ensemble import BatchedExplicit, BatchedProblem, array_namespace
    from solver.fused import friction_bound

    law0 = laws[0]
    bp = BatchedProblem.from_problem(problem, law0.dt, law0.beta2)
    return BatchedExplicit(
        bp, d=np.array([law.d for law in laws]), slide=np.array([law.slide for law in laws]),
        f=np.array([law.f for law in laws]), xp=array_namespace(backend),
        kernel="numba" if backend == "cpu" else "cuda", tau=tau, bound=friction_bound(law0))


def contact_work_observer(stepper, projection, with_friction: bool, u0):
    """The contact-work observer: the fused kernel accumulates the work itself
    (``FusedEnergy``), a numpy or implicit step needs ``EnergyAccumulator`` every step."""
    if getattr(stepper, "kernel", "numpy") == "numba":
        from solver.fused import FusedEnergy

        return FusedEnergy(stepper, projection)
    from solver.observers import EnergyAccumulator

    return EnergyAccumulator(projection, with_friction, u0)


def damping_work_observer(stepper, u0):
    """The Kelvin-Voigt work of a damped explicit stepper, None for any other: the fused
    kernel sums it itself (``FusedDampingWork``, no step hook), the numpy step needs
    ``DampingWork`` every step."""
    if not getattr(stepper, "damped", False):
        return None
    if getattr(stepper, "kernel", "numpy") == "numba":
        from solver.fused import FusedDampingWork

        return FusedDampingWork(stepper, u0)
    from solver.observers import DampingWork

    return DampingWork(stepper, u0)


class TimedContact:
    """The explicit contact step with its wall time summed in ``seconds`` (two clock reads a
    step, ~0.1 us; the numbers the projection computes are unchanged)."""

    def __init__(self, projection) -> None:
        self.projection = projection
        self.seconds = 0.0

    def __call__(self, u_trial, u_now, force) -> None:
        t0 = perf_counter()
        self.projection(u_trial, u_now, force)
        self.seconds += perf_counter() - t0
