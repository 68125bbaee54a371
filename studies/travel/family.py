"""Every k-periodic wave of one zone topology, by enumerating active sets.

For a fixed active set the wave-frame law is linear in W (``newton.wave_of_active_set``),
so whether a wave with that active set exists at a speed ω is one linear solve and the
signs of its inequality margins. No Newton, so no start and no basin: a scan over active
sets and speeds lists *every* admissible wave of the scanned topology, and the width of
that list is a property of the discrete problem, not of a solver.

A stick-slip-separation wave of mode k on N nodes has n = N/k nodes per wavelength. Read in
the order of θ (the transient's snapshots, ω < 0, show exactly this), one wavelength is

    stick (n_stick) · slip (n_slip) · separation (n − n_stick − n_slip − n_land) · slip (n_land)

(``zone_pattern``): the cylinder drags a sticking run forward, it slips, the tube lifts off,
and lands again through ``n_land`` slipping nodes. The slip sense is the transient's (q > 0
for the Figure-1 scenes: the cylinder drags the tube in +θ). ``scan_family`` solves every
(n_stick, n_slip, n_land) of the given ranges at every given ω and keeps the members whose
margins are all >= −tol (``newton.inequality_margins``: gap, pressure, cone, slip sense).

What it does not see: other topologies (two stick runs per wavelength, a stick run inside
the separation) and waves that are not k-periodic node by node.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from stickslip.solver.contact import SEPARATION, SLIP, STICK
from stickslip.studies.travel.newton import (
    CircleProblem,
    inequality_margins,
    nodal_stiffness,
    wave_amplitude,
    wave_of_active_set,
    zone_lengths,
)

__all__ = ["FamilyMember", "FamilyScan", "scan_family", "zone_pattern", "zones_of_statuses"]


def zone_pattern(n_wave: int, n_stick: int, n_slip: int, n_land: int) -> NDArray[np.int8]:
    """Statuses of one wavelength of ``n_wave`` nodes in θ order (module doc)."""
    n_sep = n_wave - n_stick - n_slip - n_land
    if min(n_stick, n_slip, n_land) < 0 or n_sep < 1:
        raise ValueError(f"zones ({n_stick}, {n_slip}, {n_land}) do not fit a wavelength of "
                         f"{n_wave} nodes with a separation run")
    return np.array([STICK] * n_stick + [SLIP] * n_slip + [SEPARATION] * n_sep
                    + [SLIP] * n_land, dtype=np.int8)


def zones_of_statuses(status: NDArray[np.int8]) -> list[tuple[int, int, int]] | None:
    """The (n_stick, n_slip, n_land) of each wavelength of a nodal status array in θ order
    (a transient's snapshot), or None if it is not of the ``zone_pattern`` topology: runs
    stick · [slip] · separation · [slip], repeated."""
    st = np.asarray(status)
    if not np.any(st == STICK) or not np.any(st == SEPARATION):
        return None
    start = int(np.flatnonzero((st == STICK) & (np.roll(st, 1) != STICK))[0])
    st = np.roll(st, -start)
    edges = np.flatnonzero(st != np.roll(st, -1))
    runs = [(int(st[e]), int(e - b + 1)) for b, e in zip(np.r_[0, edges[:-1] + 1], edges,
                                                          strict=True)]
    out, i = [], 0
    while i < len(runs):
        code, length = runs[i]
        if code != STICK:
            return None
        slip = land = 0
        i += 1
        if i < len(runs) and runs[i][0] == SLIP:
            slip, i = runs[i][1], i + 1
        if i >= len(runs) or runs[i][0] != SEPARATION:
            return None
        i += 1
        if i < len(runs) and runs[i][0] == SLIP:
            land, i = runs[i][1], i + 1
        out.append((length, slip, land))
    return out


@dataclass
class FamilyMember:
    """An admissible k-periodic wave: speed, zones (nodes per wavelength), amplitude, ψ."""

    omega: float
    zones: tuple[int, int, int]  # (n_stick, n_slip, n_land)
    min_margin: float
    amplitude: float  # ``newton.wave_amplitude`` (as a transient's: peak lift-off)
    psi1: float  # sub-node separation fraction (``newton.zone_lengths``)
    psi2: float  # ψ₁ + sub-node stick fraction


@dataclass
class FamilyScan:
    """All members found, and per speed the best (largest) smallest margin and its zones."""

    members: list[FamilyMember] = field(default_factory=list)
    best: list[tuple[float, float, tuple[int, int, int], str]] = field(default_factory=list)


def scan_family(prob: CircleProblem, k: int, omegas: Iterable[float],
                zones: Sequence[tuple[int, int, int]], *, sense: float = 1.0,
                tol: float = 1e-8) -> FamilyScan:
    """Solve every active set ``zone_pattern(N/k, *z)`` for z in ``zones`` at every ω of
    ``omegas`` (k-periodic, ``wave_of_active_set(..., period=k)``) and keep the admissible
    ones (module doc). One S(ω) per speed serves all active sets."""
    n = prob.n
    if n % k:
        raise ValueError(f"k = {k} does not divide the {n} contact nodes")
    c = nodal_stiffness(prob)
    fscale = c * prob.d
    sgn = np.full(n, float(np.sign(sense)))
    out = FamilyScan()
    for om in omegas:
        S, _ = prob.stiffness(float(om), False)
        best = (-np.inf, -np.inf, (0, 0, 0), "")
        for z in zones:
            status = np.tile(zone_pattern(n // k, *z), k)
            sol = wave_of_active_set(prob, status, sgn, float(om), period=k, S=S, c=c)
            margins = inequality_margins(prob, sol, fscale)
            worst = min(margins, key=margins.get)
            if margins[worst] > best[1]:
                best = (float(om), margins[worst], tuple(z), worst)
            if margins[worst] >= -tol:
                zl = zone_lengths(prob, sol)
                out.members.append(FamilyMember(
                    float(om), tuple(z), margins[worst], wave_amplitude(prob, sol),
                    zl["separation"], zl["separation"] + zl["stick"]))
        out.best.append(best)
    return out
