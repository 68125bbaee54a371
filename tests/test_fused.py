"""The fused explicit step (solver/fused.py) against the numpy reference step.

Both compute the same scheme (solver/newmark.py docstring) element by element; only the sum
orders of K u (CSR pairs here, PETSc's MatMult there) and of the contact-work sums differ.
So on every scene below the two runs agree to round-off, statuses exactly.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

pytest.importorskip("dolfinx")
pytest.importorskip("numba")
from mpi4py import MPI  # noqa: E402

from stickslip.solver.run import Simulation  # noqa: E402
from stickslip.solver.scene import load_scene  # noqa: E402

SELF = MPI.COMM_SELF
STEPS = 300


def smoke(*overrides: str):
    return load_scene("scenes/smoke.toml", ["output.progress=false", *overrides])


def run(scene, kernel: str, comm=SELF, steps: int = STEPS):
    sim = Simulation(scene.with_overrides(f'time.kernel="{kernel}"'), comm)
    sim.proceed(end_time=np.inf, max_steps=steps)
    return sim


#: Kelvin-Voigt damping on the smoke scene: tau = 2 us, zeta = tau w / 2 ~ 2 % at 15 kHz
DAMPED = "damping.retardation_time=2e-6"

SCENES = {  # overrides, steps
    "p1-triangles": ((), STEPS),
    "quadrilaterals": (('mesh.cell="quadrilateral"',), STEPS),
    # P2: its flutter amplifies round-off 10x per 50 steps from step ~100 (measured: 7e-14
    # of max|u| at step 100, 3e-9 at step 300), so compare before the amplification
    "p2": (("mesh.degree=2", "mesh.n_inner=24"), 100),
    "frictionless": (("loading.f=0.0", "initial.amplitude=0.5"), STEPS),
    "beta2-half": (("time.beta2=0.5", "time.dt_fraction=0.8"), STEPS),
    "random-start": (('initial.perturbation="random"', "initial.seed=3"), STEPS),
}


@pytest.mark.parametrize("name", list(SCENES))
def test_fused_step_equals_the_numpy_step_to_round_off(name):
    """300 steps (t ~ 0.02 s on P1, contact statuses changing): u and the samples agree to 1e-11
    of max|u| (measured 1e-15 .. 1.5e-12, the largest with beta2 = 1/2, which has no numerical
    damping: the sum orders differ, and the flutter of steady sliding amplifies round-off
    ~700 /s), the status history exactly, the contact work to 1e-9 relative (a sum
    of ~1e4 terms of both signs, BLAS order against sequential order)."""
    overrides, steps = SCENES[name]
    sc = smoke(*overrides)
    ref, fused = run(sc, "numpy", steps=steps), run(sc, "numba", steps=steps)
    assert getattr(fused.integrator, "kernel", "") == "numba"
    assert getattr(ref.integrator, "kernel", "numpy") == "numpy"
    scale = np.max(np.abs(ref.integrator.u))
    assert np.max(np.abs(ref.integrator.u - fused.integrator.u)) < 1e-11 * scale
    assert np.max(np.abs(ref.integrator.v - fused.integrator.v)) < 1e-9 * np.max(
        np.abs(ref.integrator.v)) + 1e-300
    a, b = ref.recorder.arrays(), fused.recorder.arrays()
    np.testing.assert_array_equal(a["status"], b["status"])
    assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-11 * scale
    for k in range(2, 5):  # work_contact, work_cylinder, friction_dissipation
        ref_w, new_w = a["energies"][-1, k], b["energies"][-1, k]
        assert abs(ref_w - new_w) <= 1e-9 * max(abs(ref_w), 1e-30)
    if sc.loading.f > 0:
        assert len(np.unique(a["status"])) >= 2, "the scene must change contact statuses"


@pytest.mark.parametrize("damping", [(), (DAMPED,)], ids=["undamped", "damped"])
def test_compiled_time_loop_equals_the_step_by_step_loop(monkeypatch, damping):
    """One rank: ``proceed`` runs the steps between two samples as one ``advance`` call,
    which records the probes in its own pass. Against the same fused step called once per
    step with the probes a step hook: the state, the samples, statuses, probes, energies
    and work are bitwise equal (``advance`` calls ``single_step``; both record with the
    batch's ``BatchRecorder``, its energies the kernel's row-order sums, ``column_energies``).
    Damped, both take K u_n for the samples from ``refresh_ku``: W_d bitwise too."""
    from stickslip.solver.scene_explicit import SceneExplicit

    sc = smoke('initial.perturbation="random"', "initial.seed=3", *damping)
    fast = run(sc, "numba", steps=STEPS + 3)  # ends between two samples (every = 4)
    assert fast.integrator.compiled_loop
    monkeypatch.setattr(SceneExplicit, "compiled_loop", property(lambda self: False))
    slow = run(sc, "numba", steps=STEPS + 3)
    assert not slow.integrator.compiled_loop
    for name in ("u", "v", "a", "v_pred", "ku"):
        np.testing.assert_array_equal(getattr(fast.integrator, name),
                                      getattr(slow.integrator, name))
    assert fast.integrator.time == slow.integrator.time
    assert fast.integrator.step_count == slow.integrator.step_count == STEPS + 3
    a, b = fast.recorder.arrays(), slow.recorder.arrays()
    for key in ("t", "u_r", "u_theta", "v_r", "v_theta", "r_r", "r_theta", "status",
                "energies"):
        np.testing.assert_array_equal(a[key], b[key])
    pa, pb = fast.probes.arrays(), slow.probes.arrays()
    for key in pa:
        np.testing.assert_array_equal(pa[key], pb[key])


def test_summary_reports_the_kernel_and_its_first_call_time(tmp_path):
    from stickslip.studies.rundir import run_scene

    s = run_scene(smoke("time.max_steps=20"), tmp_path / "r", comm=SELF,
                  stream=open(os.devnull, "w"))
    assert s["scheme"]["kernel"] == "numba"
    assert 0.0 < s["scheme"]["kernel_first_call_s"] < 120.0  # compile, or load from cache


def test_fallback_rule():
    from stickslip.solver.schemes import select

    assert select.resolve_kernel(smoke()) == "numba"
    assert select.resolve_kernel(smoke('time.kernel="numpy"')) == "numpy"
    implicit = smoke("time.beta1=0.25", "time.beta2=0.5", "time.dt_fraction=2")
    assert select.resolve_kernel(implicit) == "numpy"


def test_numba_requested_without_numba_is_an_error(monkeypatch):
    from stickslip.solver.schemes import select

    monkeypatch.setattr(select, "numba_available", lambda: False)
    assert select.resolve_kernel(smoke()) == "numpy"  # auto falls back
    with pytest.raises(ValueError, match="numba"):
        select.resolve_kernel(smoke('time.kernel="numba"'))


def test_read_only_package_dir_gets_a_writable_numba_cache(monkeypatch, tmp_path):
    from stickslip.solver import fused

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    real_access = os.access
    here = os.path.dirname(os.path.realpath(fused.__file__))
    monkeypatch.setattr(os, "access", lambda p, mode: False if str(p) == here
                        else real_access(p, mode))
    fused._cache_dir()
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "stickslip-numba")


def test_bad_kernel_name_is_refused_with_the_choices():
    from stickslip.solver.scene import SceneError

    with pytest.raises(SceneError, match="kernel"):
        smoke('time.kernel="fortran"')


@pytest.mark.parallel
def test_fused_step_with_ghosts_equals_the_numpy_step():
    """On COMM_WORLD (2 ranks under mpirun): the kernel reads ghost values refreshed by
    PETSc's ghostUpdate. Two builds of the mesh may be partitioned differently (measured:
    12 or 14 ghost dofs on the smoke mesh), so the runs are compared through the recorder's
    gathered, angle-ordered samples: u_r and u_theta to 1e-11 of max|u_r| (round-off, as in
    the serial comparison), statuses exactly, contact work to 1e-9 relative."""
    sc = smoke()
    ref, fused = run(sc, "numpy", MPI.COMM_WORLD), run(sc, "numba", MPI.COMM_WORLD)
    assert getattr(fused.integrator, "kernel", "") == "numba"
    if MPI.COMM_WORLD.rank == 0:
        a, b = ref.recorder.arrays(), fused.recorder.arrays()
        # the three works at the last sample, each summed over the ranks
        assert np.allclose(a["energies"][-1, 2:5], b["energies"][-1, 2:5], rtol=1e-9, atol=0)
        np.testing.assert_array_equal(a["theta"], b["theta"])
        np.testing.assert_array_equal(a["status"], b["status"])
        scale = np.max(np.abs(a["u_r"]))
        assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-11 * scale
        assert np.max(np.abs(a["u_theta"] - b["u_theta"])) < 1e-11 * scale



@pytest.mark.parametrize("beta2", [0.6, 0.5])
def test_damped_fused_step_equals_the_damped_numpy_step_to_round_off(beta2):
    """Kelvin-Voigt damping in the fused kernel against the numpy kernel (K w_n by
    PETSc MatMult, ``DampingWork`` as a step hook), 300 steps: the same operations, only the
    sum orders of K w and of the dot products differ. u to 1e-11 of max|u| and the samples
    as for the undamped scenes above (measured 3e-13 at beta2 = 0.6); statuses exactly; the
    energies, the three contact works and W_d to 1e-9 relative (measured 3e-14: sums of
    ~1e4 terms of both signs in two orders). The fused run keeps its compiled time loop
    (the damping work is summed in the kernel, no step hook)."""
    sc = smoke(DAMPED, f"time.beta2={beta2}")
    ref, fused = run(sc, "numpy"), run(sc, "numba")
    assert ref.integrator.damped and ref.integrator.kernel == "numpy"
    assert not ref.integrator.compiled_loop  # its work observers are step hooks
    assert fused.integrator.damped and fused.integrator.compiled_loop
    scale = np.max(np.abs(ref.integrator.u))
    assert np.max(np.abs(ref.integrator.u - fused.integrator.u)) < 1e-11 * scale
    assert np.max(np.abs(ref.integrator.v - fused.integrator.v)) < 1e-9 * np.max(
        np.abs(ref.integrator.v))
    a, b = ref.recorder.arrays(), fused.recorder.arrays()
    np.testing.assert_array_equal(a["status"], b["status"])
    assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-11 * scale
    ea, eb = a["energies"], b["energies"]
    assert ea[-1, 5] > 0.01 * (ea[-1, 0] + ea[-1, 1])  # the damping does work
    np.testing.assert_allclose(eb, ea, rtol=1e-9, atol=1e-9 * np.abs(ea).max())
    assert fused.facts()["scheme"]["damping_tau_s"] == 2e-6


def test_damped_and_regularised_scenes_get_the_fused_kernel_and_the_filter_does_not():
    from stickslip.solver.schemes import select

    for extra in ((DAMPED,), PRAKASH_CLIFTON, CONSTANT_TIME):
        assert select.resolve_kernel(smoke(*extra)) == "numba"
        assert select.batchable(smoke(*extra))
    assert select.resolve_kernel(smoke(DAMPED, 'time.kernel="numpy"')) == "numpy"
    filtered = smoke(DAMPED, 'friction.filter="1-2-1"')
    assert select.resolve_kernel(filtered) == "numpy" and not select.batchable(filtered)


#: regularised friction bounds (``solver.contact.nodal.EffectivePressure``): a slip length
#: comparable to the slip per period, and a relaxation time of 5 steps
PRAKASH_CLIFTON = ('friction.regularization="prakash-clifton"', "friction.slip_length=2e-5",
                   "friction.reference_velocity=1.0")
CONSTANT_TIME = ('friction.regularization="constant-time"', "friction.relaxation_time=4e-4")


@pytest.mark.parametrize("extra", [PRAKASH_CLIFTON, CONSTANT_TIME, (*PRAKASH_CLIFTON, DAMPED)],
                         ids=["prakash-clifton", "constant-time", "prakash-clifton-damped"])
def test_regularised_fused_step_equals_the_numpy_step_to_round_off(extra):
    """The regularised friction bound f sigma_eff in the fused kernel against the numpy
    projection (``RegularizedContactProjection``), 300 steps: the same operations but for
    the sum orders and exp (numpy's SIMD exp against libm's, both within 1 ulp). u and the
    samples to 1e-11 of max|u| as the Coulomb scenes, statuses exactly, the energies and
    the effective pressure (the kernel updates the projection's own ``EffectivePressure``
    arrays) to 1e-9 relative (measured 5e-13)."""
    sc = smoke(*extra)
    ref, fused = run(sc, "numpy"), run(sc, "numba")
    assert fused.integrator.batch.reg > 0 and fused.integrator.compiled_loop
    scale = np.max(np.abs(ref.integrator.u))
    assert np.max(np.abs(ref.integrator.u - fused.integrator.u)) < 1e-11 * scale
    a, b = ref.recorder.arrays(), fused.recorder.arrays()
    np.testing.assert_array_equal(a["status"], b["status"])
    assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-11 * scale
    ea, eb = a["energies"], b["energies"]
    np.testing.assert_allclose(eb, ea, rtol=1e-9, atol=1e-9 * np.abs(ea).max())
    sa, sb = ref.columns.projection.effective.sigma, fused.columns.projection.effective.sigma
    assert np.abs(sa).max() > 0.0
    np.testing.assert_allclose(sb, sa, rtol=0, atol=1e-9 * np.abs(sa).max())


def test_a_friction_law_written_in_the_law_alone_runs_in_the_kernel(monkeypatch):
    """A regularised bound the kernels can express is a ``Regularisation`` subclass in
    ``solver/contact/law.py`` and nothing else: the kernels take its code and its two rates
    (``ContactLaw.kernel_bound``), the numpy projection its rates, the scene its name and
    required keys. Here a law defined in this test only, d sigma_eff/dt = -|V|/L (sigma_eff
    - p), registered as the module does, runs in the fused kernel and agrees with the numpy
    step as the shipped laws do (tolerances of the test above)."""
    from dataclasses import dataclass

    from stickslip.solver.contact import law as law_module
    from stickslip.solver.scene import sections

    @dataclass(frozen=True)
    class SlipDistance(law_module.Regularisation):
        slip_length: float = 0.0
        name = "slip-distance"  # class attributes (the module's are ClassVar-annotated)
        code = 3
        compiled = True
        required = {"slip_length": ("m", "")}

        def rates(self, dt: float) -> tuple[float, float]:
            return 1.0 / (dt * self.slip_length), 0.0

    monkeypatch.setitem(law_module.REGULARISATIONS, SlipDistance.name, SlipDistance)
    monkeypatch.setattr(sections, "REGULARIZATIONS",
                        (*sections.REGULARIZATIONS, SlipDistance.name))
    sc = smoke('friction.regularization="slip-distance"', "friction.slip_length=2e-5")
    ref, fused = run(sc, "numpy"), run(sc, "numba")
    assert fused.integrator.batch.reg == 3 and fused.integrator.compiled_loop
    scale = np.max(np.abs(ref.integrator.u))
    assert np.max(np.abs(ref.integrator.u - fused.integrator.u)) < 1e-11 * scale
    a, b = ref.recorder.arrays(), fused.recorder.arrays()
    np.testing.assert_array_equal(a["status"], b["status"])
    sa, sb = ref.columns.projection.effective.sigma, fused.columns.projection.effective.sigma
    assert np.abs(sa).max() > 0.0
    np.testing.assert_allclose(sb, sa, rtol=0, atol=1e-9 * np.abs(sa).max())


@pytest.mark.parallel
def test_damped_fused_step_with_ghosts_equals_the_numpy_step():
    """Damped on COMM_WORLD (2 ranks under mpirun): the ghosts K reads are those of
    w_n = u_n + tau v~_n (refreshed per step), and those of u_n at the samples' K u_n.
    Tolerances as the undamped comparison above; W_d (summed over ranks) to 1e-9 relative."""
    sc = smoke(DAMPED)
    ref, fused = run(sc, "numpy", MPI.COMM_WORLD), run(sc, "numba", MPI.COMM_WORLD)
    assert fused.integrator.damped
    if MPI.COMM_WORLD.rank == 0:
        a, b = ref.recorder.arrays(), fused.recorder.arrays()
        np.testing.assert_array_equal(a["status"], b["status"])
        scale = np.max(np.abs(a["u_r"]))
        assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-11 * scale
        ea, eb = a["energies"], b["energies"]
        assert ea[-1, 5] > 0.0
        np.testing.assert_allclose(eb, ea, rtol=1e-9, atol=1e-9 * np.abs(ea).max())
