"""The starts of a census: the random distribution and the structured mode-k bumps.

Every start is steady sliding plus a radial bump of the inner circle (``solver.run.
Simulation.perturbation``), shaped through the thickness by X(r) (paper eq. [1]):

* random start with seed s: u_r(θ) = A d Σ_{k=1..K} w_k ½ (1 + cos(kθ + φ_k)), with
  w_k ~ U(0, 1) normalised to Σ w_k = 1 and φ_k ~ U(0, 2π), drawn by
  ``numpy.random.default_rng(s)``; start i of M has s = S + i (S = ``--seed``);
* structured start k: u_r(θ) = A d ½ (1 + cos kθ) (``initial.perturbation = "mode"``).

The same seeds are used on every mesh of the ladder, so random start i is the same function
of θ on every mesh (common random numbers: a difference between meshes is the mesh's, not
the draw's). The defaults K = 16, A = 0.1 are the scene's own random bump; basin shares
belong to the distribution, so the census records it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

#: Defaults of the random start distribution (module docstring).
DEFAULT_N_MODES = 16
DEFAULT_AMPLITUDE = 0.1
DEFAULT_SEED = 1
#: Most random starts per mesh: each is a run, and a basin share's 95 % interval is already
#: +-1 % at 10^4 starts. Checked before the start list is made (2^31 starts would fill the
#: memory with it before any run).
MAX_STARTS = 10_000
#: Largest seed: random start i's seed S + i is written to the census's TOML file, whose
#: integers are 64-bit.
MAX_SEED = 2**63 - 1


@dataclass(frozen=True)
class StartDistribution:
    """M random starts with seeds ``seed`` … ``seed + starts - 1``, and structured ones."""

    starts: int
    seed: int = DEFAULT_SEED
    n_modes: int = DEFAULT_N_MODES
    amplitude: float = DEFAULT_AMPLITUDE
    structured: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if not 0 <= self.starts <= MAX_STARTS:
            raise ValueError(f"--starts {self.starts}: use an integer 1 <= M <= {MAX_STARTS}"
                             " (random starts per mesh, each a run)")
        if not 0 <= self.seed <= MAX_SEED - self.starts:
            raise ValueError(f"--seed {self.seed}: use an integer 0 <= S <= 2^63 - 1 - M "
                             "(seeds S .. S + M - 1 are 64-bit integers)")
        if self.n_modes < 1:
            raise ValueError(f"--n-modes {self.n_modes}: use an integer >= 1")
        if not self.amplitude > 0.0:
            raise ValueError(f"--amplitude {self.amplitude}: use a fraction of d > 0")
        if any(k < 1 for k in self.structured):
            raise ValueError(f"--structured {self.structured}: wavenumbers must be >= 1")

    @property
    def seeds(self) -> range:
        return range(self.seed, self.seed + self.starts)

    def describe(self) -> str:
        text = (f"{self.starts} random starts: steady sliding + A d Σ_k w_k (1 + cos(kθ + φ_k))"
                f"/2, k = 1..{self.n_modes}, A = {self.amplitude:g}, w ~ U(0,1) normalised, "
                f"φ ~ U(0,2π), seeds {self.seed}..{self.seed + self.starts - 1}")
        if self.structured:
            text += (f"; structured: A d (1 + cos kθ)/2 for k = "
                     f"{', '.join(map(str, self.structured))}")
        return text

    def to_dict(self) -> dict:
        d = asdict(self)
        d["structured"] = list(self.structured)
        d["description"] = self.describe()
        return d

    def points(self, meshes: tuple[int, ...]) -> list[dict]:
        """The sweep points (dotted scene keys): per mesh, random starts then structured."""
        out: list[dict] = []
        for n in meshes:
            out += [{"mesh.n_inner": n, "initial.perturbation": "random", "initial.seed": s}
                    for s in self.seeds]
            out += [{"mesh.n_inner": n, "initial.perturbation": "mode", "initial.mode": k}
                    for k in self.structured]
        return out


def parse_structured(text: str | None, k_max: int) -> tuple[int, ...]:
    """``K1:K2`` (inclusive) or ``K1,K2,...`` -> wavenumbers 1 <= k <= ``k_max`` (the
    coarsest mesh's n_inner // 2: two contact nodes per wavelength, as ``initial.n_modes``);
    checked before the list is made. ValueError names the fix."""
    if not text:
        return ()
    try:
        if ":" in text:
            a, b = (int(x) for x in text.split(":"))
            bounds = (a, b)
        else:
            bounds = tuple(int(x) for x in text.split(","))
    except ValueError:
        raise ValueError(f"--structured {text!r}: use K1:K2 or K1,K2,... (integers)") from None
    if ":" in text and a > b:
        raise ValueError(f"--structured {text!r}: give K1 <= K2")
    if not bounds or min(bounds) < 1 or max(bounds) > k_max:
        raise ValueError(f"--structured {text!r}: give wavenumbers 1 <= k <= {k_max} "
                         "(mesh.n_inner // 2 of the coarsest mesh: two contact nodes per "
                         "wavelength)")
    return tuple(range(a, b + 1)) if ":" in text else bounds


def parse_meshes(text: str) -> tuple[int, ...]:
    """``132,264,528`` -> (132, 264, 528), increasing, no repeats; ValueError names the fix."""
    try:
        meshes = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise ValueError(f"--meshes {text!r}: give contact-node counts, e.g. 132,264") from None
    if not meshes:
        raise ValueError(f"--meshes {text!r}: the ladder is empty; give e.g. --meshes 132,264")
    if any(n < 1 for n in meshes) or len(set(meshes)) != len(meshes):
        raise ValueError(f"--meshes {text!r}: give distinct positive node counts")
    return tuple(sorted(meshes))
