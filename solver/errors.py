"""Errors of the FE core that the layers above catch (run directory, sweeps, CLI)."""

from __future__ import annotations


class Diverged(RuntimeError):
    """The time scheme blew up (NaN, energy beyond the bound, a failed contact solve)."""


class StepTooLarge(ValueError):
    """A fixed time step above the stability limit of the scheme."""
