"""Exact continuum references, dolfinx-free (numpy/scipy only).

* :mod:`exact.annulus`: plane-strain clamped annulus, Bessel potentials per circumferential
  order n (dynamic determinant at ``r = R``) and a Chebyshev collocation of the same problem;
* :mod:`exact.sliding_flutter`: linearised steady sliding (``u_r = 0``,
  ``σ_rθ = f σ_rr`` at ``r = R``): every branch per order n in complex ω, with optional
  Kelvin-Voigt damping and linearised Prakash-Clifton friction;
* :mod:`exact.halfspace`: the half-space limit, closed-form dispersion relation and the
  threshold ``f_c(ν)``.

Documentation: docs/continuum.md.
"""
