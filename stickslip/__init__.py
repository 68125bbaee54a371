"""stickslip: friction-induced stick-slip(-separation) waves of an elastic tube on a rotating
rigid cylinder, as a Python library.

The public API, one import for a notebook or a study script::

    import stickslip

    scene = stickslip.load_scene("figure3_n132_damped", {"mesh.n_inner": 132})
    summary = stickslip.run(scene, "runs/fig3", force=True)     # summary.json as a dict
    wave = stickslip.analyse("runs/fig3")                       # WaveSummary
    print(wave.regime, wave.mode, wave.celerity_m_s, wave.frequency_hz)

=====================  ===============================================================
``load_scene``         a scene file (or shipped scene name) with overrides -> ``Scene``
``run``                one transient run into a run directory -> its summary
``continue_run``       a run continued from its checkpoint to a later time -> its summary
``analyse``            the wave measured in a run directory -> ``WaveSummary``
``load_run``           a run directory's scene, summary and samples -> ``RunData``
``sweep``              a parameter study (sweep file) -> its table
``plot_run``           the figures of a run directory (PNG)
``plot_sweep``         the regime map of a sweep directory (PNG)
``cea``                complex eigenvalue analysis of steady sliding -> ``CEAResult``
``cea_friction_sweep`` the CEA at several friction coefficients
``travel``             one travelling wave solved in its own frame -> summary and profiles
``travel_branch``      a branch of travelling waves followed in one scene key
``reduced_waves``      the reduced model's travelling waves at one point (no FE)
``attractors``         the census of a scene point: its attractors and basin shares
``rpo_along``          a start followed along a scene key: where its two-wave state is born
=====================  ===============================================================

Importing ``stickslip`` is cheap: every name is imported on first use, so the reduced model
and ``load_scene`` work where FEniCSx is not installed. The output files each function writes
are described in the documentation's reference ("Output files").
"""

from __future__ import annotations

import importlib
from typing import Any

from stickslip.solver import __version__ as __version__

#: Public name -> the module that defines it (imported on first access).
_EXPORTS = {
    "load_scene": "stickslip.api",
    "run": "stickslip.api",
    "continue_run": "stickslip.api",
    "analyse": "stickslip.api",
    "load_run": "stickslip.api",
    "sweep": "stickslip.api",
    "plot_run": "stickslip.api",
    "plot_sweep": "stickslip.api",
    "cea": "stickslip.api",
    "cea_friction_sweep": "stickslip.api",
    "travel": "stickslip.api",
    "travel_branch": "stickslip.api",
    "reduced_waves": "stickslip.api",
    "attractors": "stickslip.api",
    "rpo_along": "stickslip.api",
    "Scene": "stickslip.solver.scene",
    "SceneError": "stickslip.solver.scene",
    "STATUS_CODES": "stickslip.api",
    "EXIT_CODES": "stickslip.api",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'stickslip' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
