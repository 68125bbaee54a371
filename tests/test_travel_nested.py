"""Nested starts of the travelled wave ("mesh convergence"; archive/travel/
travelling_waves_history.md 2d): the prolongation of a contact-circle state and the damped Schur
complement that a finer mesh needs.

* ``driver.prolong`` (linear): for 2N nodes the coarse values are kept at the even nodes and
  each odd node is the mean of its two neighbours (exact algebra, so to round-off); it never
  creates values outside the coarse range (W_r ≥ d stays true: a prolonged separation/contact
  pattern is still non-penetrating). ``fourier`` reproduces a trigonometric polynomial of
  degree < N/2 exactly (to 1e-12: FFT round-off).
* ``frame._schur_damped`` with A_ci kept sparse equals the dense formula
  A_cc − A_ci A_ii⁻¹ A_ic to 1e-10 relative (the same arithmetic in another order; ~1e-15
  expected).
"""

from __future__ import annotations

import numpy as np
import pytest

from stickslip.studies.travel.driver import prolong


def test_prolong_linear_keeps_coarse_values_and_bounds():
    n = 24
    th = np.arange(n) * 2 * np.pi / n
    d = 1e-3
    W_r = d + np.maximum(0.0, 2e-3 * np.cos(4 * th))  # contact (= d) and separation (> d)
    W_t = 1e-3 * np.sin(4 * th + 0.3)
    fine = prolong(np.concatenate([W_r, W_t]), 2 * n).reshape(2, 2 * n)
    assert np.array_equal(fine[0, ::2], W_r) and np.array_equal(fine[1, ::2], W_t)
    assert np.allclose(fine[1, 1::2], 0.5 * (W_t + np.roll(W_t, -1)), rtol=0, atol=1e-18)
    assert fine[0].min() >= d  # exactly: a convex combination of values ≥ d
    # any fine count, same bounds
    odd = prolong(np.concatenate([W_r, W_t]), 3 * n + 1).reshape(2, -1)
    assert odd[0].min() >= d and odd[1].max() <= W_t.max()


def test_prolong_fourier_is_exact_on_trigonometric_polynomials():
    n, m = 24, 64
    th, thf = (np.arange(k) * 2 * np.pi / k for k in (n, m))
    f = (lambda t: 1.0 + np.cos(4 * t) - 0.5 * np.sin(7 * t),
         lambda t: np.sin(4 * t + 0.3) + 0.2 * np.cos(11 * t))
    fine = prolong(np.concatenate([f[0](th), f[1](th)]), m, "fourier").reshape(2, m)
    assert np.abs(fine[0] - f[0](thf)).max() < 1e-12
    assert np.abs(fine[1] - f[1](thf)).max() < 1e-12


def test_prolong_rejects_bad_input():
    with pytest.raises(ValueError, match="2N"):
        prolong(np.zeros(5), 10)
    with pytest.raises(ValueError, match="how"):
        prolong(np.zeros(6), 12, "cubic")


def test_damped_schur_sparse_equals_dense():
    pytest.importorskip("dolfinx")
    from scipy.sparse.linalg import splu

    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    scene = load_scene("scenes/figure1_n132_damped.toml", ["mesh.n_inner=36"])
    st = D.setup(scene, float(scene.damping.tau))
    ops = st.ops
    om = -2490.0
    S, _ = ops._schur_damped(om, False)
    A = (ops.K - om**2 * ops.G - om * ops.C).tocsr()
    c, i = ops.contact, ops.interior
    dense = (A[c][:, c].toarray()
             - A[c][:, i].toarray() @ splu(A[i][:, i].tocsc()).solve(A[i][:, c].toarray()))
    assert np.abs(S - dense).max() < 1e-10 * np.abs(dense).max()
