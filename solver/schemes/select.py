"""The scheme registry: the one place that knows the time schemes, their kernels and backends.

As Dedalus' ``@add_scheme`` and ``timesteppers.schemes[name]``: each time scheme is an object
in ``SCHEMES``, registered with ``add_scheme``. ``for_scene(scene)`` is the one question a run
asks; the scheme it returns knows the rest (gusto's scheme objects handed to a timestepper):

* ``time_step(scene, omega_max)``: its stability limit and the step (with advice);
* ``build(problem, scene, omega_max)``: ``SchemeParts``, its step (``time_step``), its stepper
  and contact step, and ``scene_records`` (the samples, probes and work observers, as its
  kernel records them);
* ``batchable(scene)`` and ``build_batch(bp, laws, backend, tau)``: B scenes as the
  columns of one stepper (the explicit scheme only);
* ``kernel(scene)``: the step kernel, chosen once here and then a strategy inside the stepper.

Every branch on ``time.beta1`` (explicit or implicit), on the kernel (numpy, numba, CUDA) and
on the backend (cpu, gpu) that decides what runs lives in this module; tests/test_architecture.py
checks that no other module branches on them or duck-types a stepper.

* ``beta1 = 0``: the paper's explicit Newmark, the batch ``solver.ensemble.BatchedExplicit``
  of B scenes or, one scene, of one (``solver.scene_explicit.SceneExplicit``), with the
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
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from stickslip.solver.columns import SceneRecords
from stickslip.solver.contact import ContactLaw, make_projection
from stickslip.solver.contact.surface import SurfaceContactProjection
from stickslip.solver.ensemble import BatchedExplicit, array_namespace
from stickslip.solver.ensemble_observers import one_scene_records
from stickslip.solver.errors import StepTooLarge
from stickslip.solver.fused import friction_bound
from stickslip.solver.fused import numba_available as available
from stickslip.solver.newmark import critical_time_step
from stickslip.solver.observers import (
    DampingWork,
    EnergyAccumulator,
    SteppedColumn,
    SurfaceWork,
)
from stickslip.solver.scene import Scene
from stickslip.solver.scene_explicit import DampingStart, scene_explicit

__all__ = [
    "SCHEMES", "BACKENDS", "Scheme", "SchemeParts", "add_scheme", "for_scene", "check_backend",
    "time_step", "resolve_kernel", "unsteppable", "batchable", "STEP_WARNING",
    "shortest_wave_period", "stability_advice", "damping_advice",
]

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



# ------------------------------------------------------------------------------ registry

#: The registered time schemes by name (``add_scheme``), in the order ``for_scene`` asks them.
SCHEMES: dict[str, Scheme] = {}


class Scheme(Protocol):
    """What a registered time scheme offers a run (see the module docstring)."""

    name: str

    def applies_to(self, scene: Scene) -> bool:
        """True when ``scene``'s ``[time]`` table selects this scheme."""

    def time_step(self, scene: Scene, omega_max: float) -> tuple[float, float]:
        """(dt, dt_crit): the step (checked against the scheme's limit) and the explicit
        limit, the unit of ``time.dt_fraction``."""

    def kernel(self, scene: Scene) -> str:
        """The step kernel ``scene`` runs with ("numpy", "numba")."""

    def build(self, problem, scene: Scene, omega_max: float) -> SchemeParts:
        """The step (``time_step``), the stepper, its contact step and its work observers."""

    def batchable(self, scene: Scene) -> bool:
        """True when ``scene`` can run as a column of a batch."""

    def build_batch(self, bp, laws: list[ContactLaw], backend: str, tau: float):
        """The batched stepper of scenes sharing K and M (``solver.ensemble.BatchedProblem``
        ``bp``), dt, beta_2 and ``tau``."""


def add_scheme(name: str) -> Callable[[type], type]:
    """Class decorator: register an instance of the class as ``SCHEMES[name]``."""

    def register(cls: type) -> type:
        scheme = cls()
        scheme.name = name
        SCHEMES[name] = scheme
        return cls

    return register


def for_scene(scene: Scene) -> Scheme:
    """THE question a run asks: the registered scheme that ``scene``'s ``[time]`` selects."""
    for scheme in SCHEMES.values():
        if scheme.applies_to(scene):
            return scheme
    raise ValueError(f"no time scheme for time.beta1 = {scene.time.beta1}: use 0 (explicit) "
                     "or > 0 (implicit)")


@dataclass
class SchemeParts:
    """What a scheme builds for one scene: the stepper (``solver.stepper.Stepper``),
    its contact step (``out``: r_r, r_t, status; ``slide``; the nodes' frames, as the
    observers use them), ``records``, which makes the scene's records as the kernel takes
    them (``scene_records``), the step ``dt`` with the explicit limit ``dt_crit``
    (``Scheme.time_step``) and the ``scene`` they were built for."""

    stepper: Any
    contact: Any
    records: Callable[..., SceneRecords]
    dt: float = math.nan
    dt_crit: float = math.nan
    scene: Scene | None = None

    def scene_records(self, problem, every: int, n_steps: int,
                      u0: np.ndarray) -> SceneRecords:
        """The scene's samples (every ``every`` steps, ``n_steps`` planned), probes and work
        observers from u_0 (``solver.columns.SceneRecords``), the step hooks among them
        attached to the stepper (the work observers first, then the probes)."""
        return self.records(self, problem, every, n_steps, u0)


def time_step(scene: Scene, omega_max: float) -> tuple[float, float]:
    """(dt, dt_crit) of ``scene``'s scheme (``Scheme.time_step``)."""
    return for_scene(scene).time_step(scene, omega_max)


def resolve_kernel(scene: Scene) -> str:
    """The step kernel of ``scene``'s scheme (``Scheme.kernel``)."""
    return for_scene(scene).kernel(scene)


def unsteppable(scene: Scene) -> str | None:
    """Why ``scene``'s scheme cannot step it (``Scheme.kernel`` refuses it: one line that
    names the fix), or None: asked before anything is meshed or made (a run, a sweep's
    variants, a census's base scene)."""
    try:
        resolve_kernel(scene)
    except ValueError as err:
        return str(err)
    return None


def batchable(scene: Scene) -> bool:
    """True when ``scene`` can run as a column of a batch (``Scheme.batchable``)."""
    return for_scene(scene).batchable(scene)


def _checked_step(scene: Scene, omega_max: float, dt_crit: float, limit: float,
                  why: tuple[str, str, str]) -> tuple[float, float]:
    """(dt, dt_crit): ``time.dt`` or ``dt_fraction * dt_crit``, refused above ``limit``
    (``why``: the scheme, the limit's rule and a fix, named in the message), with the
    stability advice printed."""
    ts = scene.time
    dt = ts.dt if ts.dt > 0.0 else ts.dt_fraction * dt_crit
    if dt > limit:
        what, rule, fix = why
        raise StepTooLarge(
            f"time.dt = {dt:.4g} s is above the {what} stability limit "
            f"dt_crit = {rule} = {limit:.4g} s "
            f"(omega_max = {omega_max:.4g} rad/s, beta2 = {ts.beta2}). Use "
            f"time.dt <= {limit:.4g}, or time.dt = 0 with time.dt_fraction <= "
            f"{limit / dt_crit:.4g}" + fix
        )
    advice = stability_advice(scene, dt, dt_crit)
    damped = damping_advice(scene, omega_max)
    if damped:
        advice = f"{advice}\n{damped}" if advice else damped
    if advice and _rank0():
        print(advice, file=sys.stderr, flush=True)
    return dt, dt_crit


# ------------------------------------------------------------------------------ explicit

def numba_available() -> bool:
    """True when numba imports (Debian's python3-numba is in the apt list)."""
    return available()


#: The batched step's kernel on each backend (``solver.ensemble.BATCH_KERNELS``).
BACKENDS = {"cpu": "numba", "gpu": "cuda"}


def check_backend(backend: str, batched: bool = True, device: bool = True) -> None:
    """Refuse a backend this run cannot use (ValueError or ImportError naming the fix): "gpu"
    needs CuPy, with ``device`` a CUDA device too, and runs batches only (``batched``)."""
    if backend not in tuple(BACKENDS):
        raise ValueError(f"backend = {backend!r}: use one of {tuple(BACKENDS)}")
    if BACKENDS[backend] != "cuda":
        return

    xp = array_namespace(backend)
    if device:
        try:  # CuPy imports without a driver or a device; the first allocation fails
            devices, why = xp.cuda.runtime.getDeviceCount(), ""
        except RuntimeError as err:
            devices, why = 0, f" ({err})"
        if devices < 1:
            raise ValueError(f"--backend gpu: CuPy finds no CUDA device{why}; run on a "
                             "GPU node or use --backend cpu")
    if not batched:
        raise ValueError("--backend gpu runs batches: add --batch auto or --batch B")


def continuing_backend(backend: str) -> str:
    """Where a batch member's checkpoint of ``backend`` goes on: on its own backend, but a
    GPU's on the CPU where CuPy or a CUDA device is missing. The dynamics are the same bits
    on both kernels (``solver.ensemble.BatchedExplicit.restore`` adopts the other layout),
    so a GPU node's census starts are continued where dolfinx is; the summary's
    ``batch.backend`` names the backend that ran the continuation."""
    if BACKENDS.get(backend) == "cuda":
        try:
            check_backend(backend)
        except (ValueError, ImportError):
            return "cpu"
    return backend


def moved_backends(backends: list[str], here: dict[str, str]) -> list[str]:
    """One line per backend whose batch checkpoints (``backends``, one per run) go on
    elsewhere (``here``: ``continuing_backend`` of each): how many, from where to where."""
    moved = {there: backends.count(there) for there in sorted(here) if here[there] != there}
    return [f"{n} checkpoint(s) of the {there} backend continue on the {here[there]} (no "
            f"CUDA device here): the same dynamics, bit for bit; the summaries' "
            f"batch.backend says {here[there]}" for there, n in moved.items()]


def check_continuing_kernel(kernel: str, stepper) -> None:
    """A one-scene run continues bitwise only with the kernel it stepped with (its
    checkpoint's ``kernel``, "" for the implicit scheme): ValueError naming the fix when the
    ``stepper`` built here for its scene runs another."""
    built = stepper.facts().get("kernel", "")
    if built != kernel:
        raise ValueError(f"the run stepped with the {kernel or 'implicit'} kernel, this "
                         f"machine builds {built or 'implicit'} for its scene: install "
                         "the same (python3-numba) to continue it bitwise")


def _numpy_records(parts: SchemeParts, problem, every: int, n_steps: int,
                   u0: np.ndarray) -> SceneRecords:
    """The numpy step's records (``one_scene_records`` of a ``SteppedColumn``) with its
    work observers, both step hooks: ``EnergyAccumulator`` and, damped, ``DampingWork``."""
    stepper, contact, scene = parts.stepper, parts.contact, parts.scene
    work = SurfaceWork if isinstance(contact, SurfaceContactProjection) else EnergyAccumulator
    energy = work(contact, scene.loading.f > 0.0, u0)
    stepper.attach(energy)
    damping = DampingWork(stepper, u0) if stepper.damped else None
    if damping is not None:
        stepper.attach(damping)
    return _stepped_records(parts, problem, every, n_steps, energy, damping)


def _stepped_records(parts: SchemeParts, problem, every: int, n_steps: int,
                     energy: EnergyAccumulator, damping) -> SceneRecords:
    """The records of a stepper that is no batch, with its work observers (checkpoint
    parts ``energy`` and ``damping``)."""
    column = SteppedColumn(parts.stepper, parts.contact, problem.mass, energy, damping)
    named = {"energy": energy} if damping is None else {"energy": energy, "damping": damping}
    return one_scene_records(column, parts.stepper, problem, parts.contact,
                             parts.scene.output.probes_deg, every, n_steps, named)


def _numba_records(parts: SchemeParts, problem, every: int, n_steps: int,
                   u0: np.ndarray) -> SceneRecords:
    """The numba step's records: a batch of one's (``one_scene_records``); the kernel sums
    the contact and damping work, so no work observer is a step hook and the compiled loop
    stays."""
    stepper = parts.stepper
    named = {"damping": DampingStart(stepper)} if stepper.damped else {}
    return one_scene_records(stepper.batch, stepper, problem, parts.contact,
                             parts.scene.output.probes_deg, every, n_steps, named)


def _numpy_parts(problem, law: ContactLaw, tau: float, projection) -> SchemeParts:
    """The numpy step: the scene as a batch of one (``solver.scene_explicit``) with its own
    K product and the projection, timed, as its contact step."""
    return SchemeParts(scene_explicit(problem, law, projection, tau, "numpy"), projection,
                       _numpy_records)


def _numba_parts(problem, law: ContactLaw, tau: float, projection) -> SchemeParts:
    """The numba step: the scene as a batch of one (``solver.scene_explicit``), which runs
    the projection's law inside its kernel and writes into the projection's arrays."""
    return SchemeParts(scene_explicit(problem, law, projection, tau, "numba"), projection,
                       _numba_records)


#: The explicit scheme's kernels: each builds the stepper and its work observers.
EXPLICIT_KERNELS: dict[str, Callable[..., SchemeParts]] = {
    "numpy": _numpy_parts, "numba": _numba_parts}


@add_scheme("explicit")
class ExplicitNewmarkScheme:
    """The paper's explicit Newmark (beta_1 = 0) with the forward-increment contact step."""

    name = "explicit"

    def applies_to(self, scene: Scene) -> bool:
        return scene.time.beta1 == 0.0

    def time_step(self, scene: Scene, omega_max: float) -> tuple[float, float]:
        """dt_crit = sqrt(2 / beta2) / omega_max, or with Kelvin-Voigt damping tau the damped
        limit (``critical_time_step``): the unit of ``time.dt_fraction`` and the bound."""
        tau, b2 = scene.damping.tau, scene.time.beta2
        dt_crit = critical_time_step(omega_max, 0.0, b2, tau)
        rule = ("4/(omega_max^2 (tau + sqrt(tau^2 + 8 beta2/omega_max^2)))" if tau > 0.0
                else "sqrt(2/beta2)/omega_max")
        return _checked_step(scene, omega_max, dt_crit, dt_crit, ("explicit", rule, ""))

    def kernel(self, scene: Scene) -> str:
        """``"numba"`` or ``"numpy"``: ``surface_kernel``, else ``law_kernel`` of the
        scene's contact law."""
        return (self.surface_kernel(scene)
                or self.law_kernel(scene.time.kernel, ContactLaw.from_scene(scene, 1.0)))

    def surface_kernel(self, scene: Scene) -> str:
        """"numpy" for a 3D tube's contact surface (the disc cone of
        ``solver.contact.surface`` has the numpy step; ValueError naming the fix where
        ``time.kernel = "numba"`` asks otherwise), "" for a plane-strain scene."""
        if scene.mesh.dim != 3:
            return ""
        if scene.time.kernel == "numba":
            raise ValueError("time.kernel = \"numba\" with mesh.dim = 3: the 3D tube's "
                             "contact surface steps with numpy; set time.kernel = "
                             "\"numpy\" or \"auto\"")
        return "numpy"

    def law_kernel(self, requested: str, law: ContactLaw) -> str:
        """The kernel for ``time.kernel = requested`` and ``law``. THE fallback rule:

        * physics the fused kernel does not implement (a friction bound without
          ``ContactLaw.kernel_bound``: the 1-2-1 filtered bound) falls back to "numpy";
          Kelvin-Voigt ``[damping]`` and the regularised bounds (Prakash-Clifton, constant
          time) are in the fused and batched kernels (the numpy step's operations, to
          round-off);
        * ``time.kernel = "auto"``: "numba" when numba imports, else "numpy";
        * ``time.kernel = "numba"`` without numba: ValueError naming the fix.
        """
        try:
            law.kernel_bound()
        except ValueError:
            return "numpy"  # the filtered projection, or a bound the kernels do not know
        if requested == "numpy":
            return "numpy"
        if numba_available():
            return "numba"
        if requested == "numba":
            raise ValueError("time.kernel = \"numba\" but numba does not import: install "
                             "python3-numba (apt) or set time.kernel = \"numpy\"")
        return "numpy"

    def build(self, problem, scene: Scene, omega_max: float) -> SchemeParts:
        """The kernel's stepper (``EXPLICIT_KERNELS``) with ``make_projection``'s step, at
        the step ``time_step`` gives."""
        dt, dt_crit = self.time_step(scene, omega_max)
        surface = self.surface_kernel(scene)
        law = ContactLaw.from_scene(scene, dt)
        kernel = surface or self.law_kernel(scene.time.kernel, law)
        parts = EXPLICIT_KERNELS[kernel](problem, law, scene.damping.tau,
                                         make_projection(problem, law))
        parts.dt, parts.dt_crit, parts.scene = dt, dt_crit, scene
        return parts

    def batchable(self, scene: Scene) -> bool:
        """The fused numba kernel's physics and no field output."""
        if scene.output.fields:
            return False
        try:
            return self.kernel(scene) == "numba"
        except ValueError:
            return False

    def build_batch(self, bp, laws: list[ContactLaw], backend: str, tau: float):
        """``BatchedExplicit`` of the scenes of ``laws`` (one column each) on the shared
        ``solver.ensemble.BatchedProblem`` ``bp``, on ``backend``: numba on the CPU, the
        CUDA kernel through CuPy on the GPU (``BACKENDS``)."""
        law0 = laws[0]
        return BatchedExplicit(
            bp, d=np.array([law.d for law in laws]),
            slide=np.array([law.slide for law in laws]), f=np.array([law.f for law in laws]),
            xp=array_namespace(backend), kernel=BACKENDS[backend], tau=tau,
            bound=friction_bound(law0))


# ------------------------------------------------------------------------------ implicit

def _implicit_records(parts: SchemeParts, problem, every: int, n_steps: int,
                      u0: np.ndarray) -> SceneRecords:
    """The implicit step's records (``one_scene_records`` of a ``SteppedColumn``): the
    contact work a step hook with the exact bookkeeping of its contact solve, the damping
    work booked by the stepper."""
    # PETSc for the implicit scheme only: a node without it imports the registry
    from stickslip.solver.implicit import ImplicitDampingWork

    stepper, contact, scene = parts.stepper, parts.contact, parts.scene
    energy = EnergyAccumulator(contact, scene.loading.f > 0.0, u0, exact_work=True)
    stepper.attach(energy)
    damping = ImplicitDampingWork() if stepper.damped else None
    return _stepped_records(parts, problem, every, n_steps, energy, damping)


@add_scheme("implicit")
class ImplicitNewmarkScheme:
    """Implicit Newmark (beta_1 > 0): the active-set contact solve on the Schur complement."""

    name = "implicit"

    def applies_to(self, scene: Scene) -> bool:
        return scene.time.beta1 > 0.0

    def time_step(self, scene: Scene, omega_max: float) -> tuple[float, float]:
        """dt_crit is the undamped EXPLICIT limit (the unit of ``time.dt_fraction``; the
        damping is implicit); with 2 beta1 < beta2 the scheme's own limit is checked."""
        ts = scene.time
        dt_crit = critical_time_step(omega_max, 0.0, ts.beta2)
        limit = critical_time_step(omega_max, ts.beta1, ts.beta2)
        why = (f"beta1 = {ts.beta1}, beta2 = {ts.beta2}", "1/(omega_max sqrt(beta2/2 - beta1))",
               ", or 2 beta1 >= beta2 (unconditionally stable)")
        return _checked_step(scene, omega_max, dt_crit, limit, why)

    def kernel(self, scene: Scene) -> str:
        """"numpy": no fused step (the step is a linear solve; ``time.kernel`` is ignored);
        ValueError for a 3D tube, whose contact surface has no implicit solve."""
        if scene.mesh.dim == 3:
            raise ValueError("time.beta1 > 0 with mesh.dim = 3: the implicit contact solve "
                             "is plane strain only; run the 3D tube with time.beta1 = 0")
        return "numpy"

    def build(self, problem, scene: Scene, omega_max: float) -> SchemeParts:
        """``ImplicitNewmark`` with its active-set contact, at the step ``time_step`` gives."""
        # PETSc for the implicit scheme only: a node without it imports the registry
        from stickslip.solver.implicit import ImplicitContact, ImplicitNewmark

        self.kernel(scene)  # a 3D tube's refusal
        dt, dt_crit = self.time_step(scene, omega_max)
        ts, law = scene.time, ContactLaw.from_scene(scene, dt)
        contact = ImplicitContact(problem.nodes, law.d, law.f, law.surface_speed,
                                  problem.comm)
        stepper = ImplicitNewmark(problem.K, problem.mass, problem.clamped, dt, ts.beta1,
                                  ts.beta2, contact, problem.comm, tau=scene.damping.tau)
        return SchemeParts(stepper, contact, _implicit_records, dt, dt_crit, scene)

    def batchable(self, scene: Scene) -> bool:
        return False

    def build_batch(self, bp, laws: list[ContactLaw], backend: str, tau: float):
        raise ValueError("the implicit scheme runs one scene at a time (no batch)")
