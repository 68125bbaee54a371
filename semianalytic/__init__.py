"""Semi-analytical reduced model of the paper (sections 2-3): pure numpy/scipy.

Modules: :mod:`~semianalytic.coefficients` (eq. [2] coefficients), :mod:`~semianalytic.steady`
(steady sliding), :mod:`~semianalytic.flutter` (dispersion relation), :mod:`~semianalytic.waves`
(stick-slip and stick-slip-separation waves, eqs. [3]-[7]), :mod:`~semianalytic.junctions`
(closure comparison), :mod:`~semianalytic.plotting` (Figure 1; imports matplotlib lazily) and
:mod:`~cli.semianalytic` (``stickslip wave`` / ``stickslip flutter``). No dolfinx needed.
"""

from stickslip.semianalytic.coefficients import Coefficients, coefficients, gamma_from_physical
from stickslip.semianalytic.flutter import flutter_modes
from stickslip.semianalytic.steady import closed_form_steady, reduced_steady
from stickslip.semianalytic.waves import (
    TravellingWave,
    celerity_m_s,
    find_waves,
    frequency_hz,
    stick_slip_separation_waves,
    stick_slip_waves,
)

__all__ = [
    "Coefficients",
    "TravellingWave",
    "celerity_m_s",
    "closed_form_steady",
    "coefficients",
    "find_waves",
    "flutter_modes",
    "frequency_hz",
    "gamma_from_physical",
    "reduced_steady",
    "stick_slip_separation_waves",
    "stick_slip_waves",
]
