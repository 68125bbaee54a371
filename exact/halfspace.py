"""Elastic half-space sliding on a rigid plane: closed-form flutter dispersion relation.

Body ``y > 0``, rigid plane ``y = 0`` sliding in ``+x`` (the friction traction on the body
points along ``+x``: ``σ_xy = f σ_yy`` with ``σ_yy < 0``), perturbation
``e^{i(kx − ωt)}``, ``k > 0``, phase speed ``c = ω/k`` (complex). Potentials decaying in y,
``φ = A e^{−kay}``, ``ψ = B e^{−kby}`` with ``a = sqrt(1 − c²/c_p²)``,
``b = sqrt(1 − c²/c_s²)`` (``Re a, Re b > 0``). ``u_y = 0`` gives ``B = iaA``, and then
``σ_xy = −iρ a k² c² A``, ``σ_yy = μk²(2 − x − 2ab) A`` with ``x = c²/c_s²``. The sliding
condition ``σ_xy = f σ_yy`` is (divided by ``μk² x A``, which removes the spurious c = 0)::

    G(c) = i a + f (2 − x − 2ab) / x = 0                         (1)

Everything scales with k: ``ω = ck`` and the growth rate ``k Im c`` is proportional to the
wavenumber, so **one** root with ``Im c > 0`` makes the problem ill-posed (Hadamard).
In the open upper half-plane the principal square roots are the decaying ones, so the
growing roots are exactly the roots of (1) there.

Rationalising (1) twice gives a quartic in ``x`` (:func:`quartic`),
``q(x)² + 4f²(2 − x)²(1 − κx) = 0``, ``q = −4f²κ + (1 − f² + 4f²κ) x − κx²``,
``κ = c_s²/c_p² = (1 − 2ν)/(2(1 − ν))``: all candidate roots at once; each is checked in (1).

On the real axis at ``c = −√2 c_s + i0`` (``x = 2``, ``a = sqrt(ν/(1 − ν))``,
``b = +i``) equation (1) reads ``i a (1 − f) = 0``: a neutral root exactly at **f = 1**
for every ν, which is the threshold :func:`threshold` finds numerically (it moves into the
upper half-plane for f > 1, travelling against the sliding of the rigid plane).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "argument_principle_count",
    "dispersion",
    "growing_roots",
    "kappa",
    "quartic",
    "threshold",
]


def kappa(nu: float) -> float:
    """``c_s²/c_p² = (1 − 2ν) / (2(1 − ν))`` (plane strain)."""
    return (1 - 2 * nu) / (2 * (1 - nu))


def dispersion(c: complex | np.ndarray, f: float, nu: float) -> complex | np.ndarray:
    """``G(c)`` of eq. (1), ``c`` in units of the shear speed ``c_s`` (principal roots)."""
    c = np.asarray(c, dtype=complex)
    x = c * c
    a = np.sqrt(1 - kappa(nu) * x)
    b = np.sqrt(1 - x)
    return 1j * a + f * (2 - x - 2 * a * b) / x


def quartic(f: float, nu: float) -> np.ndarray:
    """Coefficients (highest first) of ``q(x)² + 4f²(2 − x)²(1 − κx)``."""
    kap = kappa(nu)
    q = np.poly1d([-kap, 1 - f * f + 4 * f * f * kap, -4 * f * f * kap])
    p = q * q + 4 * f * f * np.poly1d([1, -4, 4]) * np.poly1d([-kap, 1])
    return p.coeffs


def growing_roots(f: float, nu: float, tol: float = 1e-9) -> np.ndarray:
    """Roots ``c/c_s`` of (1) with ``Im c > 0`` (growth ``k c_s Im c``): the quartic's roots,
    both signs of ``√x``, kept where the principal-branch ``G`` vanishes."""
    out = []
    for x in np.roots(quartic(f, nu)):
        for c in (np.sqrt(x + 0j), -np.sqrt(x + 0j)):
            if c.imag > tol and abs(dispersion(c, f, nu)) <= 1e-7 * (1 + f):
                out.append(complex(c))
    return np.array(sorted(out, key=lambda z: -z.imag))


def argument_principle_count(
    f: float, nu: float, eps: float = 1e-6, radius: float = 50.0, samples: int = 200_001
) -> int:
    """Number of zeros of (1) in the upper half-plane (independent of :func:`quartic`):
    winding number of ``G`` along ``Im c = eps`` from ``−radius`` to ``radius`` and back
    along the half-circle ``|c| = radius`` (G has no poles there: ``x ≠ 0``)."""
    t = np.linspace(-radius, radius, samples)
    line = t + 1j * eps
    arc = radius * np.exp(1j * np.linspace(0.0, math.pi, samples // 4))
    path = np.concatenate([line, arc + 1j * eps])
    g = dispersion(path, f, nu)
    dphi = np.angle(g[1:] / g[:-1])
    return int(round(float(np.sum(dphi)) / (2 * math.pi)))


def threshold(nu: float, fmax: float = 5.0, df: float = 0.01, tol: float = 1e-10) -> float:
    """Smallest f with a growing root: the first f on a ``df`` grid up to ``fmax`` with one
    (at small ν the root leaves the upper half-plane again at large f, so the scan starts
    from 0), then bisection (growth floor ``Im c > 1e-13``). ``inf`` if none up to fmax."""
    grid = np.arange(df, fmax + df / 2, df)
    hit = next((float(f) for f in grid if growing_roots(float(f), nu).size), None)
    if hit is None:
        return math.inf
    lo, hi = hit - df, hit
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if growing_roots(mid, nu, tol=1e-13).size:
            hi = mid
        else:
            lo = mid
    return hi
