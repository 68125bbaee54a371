"""Complex eigenvalue analysis of FE steady sliding (``stickslip flutter-fe``), docs/flutter.md.

``cea`` (operators, sliced SLEPc solve, modes), ``references`` (exact and reduced-model
spectra), ``transient`` (growth measured in a run), ``plots``.
"""

from studies.flutter_fe.cea import (
    CEAMode,
    CEAOperators,
    CEAResult,
    band_eigenvalues,
    build_operators,
    complex_eigenvalue_analysis,
    sweep_friction,
)
from studies.flutter_fe.plots import plot_cea_diagram, plot_spectrum
from studies.flutter_fe.references import annulus_sliding_frequencies, reduced_model_flutter
from studies.flutter_fe.transient import (
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
    "matrix_pencil",
    "measure_transient_growth",
    "newmark_exponents",
    "plot_cea_diagram",
    "plot_spectrum",
    "reduced_model_flutter",
    "sweep_friction",
]
