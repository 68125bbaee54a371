"""Errors of the FE core that the layers above catch (run directory, sweeps, CLI)."""

from __future__ import annotations


class Diverged(RuntimeError):
    """The time scheme blew up (NaN, energy beyond the bound, a failed contact solve)."""


class StepTooLarge(ValueError):
    """A fixed time step above the stability limit of the scheme."""


#: The energy guard: a run is declared diverged when its energy E exceeds both
#: ENERGY_GROWTH x E(0) and FED_FACTOR x (E(0) + W_cylinder(t)). The energy can only grow by the
#: work the rotating cylinder feeds in, so a physical wave (even at Omega = 1000 rad/s) stays
#: below the second bound; a blow-up of the time scheme does not.
ENERGY_GROWTH = 1e4
FED_FACTOR = 10.0


def energy_bound(initial):
    """ENERGY_GROWTH x E(0) (a float or an array of them)."""
    import numpy as np

    return ENERGY_GROWTH * np.maximum(initial, 1e-300)


def blown_up(total, bound, fed):
    """The guard's test for energies ``total`` with bound ``energy_bound(E(0))`` and
    ``fed`` = E(0) + |W_cylinder| (floats or arrays)."""
    return (total > bound) & (total > FED_FACTOR * fed)


def blowup_message(total: float, fed: float, t: float) -> str:
    """The one-line reason of a run (or batched scene) that the guard declares diverged."""
    return (f"energy {total:.3g} J/m exceeds 1e4 x the initial energy and 10 x the energy fed "
            f"by the cylinder ({fed:.3g} J/m) at t = {t:.6g} s: the time scheme is unstable "
            "here; reduce time.dt_fraction")
