"""Complex eigenvalue analysis of FE steady sliding (``stickslip flutter-fe``), docs/flutter.md.

``cea`` (operators, sliced SLEPc solve, Kelvin–Voigt damping, the regularised friction
bound, modes), ``shapes`` (mode shapes for ParaView and CSV), ``references`` (exact and
reduced-model spectra), ``transient`` (growth measured in a run), ``plots``.
"""

from stickslip.studies.flutter_fe.cea import (
    CEAMode,
    CEAOperators,
    CEAResult,
    band_eigenvalues,
    build_operators,
    complex_eigenvalue_analysis,
    damped_exponents,
    regularised_band,
    sweep_friction,
)
from stickslip.studies.flutter_fe.plots import plot_cea_diagram, plot_spectrum
from stickslip.studies.flutter_fe.references import (
    annulus_sliding_frequencies,
    reduced_model_flutter,
)
from stickslip.studies.flutter_fe.transient import (
    TransientGrowth,
    matrix_pencil,
    measure_transient_growth,
    newmark_exponents,
)

__all__ = [
    "CEAMode",
    "CEAOperators",
    "CEAResult",
    "TransientGrowth",
    "annulus_sliding_frequencies",
    "band_eigenvalues",
    "build_operators",
    "complex_eigenvalue_analysis",
    "damped_exponents",
    "matrix_pencil",
    "measure_transient_growth",
    "newmark_exponents",
    "plot_cea_diagram",
    "plot_spectrum",
    "reduced_model_flutter",
    "regularised_band",
    "sweep_friction",
]
