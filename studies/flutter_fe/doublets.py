"""The ±k doublets of a CEA spectrum: split by the geometry, and which member is unstable.

On the rotationally symmetric tube every wavenumber k ≥ 1 has two modes of one frequency
(cos kθ and sin kθ; a doublet). A cross-section with n-fold symmetry splits the doublets whose
2k is a multiple of n and leaves the others degenerate (a 4-fold clamp splits k = 2, 4, 6,
...); an asymmetric one splits them all. With friction, the steady sliding operator couples
the two members: a degenerate doublet becomes a flutter pair (μ and its conjugate), one motion
growing, travelling one way, the other decaying; a pair split far enough by the geometry
stays two stable standing modes (the brake designer's mode splitting; the demo "Your own
geometry").

``doublets(res, kmax)`` reads a ``CEAResult`` (``studies.flutter_fe.cea``): for each
k = 1 .. kmax, the lowest-frequency modes whose dominant wavenumber is k (purity ≥ 0.5),
the first two if they are standing (real μ) or the first if it is a flutter pair.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

__all__ = ["DEGENERATE", "Doublet", "doublets", "doublet_lines"]

#: Relative split below which a doublet counts as degenerate: the unstructured mesh of a
#: symmetric geometry splits them by up to 0.15 % (measured on scenes/tube_four_clamps.toml),
#: while a 3-fold clamp splits k = 3 by 0.74 % (tests/test_user_mesh.py, N = 48).
DEGENERATE = 0.005
MIN_PURITY = 0.5  # the wavenumber k holds most of the mode's power on the contact circle


@dataclass(frozen=True)
class Doublet:
    """The ±k pair of wavenumber ``k``: frequencies [Hz], growth rates [1/s], its state."""

    k: int
    frequencies_hz: tuple[float, ...]  # one (a flutter pair) or two (standing members)
    growth_rates: tuple[float, ...]  # of the motions listed
    state: str  # 'degenerate' | 'split' | 'flutter' | 'missing'
    unstable: str  # which member grows: '' or 'the one travelling against / with ...'

    @property
    def split_hz(self) -> float:
        f = self.frequencies_hz
        return abs(f[1] - f[0]) if len(f) == 2 else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "split_hz": self.split_hz}


def doublets(res: Any, kmax: int = 8) -> list[Doublet]:
    """The doublets k = 1 .. kmax of ``res`` (module docstring)."""
    out = []
    for k in range(1, kmax + 1):
        family = sorted((m for m in res.modes if m.wavenumber == k and m.purity >= MIN_PURITY),
                        key=lambda m: m.frequency_hz)
        if not family:
            out.append(Doublet(k, (), (), "missing", ""))
            continue
        first = family[0]
        if first.direction in ("rotation", "opposite"):  # complex μ: the coalesced pair
            grows = first.growth_rate > 0
            sense = ("with the rotation" if first.direction == "rotation"
                     else "against the rotation")
            out.append(Doublet(k, (first.frequency_hz,), (first.growth_rate,), "flutter",
                               f"the wave travelling {sense}" if grows else ""))
            continue
        pair = [m for m in family if m.direction in ("standing", "divergence")][:2]
        freqs = tuple(m.frequency_hz for m in pair)
        split = abs(freqs[1] - freqs[0]) / (0.5 * sum(freqs)) if len(pair) == 2 else 0.0
        growing = [i for i, m in enumerate(pair) if m.growth_rate > 0]
        out.append(Doublet(k, freqs, tuple(m.growth_rate for m in pair),
                           "split" if split > DEGENERATE else "degenerate",
                           " and ".join(("lower", "upper")[i] for i in growing)))
    return out


def doublet_lines(res: Any, kmax: int = 8) -> list[str]:
    """The doublet table of ``res`` as text lines (the CEA's console output)."""
    lines = [f"±k doublets (split: more than {100 * DEGENERATE:g} % apart; flutter pair: one "
             "member grows, its partner decays):",
             f"{'k':>4} {'f1 (Hz)':>9} {'f2 (Hz)':>9} {'split':>8}  state"]
    for d in doublets(res, kmax):
        f = [f"{x:9.1f}" for x in d.frequencies_hz] + [" " * 9] * (2 - len(d.frequencies_hz))
        if d.state == "flutter":
            state = (f"flutter pair: {d.unstable} grows at {d.growth_rates[0]:.1f} 1/s"
                     if d.unstable else "flutter pair, neutral")
        elif d.state == "missing":
            state = f"no mode of purity >= {MIN_PURITY:g} below the band's top"
        else:
            state = d.state + (f": the {d.unstable} grows" if d.unstable else ", both stable")
        lines.append(f"{d.k:4d} {f[0]} {f[1]} {d.split_hz:8.1f}  {state}")
    return lines
