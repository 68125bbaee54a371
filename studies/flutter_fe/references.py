"""Reference spectra for the CEA: the exact f = 0 annulus frequencies and the reduced model."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from stickslip.exact.annulus import annulus_sliding_frequencies  # the exact f = 0 reference
from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.flutter import flutter_modes, mode_physical

if TYPE_CHECKING:
    from stickslip.solver.scene import Scene

__all__ = ["annulus_sliding_frequencies", "reduced_model_flutter"]


def reduced_model_flutter(scene: Scene, kmax: int = 12) -> list[dict[str, Any]]:
    """The reduced model's flutter modes (eq. [2] in sliding, ``semianalytic.flutter``) in
    physical units for the scene's ν, ξ, f, c₀, R, Ω (growth 1/s, frequency Hz, m/s)."""
    g, m, lo = scene.geometry, scene.material, scene.loading
    gamma = gamma_from_physical(math.sqrt(m.E / m.rho), g.R, lo.omega)
    co = coefficients(m.nu, g.xi, gamma)
    return [mode_physical(md, g.R, lo.omega) for md in flutter_modes(co, lo.f, kmax)]


