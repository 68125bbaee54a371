"""The frequency lattice of an end state: its generators, its combination tones, its type.

A travelling component (k, f) of an end state (``features.Component``: wavenumber k ≥ 1,
signed lab frequency f = k c / 2π, + with the rotation) is the field A cos(kθ − 2π f t + φ).
Nonlinear coupling of two components (k₁, f₁), (k₂, f₂) puts energy at every integer
combination n₁(k₁, f₁) + n₂(k₂, f₂) (and (k, f) is the same wave as (−k, −f)). An end state
is described by the fewest **generators** whose combinations give every component:

* **Order.** The components are taken dominant first, then by decreasing share. Each one that
  is an integer combination Σ nᵢ (kᵢ, fᵢ) of the generators found so far, with
  |nᵢ| ≤ ``MAX_COEFFICIENT``, Σ nᵢ kᵢ = k exactly and |Σ nᵢ fᵢ − f| ≤ the frequency
  tolerance, is a **combination tone** with those coefficients (the smallest Σ |nᵢ|, then
  the smallest misfit); any other becomes the next generator. So the dominant component is
  the first generator and the largest component independent of it the second. A component
  that may not generate (a ``weak`` one, unless the caller allows it) and is no combination
  is left ``other``; an aliased component (its frequency unknown) cannot be shown to be a
  combination: it generates where it may.
* **Tolerance.** The caller gives it: the features use ``TONE_BINS`` = 1 bin of the
  window's resolution 1/W (10 Hz at W = 0.1 s): two frequencies closer than 1/W cannot be
  told apart by a window of length W (Rayleigh), so a component that close to a
  combination is that combination as far as the window can say. A refined peak of a
  resolved tone is exact to far less (settled tones measured: ≤ 0.02 bins), so a true
  tone's misfit Σ nᵢ δfᵢ stays well inside. Without a finite tolerance nothing is a tone.
* **Bound.** |nᵢ| ≤ 4: tones of order up to 8 (the measured ones are of order 2 and 3),
  while few coefficient vectors meet Σ nᵢ kᵢ = k, so a chance coincidence of an
  independent component within one bin of one of them is rare. Combinations use the first
  ``MAX_SEARCH`` generators.

**Type.** In the frame of the first generator, turning at Ω₁ = 2π f₁ / k₁ (its celerity over
R), a component is A cos(kθ' − 2π f' t + φ) with the **frame frequency**
f' = f − (k / k₁) f₁: 0 for the first generator, Σ nᵢ f'ᵢ for a tone. A generator whose f'
is within the tolerance of 0 travels with the first (a rigid pattern with it). Counting the
first generator and those that move in its frame: one is a **rigid wave** (a relative
equilibrium u = W(θ − Ω₁ t)); two a **relative periodic orbit**: with f'₂ the moving one's
frame frequency, periodic in that frame with period T = 1 / |f'₂|, so that in the lab
u(θ, t + T) = u(θ − s, t) with the shift s = Ω₁ T = 2π f₁ T / k₁ (+ with the rotation; up to
the pattern's own symmetry 2π / gcd of its k); three or more a **torus**.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np

#: The largest |nᵢ| of a combination tone (module docstring).
MAX_COEFFICIENT = 4
#: Combinations are searched over the first this many generators ((2N + 1)^g vectors).
MAX_SEARCH = 6
#: The lattice types by the number of frequencies (the first generator and the ones that move
#: in its frame); more than two: ``TORUS``.
TYPES = {1: "rigid wave", 2: "relative periodic orbit"}
TORUS = "torus"


@dataclass(frozen=True)
class Tone:
    """A combination tone: the component, its coefficients on the generators (in their
    order, zeros up to the last generator), and |Σ nᵢ fᵢ − f| in Hz."""

    component: object  # features.Component
    coefficients: tuple[int, ...]
    misfit_hz: float


@dataclass(frozen=True)
class Lattice:
    """Generators (``features.Component``, in the documented order), combination tones, the
    components that are neither (weak ones that may not generate), and the tolerance."""

    generators: tuple
    tones: tuple[Tone, ...] = ()
    others: tuple = ()
    tol_hz: float = math.nan

    def frame_frequency(self, c: object) -> float:
        """f' = f − (k / k₁) f₁ of a component in the first generator's frame (Hz)."""
        g1 = self.generators[0]
        return _f(c) - c.k / g1.k * _f(g1)

    @property
    def moving(self) -> tuple:
        """The generators after the first whose frame frequency is not within the
        tolerance of 0 (NaN, an aliased one, counts as moving)."""
        return tuple(g for g in self.generators[1:]
                     if not abs(self.frame_frequency(g)) <= self.tol_hz)

    @property
    def type(self) -> str:
        """"rigid wave", "relative periodic orbit" or "torus" (module docstring)."""
        if not self.generators:
            return ""
        return TYPES.get(1 + len(self.moving), TORUS)

    @property
    def period_s(self) -> float:
        """T = 1 / |f'₂| of a relative periodic orbit (NaN otherwise or where unknown)."""
        if self.type != TYPES[2]:
            return math.nan
        f = abs(self.frame_frequency(self.moving[0]))
        return 1.0 / f if f > 0.0 else math.nan

    @property
    def shift_deg(self) -> float:
        """s = 360° f₁ T / k₁ of a relative periodic orbit: the turn of the first
        generator's frame over one period (+ with the rotation); NaN otherwise."""
        g1 = self.generators[0] if self.generators else None
        return math.nan if g1 is None else 360.0 * _f(g1) * self.period_s / g1.k

    def to_dict(self) -> dict:
        """``type``, ``generators`` (k, direction, frequency, celerity, share), the
        ``combinations`` (k, direction, frequency, share, coefficients), ``period_s``,
        ``shift_deg`` and ``frame_frequency_hz`` (of the moving generator of an RPO)."""
        moving = self.moving
        return {"type": self.type,
                "generators": [_brief(g) for g in self.generators],
                "combinations": [{**_brief(t.component), "coefficients": list(t.coefficients)}
                                 for t in self.tones],
                "period_s": _json(self.period_s), "shift_deg": _json(self.shift_deg),
                "frame_frequency_hz": _json(self.frame_frequency(moving[0]))
                if self.type == TYPES[2] else None,
                "tolerance_hz": _json(self.tol_hz)}


def _f(c: object) -> float:
    """A component's signed frequency in Hz, NaN where unknown (aliased, or None)."""
    return math.nan if c.frequency_hz is None else float(c.frequency_hz)


def _json(x: float | None) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def _brief(c: object) -> dict:
    return {"k": c.k, "direction": c.direction, "frequency_hz": _json(_f(c)),
            "celerity_m_s": _json(c.celerity_m_s), "share": float(c.share)}


@functools.lru_cache(maxsize=16)
def _grid(n_generators: int, bound: int) -> np.ndarray:
    """Every coefficient vector in [−bound, bound]^g, shape ((2 bound + 1)^g, g); none
    for g = 0."""
    if n_generators == 0:
        return np.zeros((0, 0), dtype=np.int64)
    return np.array(list(itertools.product(range(-bound, bound + 1), repeat=n_generators)),
                    dtype=np.int64).reshape(-1, n_generators)


class _Search:
    """The combinations of the generators found so far: every coefficient vector on the
    first ``MAX_SEARCH`` generators with a known frequency (zero on the others), with its
    k and frequency, computed once per generator added."""

    def __init__(self, generators: list, bound: int) -> None:
        usable = [i for i, g in enumerate(generators) if math.isfinite(_f(g))]
        usable = usable[:MAX_SEARCH]
        self.width = len(generators)
        self.usable = usable
        self.grid = _grid(len(usable), bound)
        self.ks = self.grid @ np.array([generators[i].k for i in usable], dtype=np.int64)
        self.fs = self.grid @ np.array([_f(generators[i]) for i in usable])

    def find(self, c: object, tol_hz: float) -> tuple[tuple[int, ...], float] | None:
        """(coefficients, misfit in Hz) of the simplest combination giving ``c``, or None."""
        if not self.usable or not math.isfinite(_f(c)) or not tol_hz >= 0.0:
            return None
        misfit = np.abs(self.fs - _f(c))
        hits = np.nonzero((self.ks == c.k) & (misfit <= tol_hz))[0]
        if hits.size == 0:
            return None
        order = np.lexsort((misfit[hits], np.abs(self.grid[hits]).sum(axis=1)))
        best = hits[order[0]]
        coefficients = [0] * self.width
        for i, n in zip(self.usable, self.grid[best], strict=True):
            coefficients[i] = int(n)
        return tuple(coefficients), float(misfit[best])


def lattice_of(components: tuple | list, tol_hz: float, *, weak_generators: bool = False,
               bound: int = MAX_COEFFICIENT) -> Lattice:
    """The frequency lattice of ``components`` (dominant first, then by share, as
    ``features.travelling_components`` gives them; module docstring). ``tol_hz``: the
    frequency tolerance of a tone; ``weak_generators``: whether a ``weak`` component may be a
    generator (where it is named, ``features.Features.named``)."""
    generators: list = []
    tones: list[Tone] = []
    others: list = []
    search = None
    for c in components:
        found = search.find(c, tol_hz) if search is not None else None
        if found is not None:
            tones.append(Tone(c, *found))
        elif weak_generators or not getattr(c, "weak", False):
            generators.append(c)
            search = _Search(generators, bound)
        else:
            others.append(c)
    n = len(generators)
    tones = [Tone(t.component, t.coefficients + (0,) * (n - len(t.coefficients)), t.misfit_hz)
             for t in tones]
    return Lattice(tuple(generators), tuple(tones), tuple(others), tol_hz)


def tone_text(coefficients: tuple[int, ...] | list[int], labels: tuple | list) -> str:
    """"2(6) − (10)": a tone's coefficients on the generators, each generator by its label
    (its k)."""
    text = ""
    for n, label in zip(coefficients, labels, strict=False):
        if n:
            sign = "−" if n < 0 else "+"
            term = f"{abs(n) if abs(n) != 1 else ''}({label})"
            text += (f" {sign} " if text else ("−" if n < 0 else "")) + term
    return text
