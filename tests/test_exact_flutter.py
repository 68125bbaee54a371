"""Exact continuum flutter of steady sliding (``exact/``, ``stickslip flutter-exact``).

Checks: the Bessel determinant and the Chebyshev collocation (two independent discretisations
of the same boundary-value problem) give the same roots; f = 0 reproduces the brentq Bessel
frequencies of flutter-fe's verification; the half-space threshold is f_c = 1 (closed form
x = 2 on the real axis) by bisection on the quartic and by the argument principle; the annulus
is bounded in n below f_c and grows like the half-space (∝ n) above it; Kelvin-Voigt damping
and Prakash-Clifton friction; flutter-fe converges to it at O(h²); the CLI.
Timings (shared 2-core machine, noisy): ~45 s for all 27 tests, ~15 s without the five FE ones;
the parallel one ~25 s under mpirun -n 2.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
import pytest

from stickslip.exact import halfspace
from stickslip.exact.annulus import Elastic, annulus_sliding_frequencies
from stickslip.exact.sliding_flutter import ELASTIC, Dissipation, sliding_branches

MAT = Elastic(E=1.0e9, rho=1000.0, nu=0.3, R=1.0, xi=1.25)  # the paper's tube


def _omegas(sp) -> np.ndarray:
    return np.array([complex(b.omega_re, b.omega_im) for b in sp.branches])


def _best(n: int, f: float, diss: Dissipation = ELASTIC) -> float:
    """Fastest growth of order n over the branches with phase speed ≤ 1.5 c_p."""
    return sliding_branches(n, f, MAT, fmax_hz=3000.0, speed_factor=1.5,
                            diss=diss).most_unstable().growth_rate


# --------------------------------------------------------------------------- the annulus


@pytest.mark.parametrize("n", [0, 3, 40])
def test_collocation_and_bessel_determinant_agree(n: int) -> None:
    """Every collocation eigenvalue in the band converges under the secant polish on the Bessel
    determinant to within 1e-9 (measured ≤ 7e-14 up to n = 200: the collocation is spectrally
    accurate and the determinant is exact), and no two seeds land on the same root."""
    sp = sliding_branches(n, 0.7, MAT, fmax_hz=6000.0)
    assert sp.branches and all(b.polished for b in sp.branches)
    assert max(b.shift for b in sp.branches) < 1e-9
    w = _omegas(sp)
    assert len(set(np.round(w / abs(w).max(), 10))) == w.size


def test_f0_is_real_doubly_degenerate_and_matches_the_brentq_frequencies() -> None:
    """At f = 0 every root is real (|Im ω| ≤ 1e-9 |ω|), comes as ±ω (the two directions) and
    equals the brentq roots of the real determinant (flutter-fe's reference) to 1e-9."""
    for n in (1, 4, 8):
        sp = sliding_branches(n, 0.0, MAT, fmax_hz=3000.0)
        w = _omegas(sp)
        assert np.all(np.abs(w.imag) <= 1e-9 * np.abs(w))
        pos = np.sort(w.real[w.real > 0])
        np.testing.assert_allclose(pos, np.sort(-w.real[w.real < 0]), rtol=1e-9)
        ref = annulus_sliding_frequencies(n, MAT.R, MAT.xi, MAT.E, MAT.nu, MAT.rho, 3000.0,
                                          df_hz=5.0)
        np.testing.assert_allclose(pos / (2 * math.pi), ref, rtol=1e-9)


def test_friction_splits_each_pair_into_a_growing_and_a_decaying_wave() -> None:
    """Undamped: the roots are ±sqrt(μ), so every growing wave has a decaying partner of the
    same frequency travelling the other way (growth sums to 0 to 1e-9 ω). Published-style
    numbers of the Figure-3 tube (f = 0.7, n = 4), recorded here and in docs/continuum.md:
    945.65 Hz +29.08 /s (rotation), 1851.60 Hz +1085.21 /s (opposite), 2457.99 Hz +1282.41 /s
    (rotation); a regression tolerance of 1e-6 (the polish converges to 1e-12)."""
    sp = sliding_branches(4, 0.7, MAT, fmax_hz=3000.0)
    grow = [b for b in sp.branches if b.growth_rate > 0]
    for b in grow:
        partner = min(sp.branches, key=lambda c: abs(c.omega_re + b.omega_re)
                      + abs(c.omega_im + b.omega_im))
        assert abs(partner.growth_rate + b.growth_rate) < 1e-9 * abs(b.omega_re)
        assert partner.direction != b.direction
    got = [(round(b.frequency_hz, 2), round(b.growth_rate, 2), b.direction) for b in grow]
    want = [(945.65, 29.08, "rotation"), (1851.60, 1085.21, "opposite"),
            (2457.99, 1282.41, "rotation")]
    for (f1, g1, d1), (f2, g2, d2) in zip(got, want, strict=True):
        assert abs(f1 - f2) <= 0.011 and abs(g1 - g2) <= 0.011 and d1 == d2


# --------------------------------------------------------------------------- half-space


@pytest.mark.parametrize("nu", [0.2, 0.3, 0.4])
def test_halfspace_threshold_is_one(nu: float) -> None:
    """f_c(ν) = 1: on the real axis c = −√2 c_s + i0 (x = 2, a = sqrt(ν/(1−ν)), b = +i) the
    dispersion relation reads i a (1 − f) = 0 (closed form). The bisection on the quartic's
    roots finds it to 1e-6 (its growth floor Im c > 1e-13 costs ~1e-7)."""
    assert abs(halfspace.threshold(nu) - 1.0) < 1e-6
    c = -math.sqrt(2.0) + 1e-12j
    assert abs(halfspace.dispersion(c, 1.0, nu)) < 1e-9


def test_halfspace_roots_by_quartic_and_argument_principle_agree() -> None:
    """Two independent counts of growing roots (quartic + check in the principal-branch
    relation, and the winding number of G along the upper half-plane's boundary): none for
    f = 0.3, 0.7, 0.99; one for f = 1.01, 1.5, 2 at ν = 0.3, travelling against the sliding of
    the rigid plane (Re c < 0) near −√2 c_s (between c_s and c_p)."""
    for f in (0.3, 0.7, 0.99, 1.01, 1.5, 2.0):
        roots = halfspace.growing_roots(f, 0.3)
        assert roots.size == halfspace.argument_principle_count(f, 0.3) == (1 if f > 1 else 0)
        for z in roots:
            assert abs(halfspace.dispersion(z, f, 0.3)) < 1e-9
            assert -1.45 < z.real < -1.40
    z = halfspace.growing_roots(1.5, 0.3)[0]
    assert abs(z - (-1.41445 + 0.175459j)) < 2e-5  # recorded in docs/continuum.md


# --------------------------------------------------------------------------- the threshold


def test_annulus_growth_bounded_below_fc_and_proportional_to_n_above() -> None:
    """f = 0.7 < f_c: the fastest growth over n = 100 → 200 barely moves (measured 1453 →
    1552 /s; the exact sup over n ≤ 200 is ~1553 /s, on the layer's guided waves), so the test
    allows a ratio < 1.2 and a value < 2000 /s. f = 1.5 > f_c: it doubles with n (measured
    10514 → 21444 /s, ratio 2.04; allowed 1.9..2.1) and approaches the half-space growth
    n c_s Im c / R (21760 /s at n = 200; measured 0.985 of it; allowed 3 %)."""
    g100, g200 = _best(100, 0.7), _best(200, 0.7)
    assert g200 / g100 < 1.2 and g200 < 2000.0
    h100, h200 = _best(100, 1.5), _best(200, 1.5)
    assert 1.9 < h200 / h100 < 2.1
    hs = halfspace.growing_roots(1.5, MAT.nu)[0].imag * MAT.cs * 200 / MAT.R
    assert abs(h200 / hs - 1.0) < 0.03


def test_kelvin_voigt_bounds_the_growth_above_fc() -> None:
    """Kelvin-Voigt τ = 2e-6 s (loss factor 2 % at 1.6 kHz) at f = 1.5: the growth still rises
    at n = 50 (measured 3292 /s) but is negative at n = 200 (measured −9872 /s): viscous decay
    ~ τ ω²/2 ∝ n² beats the flutter ∝ n. The ω of a damped root solves ω² = μ(1 − iωτ) with
    the undamped μ (the friction row is unchanged), checked against the Bessel polish."""
    kv = Dissipation(tau=2e-6)
    assert _best(50, 1.5, kv) > 1000.0
    assert _best(200, 1.5, kv) < 0.0
    und = _omegas(sliding_branches(8, 1.5, MAT, fmax_hz=3000.0))
    damped = _omegas(sliding_branches(8, 1.5, MAT, fmax_hz=3000.0, diss=kv))
    mu = und**2
    mapped = np.concatenate([(-1j * 2e-6 * mu + s * np.sqrt(-(2e-6 * mu) ** 2 + 4 * mu)) / 2
                             for s in (1, -1)])
    for w in damped:
        assert np.min(np.abs(mapped - w)) < 1e-8 * abs(w)


def test_prakash_clifton_limits() -> None:
    """Linearised Prakash-Clifton f_eff = f / (1 − iωt*): t* → 0 gives Coulomb (roots to
    1e-7 relative, through the quadratic companion problem instead of the reduced one), and a
    relaxation time with ω t* ≈ 3 (t* = 1e-4 s, n = 16 at 2 kHz) lowers the fastest growth at
    f = 1.5 (measured 2848 → below 1500 /s): friction that lags the pressure feeds less
    energy at high frequency."""
    a = _omegas(sliding_branches(4, 0.7, MAT, fmax_hz=3000.0))
    b = _omegas(sliding_branches(4, 0.7, MAT, fmax_hz=3000.0, diss=Dissipation(t_star=1e-13)))
    assert a.size == b.size
    for w in a:
        assert np.min(np.abs(b - w)) < 1e-7 * abs(w)
    coulomb = _best(16, 1.5)
    lagged = _best(16, 1.5, Dissipation(t_star=1e-4))
    assert lagged < 0.6 * coulomb


# --------------------------------------------------------------------------- FE convergence


def _fe_branches(N: int) -> dict[int, list]:
    from mpi4py import MPI

    from stickslip.solver.problem import build_problem
    from stickslip.solver.scene import load_scene
    from stickslip.studies.flutter_fe.cea import complex_eigenvalue_analysis, distinct_modes

    scene = load_scene("figure3_n36", [f"mesh.n_inner={N}", "output.progress=false"])
    res = complex_eigenvalue_analysis(build_problem(scene, MPI.COMM_SELF), 0.7, 3200.0)
    return {k: distinct_modes(m for m in res.modes if m.wavenumber == k)[:3] for k in (2, 4, 7)}


def _errors(N: int) -> tuple[float, float]:
    """Largest relative frequency error and growth error / ω over the first three branches of
    n = 2, 4, 7 (directions must agree)."""
    fe = _fe_branches(N)
    ef = eg = 0.0
    for k, modes in fe.items():
        ex = [b for b in sliding_branches(k, 0.7, MAT, fmax_hz=3200.0).branches
              if b.growth_rate >= 0][:3]
        for m, b in zip(modes, ex, strict=True):
            assert m.direction == b.direction, (N, k, m, b)
            ef = max(ef, abs(m.frequency_hz - b.frequency_hz) / b.frequency_hz)
            eg = max(eg, abs(m.growth_rate - b.growth_rate) / (2 * math.pi * b.frequency_hz))
    return ef, eg


@pytest.mark.dolfinx
def test_flutter_fe_approaches_the_exact_flutter() -> None:
    """N = 132 (P1, lumped, figure3_n36 with mesh.n_inner = 132, 5 layers), f = 0.7, the first
    three branches of n = 2, 4, 7: same directions; measured errors (all n ≤ 8) 3.34 % in
    frequency and 0.59 % of ω in growth (the f = 0 P1 error of the thickness family, O(h²));
    tolerances 4 % and 0.8 %. The full study (N = 66…528, docs/continuum.md) finds
    order 1.9–2.3 and 0.19 % / 0.034 % at N = 528."""
    ef, eg = _errors(132)
    assert ef < 0.04 and eg < 0.008, (ef, eg)


@pytest.mark.dolfinx
@pytest.mark.slow
def test_flutter_fe_error_falls_at_second_order() -> None:
    """N = 264 (11 layers): measured 0.69 % / 0.12 %, i.e. 4.9× and 4.8× smaller than at
    N = 132 (O(h²): 4× per halving; the automatic layer count changes from 5 to 11, hence the
    scatter). Tolerances: < 1 % and < 0.2 %, and both errors at least 3× smaller."""
    ef1, eg1 = _errors(132)
    ef2, eg2 = _errors(264)
    assert ef2 < 0.01 and eg2 < 0.002, (ef2, eg2)
    assert ef1 / ef2 > 3.0 and eg1 / eg2 > 3.0, (ef1 / ef2, eg1 / eg2)


# --------------------------------------------------------------------------- CLI


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from stickslip.cli.continuum import register

    parser = argparse.ArgumentParser(prog="stickslip")
    sub = parser.add_subparsers(dest="command", required=True)
    register(sub)
    args = parser.parse_args(["flutter-exact", *argv])
    rc = args.func(args)
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.mark.parametrize("argv, word", [
    (["--nu", "0.6"], "--nu"),
    (["--f", "nan"], "--f"),
    (["--nmax", "5000"], "--nmax"),
    (["--xi", "1.0"], "--xi"),
    (["--regularization", "prakash-clifton"], "--slip-length"),
    (["--regularization", "constant-time"], "--relaxation-time"),
    (["--loss-factor", "-0.1", "--reference-frequency-hz", "1000"], "--loss-factor"),
    (["--retardation-time", "nan"], "--retardation-time"),
    (["--f-sweep", "0:1:x"], "--f-sweep"),
    (["--set", "loading.f=0.5"], "SCENE"),
])
def test_cli_refuses_bad_input(argv: list[str], word: str,
                               capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, err = _cli(argv, capsys)
    assert rc == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and word in lines[0]


def test_cli_json_lists_every_branch(capsys: pytest.CaptureFixture[str]) -> None:
    """`--json` for n = 4 at f = 0.7 from the Figure-3 scene: the same branches as
    sliding_branches, the threshold 1, the half-space stable (growth per n 0)."""
    rc, out, _ = _cli(["figure3_n132", "--n", "4", "--fmax-hz", "3000", "--speed-factor", "0",
                       "--json"], capsys)
    assert rc == 0
    data = json.loads(out)
    assert abs(data["halfspace_threshold_f_c"] - 1.0) < 1e-6
    (res,) = data["results"]
    assert res["f"] == 0.7 and res["halfspace_growth_per_n_per_s"] == 0.0
    got = [(b["frequency_hz"], b["growth_rate"]) for b in res["orders"][0]["branches"]]
    ref = [(b.frequency_hz, b.growth_rate) for b in
           sliding_branches(4, 0.7, MAT, fmax_hz=3000.0).branches]
    np.testing.assert_allclose(np.array(got), np.array(ref), rtol=1e-9, atol=1e-6)


@pytest.mark.dolfinx
def test_filtered_friction_removes_the_mesh_scale_branch() -> None:
    """N = 72, f = 0.7, the whole discrete spectrum (≤ 9 kHz; ω_max ≈ 5.4 kHz). With the nodal
    law the fastest mode is the mesh-scale k = 22 at 1458 /s; with friction on 1-2-1 filtered
    reactions it is the physical k = 8 at 1219 /s, below the exact growth of n = 8 (1508 /s):
    the FE approaches it from below, as every branch of section 3. Tolerances: the winning k
    (≤ 10 = physical family, ≥ 15 = mesh scale) and growth below the exact sup over n
    (1553 /s, docs/continuum.md)."""
    from mpi4py import MPI

    from stickslip.solver.problem import build_problem
    from stickslip.solver.scene import load_scene
    from stickslip.studies.flutter_fe.cea import build_operators, complex_eigenvalue_analysis

    problem = build_problem(load_scene("figure3_n36", ["mesh.n_inner=72"]), MPI.COMM_SELF)
    top = {}
    for law in ("nodal", "1-2-1"):
        ops = build_operators(problem, "lumped", law)
        top[law] = complex_eigenvalue_analysis(problem, 0.7, 9000.0, ops=ops).unstable()[0]
        ops.destroy()
    assert top["nodal"].wavenumber >= 15
    assert top["1-2-1"].wavenumber <= 10 and top["1-2-1"].growth_rate < 1553.0


@pytest.mark.dolfinx
@pytest.mark.parallel
def test_filtered_friction_is_the_same_on_one_and_all_ranks() -> None:
    """The 1-2-1 filter finds each contact node's angular neighbours across ranks: N = 72,
    f = 0.7, up to 2.5 kHz, COMM_SELF and COMM_WORLD give the same modes (MUMPS/Krylov in
    another order: frequencies to 1e-8, growth to 1e-6, as the unfiltered MPI test)."""
    from mpi4py import MPI

    from stickslip.solver.problem import build_problem
    from stickslip.solver.scene import load_scene
    from stickslip.studies.flutter_fe.cea import build_operators, complex_eigenvalue_analysis

    out = {}
    for name, comm in (("self", MPI.COMM_SELF), ("world", MPI.COMM_WORLD)):
        pb = build_problem(load_scene("figure3_n36", ["mesh.n_inner=72"]), comm)
        ops = build_operators(pb, "lumped", "1-2-1")
        out[name] = complex_eigenvalue_analysis(pb, 0.7, 2500.0, ops=ops).modes
        ops.destroy()
    a, b = out["self"], out["world"]
    assert len(a) == len(b) > 50
    for ma, mb in zip(a, b, strict=True):
        assert mb.frequency_hz == pytest.approx(ma.frequency_hz, rel=1e-8)
        assert mb.growth_rate == pytest.approx(ma.growth_rate, rel=1e-6, abs=1e-6)
        assert (mb.k, mb.direction) == (ma.k, ma.direction)


def test_cli_reads_the_scene_damping(capsys: pytest.CaptureFixture[str]) -> None:
    """``flutter-exact SCENE`` takes Kelvin-Voigt tau from the scene's [damping] (loss factor
    2 % at 1.6 kHz: tau = 1.99 µs), so it is the continuum of the damped CEA. The lowest
    n = 8 branch grows at 353.7 /s undamped and 273.9 /s damped (the 79.8 /s drop is
    tau Re(omega²)/2 to first order in tau omega = 0.018: tolerance 1 %)."""
    from stickslip.cli.main import main

    lowest = {}
    for extra in ([], ["--set", "damping.loss_factor=0"]):
        assert main(["flutter-exact", "figure1_n132_damped", "--n", "8", "--fmax-hz", "1600",
                     "--json", *extra]) == 0
        out = json.loads(capsys.readouterr().out)
        tau = out["dissipation"]["retardation_time_s"]
        br = [b for b in out["results"][0]["orders"][0]["branches"] if b["growth_rate"] > 0]
        lowest[tau] = min(br, key=lambda b: b["frequency_hz"])
    tau = 0.02 / (2 * math.pi * 1600.0)
    assert sorted(lowest) == [0.0, pytest.approx(tau, rel=1e-12)]
    undamped, damped = lowest[0.0], next(v for k, v in lowest.items() if k > 0)
    assert undamped["growth_rate"] == pytest.approx(353.7, abs=0.1)
    assert damped["growth_rate"] == pytest.approx(273.9, abs=0.1)
    w = 2 * math.pi * undamped["frequency_hz"]
    drop = 0.5 * tau * (w * w - undamped["growth_rate"] ** 2)
    assert undamped["growth_rate"] - damped["growth_rate"] == pytest.approx(drop, rel=0.01)
