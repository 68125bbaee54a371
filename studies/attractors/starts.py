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

**Rungs.** A rung of the ladder is a mesh (N contact nodes, ``mesh.n_inner``) and an element
degree p (``mesh.degree``): ``parse_rungs`` reads ``--meshes 132,264`` (each N at the
scene's degree, or at every degree of ``--degrees 1,2``) and explicit rungs
``--meshes 264p1,132p2``. A rung's key (``rung_key``: per-mesh keys of ``attractors.json``)
is ``"132"`` for degree 1, as a plain-N ladder always was, and ``"132p2"`` otherwise;
``rung_label`` is the value a JSON list holds (the integer N for degree 1).
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass

#: Defaults of the random start distribution (module docstring).
DEFAULT_N_MODES = 16
DEFAULT_AMPLITUDE = 0.1
DEFAULT_SEED = 1
#: Most random starts per mesh: each is a run, and a basin share's 95 % interval is already
#: +-1 % at 10^4 starts. Checked before the start list is made (2^31 starts would fill the
#: memory with it before any run).
MAX_STARTS = 10_000
#: The Lagrange degrees a rung may take (``mesh.degree``: P1/Q1, P2/Q2).
DEGREES = (1, 2)
#: Most rungs of a ladder: each is a census of M starts (a ladder needs a few).
MAX_RUNGS = 64
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

    def points(self, rungs: tuple, base_degree: int = 1) -> list[dict]:
        """The sweep points (dotted scene keys): per rung (N, p) (an int N: (N, 1)), random
        starts then structured. A point sets ``mesh.degree`` only where p is not the base
        scene's ``base_degree``, so the starts of a degree-1 ladder keep their names."""
        out: list[dict] = []
        for rung in rungs:
            n, degree = as_rung(rung)
            mesh = {"mesh.n_inner": n}
            if degree != base_degree:
                mesh["mesh.degree"] = degree
            out += [{**mesh, "initial.perturbation": "random", "initial.seed": s}
                    for s in self.seeds]
            out += [{**mesh, "initial.perturbation": "mode", "initial.mode": k}
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


#: One rung as text: N, or N then ``p`` then the degree (``132``, ``132p2``).
RUNG_TEXT = re.compile(r"([0-9]+)(?:p([0-9]+))?")


def as_rung(rung: object) -> tuple[int, int]:
    """(N, p) of a rung given as (N, p), an int N (degree 1) or a key (``parse_rung_key``)."""
    if isinstance(rung, tuple):
        return int(rung[0]), int(rung[1])
    return parse_rung_key(rung)


def rung_key(n: int, degree: int = 1) -> str:
    """The rung's key in ``attractors.json`` (per-mesh keys): ``"132"`` for degree 1 (the
    plain-N key), ``"132p2"`` for degree 2."""
    return str(int(n)) if int(degree) == 1 else f"{int(n)}p{int(degree)}"


def rung_label(n: int, degree: int = 1) -> int | str:
    """The rung as a JSON list holds it (``meshes``, the ladder's ``meshes``): the integer N
    for degree 1, as a plain-N ladder always wrote it, else its key ``"132p2"``."""
    return int(n) if int(degree) == 1 else rung_key(n, degree)


def parse_rung_key(key: object) -> tuple[int, int]:
    """(N, p) of a rung key or label: ``132`` or ``"132"`` -> (132, 1), ``"132p2"`` ->
    (132, 2). ValueError where it is not one."""
    if isinstance(key, int) and not isinstance(key, bool):
        return int(key), 1
    found = RUNG_TEXT.fullmatch(str(key).strip())
    if not found:
        raise ValueError(f"{key!r} is not a rung (N or NpP, e.g. 132 or 132p2)")
    return int(found[1]), int(found[2] or 1)


def parse_degrees(text: str | None) -> tuple[int, ...]:
    """``--degrees 1,2`` -> (1, 2) (each of ``DEGREES``, no repeats); () for None."""
    if text is None:
        return ()
    try:
        degrees = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise ValueError(f"--degrees {text!r}: give element degrees, e.g. 1,2") from None
    if not degrees or any(p not in DEGREES for p in degrees) \
            or len(set(degrees)) != len(degrees):
        raise ValueError(f"--degrees {text!r}: give distinct element degrees out of "
                         f"{', '.join(map(str, DEGREES))} (mesh.degree), e.g. 1,2")
    return degrees


def parse_rungs(meshes: str | None, degrees: str | None, default_n: int,
                default_degree: int = 1) -> tuple[tuple[int, int], ...]:
    """The rungs (N, p) of ``--meshes`` and ``--degrees`` (module docstring): a plain N is
    taken at every degree of ``degrees`` (default: the scene's ``default_degree``), a rung
    ``NpP`` as it is; no ``meshes``: the scene's N (``default_n``). Returned in the order
    given; the census orders them along the ladder (``census.ladder_order``: by dofs).
    ValueError (one line, naming the option and the fix): malformed text, N < 1, a degree
    out of ``DEGREES``, an odd N at degree 2 (its N/2 curved edges), a rung twice."""
    wanted = parse_degrees(degrees) or (default_degree,)
    text = meshes if meshes is not None else str(default_n)
    option = "--meshes" if meshes is not None else "--degrees"
    tokens = [t.strip() for t in text.split(",") if t.strip()]
    if not tokens:
        raise ValueError(f"--meshes {text!r}: the ladder is empty; give e.g. --meshes "
                         "132,264 or 264p1,132p2")
    if len(tokens) * len(wanted) > MAX_RUNGS:
        raise ValueError(f"{option} {text!r}: more than {MAX_RUNGS} rungs; give fewer")
    rungs: list[tuple[int, int]] = []
    for token in tokens:
        found = RUNG_TEXT.fullmatch(token)
        if not found:
            raise ValueError(f"--meshes {text!r}: {token!r} is not a rung; give contact-node "
                             "counts N or rungs NpP (N, then p, then the element degree), "
                             "e.g. 132,264 or 264p1,132p2")
        n = int(found[1])
        for p in (int(found[2]),) if found[2] else wanted:
            if n < 1:
                raise ValueError(f"{option} {text!r}: give positive node counts N")
            if p not in DEGREES:
                raise ValueError(f"--meshes {text!r}: degree {p} in {token!r} is not "
                                 f"supported; give p{' or p'.join(map(str, DEGREES))} "
                                 "(mesh.degree)")
            if p == 2 and n % 2:
                raise ValueError(f"{option} {text!r}: degree 2 needs an even N (N/2 curved "
                                 f"edges); give {n + 1}p2 or {n - 1}p2" if n > 1 else
                                 f"{option} {text!r}: degree 2 needs an even N")
            if (n, p) in rungs:
                raise ValueError(f"{option} {text!r}: the rung {rung_key(n, p)} appears "
                                 "twice; give each rung once")
            rungs.append((n, p))
    return tuple(rungs)
