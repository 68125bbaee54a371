"""Features of an end state: its travelling components, from the space-time spectrum.

An end state is described over a window [t₀, t₁] of the contact-circle samples
u_r(θ_j, t_n), u_θ(θ_j, t_n) (N nodes uniform in θ, S samples every Δt_s) by its
**travelling components** (``window_features``), in the spirit of Attractors.jl's
``AttractorsViaFeaturizing`` (featurise every end state, then group the features):

* Space: the Fourier coefficient of wavenumber k = 1 … N/2,
  a_k(t_n) = (2/N) Σ_j u(θ_j, t_n) e^{−ikθ_j}, its time mean (a standing deformation)
  removed. A component A cos(k(θ − c t) + φ) travelling at angular speed c (c > 0: with the
  rotation) gives a_k(t) = A e^{iφ} e^{−ikct}.
* Time: the Hann-windowed transform X_k(f) = Σ_n w_n a_k(t_n) e^{−2πi f t_n} over
  f ∈ [−f_s/2, f_s/2), f_s = 1/Δt_s. The component sits at f = −kc/2π with |X_k| = A Σ_n w_n.
  Per k and per sign of f the largest peak is taken and its frequency refined by maximising
  |X_k(f)|² within ±1 bin (bounded scalar search on the transform itself, so a clean tone is
  located to round-off, not to the bin width 1/(t₁ − t₀)). u_r and u_θ enter together:
  amplitude A = sqrt(|X_k,r|² + |X_k,θ|²) / Σ w at the peak.
* Harmonics: a peak at wavenumber m k (m ≥ 2) whose frequency is m times the frequency of a
  component at k (folded into [−f_s/2, f_s/2) where m f is above the Nyquist frequency f_s/2)
  travels at k's phase speed: it belongs to k (listed as k's harmonic; its amplitude adds to
  k's as sqrt(Σ A²)), within ``HARMONIC_BINS`` bins. So does a sum tone k₁ + k₂ at
  f₁ + f₂ of two components larger than it (to the larger; its amplitude is not added).
* Components: the remaining peaks. Each has a frequency f_k = k c/2π (signed, + with the
  rotation), a celerity R c = 2π R f_k / k and a **share**: its amplitude (with its
  harmonics) over the largest component's (the dominant: share 1). Components of share
  ≥ ``SHARE_TOL`` are listed; those between ``SHARE_TOL`` / 2 and ``SHARE_TOL`` are kept as
  ``weak`` so that a comparison across a threshold does not flip (``match``).
* Aliasing: a harmonic whose true frequency m f is at or above f_s/2 is flagged ``aliased``;
  so is a component whose peak lies within one bin of ±f_s/2, and, where the run recorded
  every-step probes (``probe_t``, ``probe_data``), a component whose frequency the probe's
  own spectrum does not hold (below half its amplitude): its true frequency is another
  alias. An aliased component has no celerity (NaN), never a speed. Without probes a
  component folded from above f_s/2 cannot be told from one below, except as a harmonic.

Lattice (``studies.attractors.lattice``, ``Features.lattice``): the components are integer
combinations of a few **generators** (dominant first, then the largest independent one);
the others are **combination tones**, within ``TONE_BINS`` bins of the window's resolution.
A name gives the generators only (``Features.named``); the number of generators that move
types the state (rigid wave, relative periodic orbit, torus).

``match(a, b)`` is the one rule that says two feature sets are the same state: between two
starts (grouping into attractors) and between two consecutive windows of one start
(stationarity: a settled end state). It asks for the same listed components (k and
direction; a component listed in one needs at least a ``weak`` one, or the same peak
attached as a harmonic or sum tone, in the other), each celerity within ``CELERITY_TOL``
(relative), each share within ``SHARE_TOL_REL`` (relative, at least ``SHARE_TOL_ABS``), and
the zone fractions within ``FRACTION_TOL``. So the generators are compared by frequency
(celerity) and share, which keeps the lattice type; a combination tone of the two sets'
lattice together (``joint_tones``) is not compared: its share follows from the generators'
and, where a slow generator's period is not short against the window, swings with the
window's phase. ``stationary`` adds, between two windows, the RMS amplitude within
``AMPLITUDE_TOL`` and, where the later window is not a rigid wave and has no tones, the
frame spread within ``SPREAD_CHANGE_REL`` (the spread holds the tones). Two windows
accept a companion whose share decays slowly; ``share_drift`` judges the whole last leg of
settle-or-extend (``leg_window_ends``): the least-squares line of each share across its
windows, extrapolated over the next leg, (``LEG_GROWTH`` − 1) t_end, must move it by no more
than the share tolerance. The tolerances and the spreads measured behind them:
docs/attractors.md.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from stickslip.solver.contact import zone_fractions
from stickslip.studies.attractors.lattice import Lattice, lattice_of

#: Share (amplitude over the dominant component's) from which a component is listed.
SHARE_TOL = 0.10
#: Relative celerity difference within which two components are the same.
CELERITY_TOL = 0.02
#: Relative share difference within which two components are the same (and its floor).
SHARE_TOL_REL = 0.10
SHARE_TOL_ABS = 0.02
#: Short names of the regimes in member ids.
REGIME_SHORT = {"stick-slip-separation": "SSS", "stick-slip": "SS", "slip-separation": "SSep",
                "steady-sliding": "sliding"}
#: Zone-fraction difference (absolute) within which two end states are the same.
FRACTION_TOL = 0.02
#: Frequency tolerance of a harmonic, in bins of the window's resolution 1/(t₁ − t₀).
HARMONIC_BINS = 2.0
#: Frequency tolerance of a combination tone (``lattice``), in bins: two frequencies closer
#: than the resolution 1/(t₁ − t₀) cannot be told apart by one window (Rayleigh).
TONE_BINS = 1.0
#: Relative change of the RMS amplitude between two windows above which a start is unsettled.
AMPLITUDE_TOL = 0.05
#: Frame spread at or below which one listed component is a rigid wave (``classify``).
SPREAD_TOL = 0.10
#: Change of the frame spread between two windows above which a start is unsettled
#: (relative, and its floor): weak companions that still decay or grow.
SPREAD_CHANGE_REL = 0.10
SPREAD_CHANGE_ABS = 0.01
#: A component whose probe amplitude at its frequency is below this fraction of its own is
#: folded from another frequency (``aliased``).
PROBE_FRACTION = 0.5
#: Each leg of settle-or-extend takes an unsettled start from t to LEG_GROWTH × t
#: (``studies.attractors.census``); ``share_drift`` extrapolates the shares over the next one.
LEG_GROWTH = 1.5


@dataclass(frozen=True)
class Component:
    """One travelling component: wavenumber, direction, share, frequency, celerity."""

    k: int
    direction: str  # "rotation" or "opposite"
    share: float  # amplitude (with harmonics) over the dominant component's
    amplitude_m: float  # with its harmonics, sqrt(Σ A²)
    frequency_hz: float  # signed lab frequency k c / 2π (+ with the rotation); NaN if aliased
    celerity_m_s: float  # 2π R f / k, NaN if aliased
    aliased: bool = False
    weak: bool = False  # share between SHARE_TOL / 2 and SHARE_TOL
    harmonics: tuple[dict, ...] = ()  # its harmonics and sum tones: {"k", "share",
    # "aliased", "of" ("×m" or "k1+k2"), "direction"}

    @property
    def key(self) -> tuple[int, str]:
        return (self.k, self.direction)


@dataclass(frozen=True)
class Features:
    """The features of one end state over one window (module docstring)."""

    components: tuple[Component, ...]  # dominant first, then by share
    fractions: dict = field(default_factory=dict)  # stick, slip, separation
    rms_amplitude_m: float = math.nan
    window: tuple[float, float] = (math.nan, math.nan)
    nyquist_hz: float = math.nan
    resolution_hz: float = math.nan
    frame_spread: float = math.nan  # in the frame of the dominant component

    @property
    def listed(self) -> tuple[Component, ...]:
        return tuple(c for c in self.components if not c.weak)

    @property
    def dominant(self) -> Component | None:
        return self.components[0] if self.components else None

    @property
    def rigid(self) -> bool:
        """One listed component (its harmonics included): a rigidly travelling wave, where
        its weak companions leave the frame spread small (``classify``)."""
        return len(self.listed) == 1

    def lattice(self, rigid: bool = True) -> Lattice:
        """The frequency lattice of the components (``lattice.lattice_of``), tones within
        ``TONE_BINS`` bins of the resolution; generators among the listed components,
        and among the weak ones too where one listed component is not a rigid wave (its
        weak companions together are not small)."""
        return lattice_of(self.components, TONE_BINS * self.resolution_hz,
                          weak_generators=not rigid and len(self.listed) == 1)

    def named(self, rigid: bool) -> tuple[Component, ...]:
        """The components a name gives: the generators of its ``lattice``, never a
        combination tone (so a tone at the listing threshold cannot flip the name)."""
        return self.lattice(rigid).generators

    def to_dict(self) -> dict:
        d = asdict(self)
        d["components"] = [asdict(c) for c in self.components]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Features:
        numeric = ("share", "amplitude_m", "frequency_hz", "celerity_m_s")  # null: NaN
        comps = tuple(Component(**{**c, **{q: _num(c.get(q)) for q in numeric},
                                   "harmonics": tuple(c.get("harmonics") or ())})
                      for c in d.get("components") or ())
        return cls(comps, dict(d.get("fractions") or {}),
                   _num(d.get("rms_amplitude_m")), tuple(_num(x) for x in d["window"]),
                   _num(d.get("nyquist_hz")), _num(d.get("resolution_hz")),
                   _num(d.get("frame_spread")))


def _num(x: object) -> float:
    return math.nan if x is None else float(x)


# ================================================================ the space-time spectrum


def _mode_series(t: np.ndarray, theta: np.ndarray, field_: np.ndarray) -> np.ndarray:
    """a_k(t_n), k = 1 … N/2, time mean removed (module docstring); shape (S, N/2)."""
    order = np.argsort(theta)
    n = theta.size
    a = np.fft.rfft(field_[:, order], axis=1)[:, 1:n // 2 + 1] * (2.0 / n)
    if n % 2 == 0:
        a[:, -1] *= 0.5  # the alternating mode k = N/2 has weight 1/N, not 2/N
    return a - a.mean(axis=0)


def _dtft(x: np.ndarray, w: np.ndarray, t: np.ndarray, f: float) -> complex:
    return complex(np.sum(w * x * np.exp(-2j * np.pi * f * (t - t[0]))))


def _refine(series: tuple[np.ndarray, ...], w: np.ndarray, t: np.ndarray, f0: float,
            bin_hz: float) -> tuple[float, float]:
    """(f, Σ|X(f)|²) at the maximum of Σ|X|² within f0 ± 1 bin (bounded scalar search)."""
    from scipy.optimize import minimize_scalar

    def neg(f: float) -> float:
        return -sum(abs(_dtft(x, w, t, f)) ** 2 for x in series)

    res = minimize_scalar(neg, bounds=(f0 - bin_hz, f0 + bin_hz), method="bounded",
                          options={"xatol": 1e-7 * bin_hz})
    f, p = float(res.x), -float(res.fun)
    p0 = -neg(f0)
    return (f, p) if p >= p0 else (f0, p0)


def _fold(f: float, fs: float) -> float:
    return (f + 0.5 * fs) % fs - 0.5 * fs


def _peaks(t: np.ndarray, a_r: np.ndarray, a_t: np.ndarray, floor: float) -> list[dict]:
    """Per k and sign of f, the largest peak of |X_k|² above ``floor`` × the largest one:
    {"k", "f" (observed, signed, Hz), "amplitude"}, the frequency refined."""
    s = t.size
    w = np.hanning(s)
    dt_s = (t[-1] - t[0]) / (s - 1)
    bin_hz = 1.0 / (s * dt_s)
    freqs = np.fft.fftfreq(s, dt_s)
    power = (np.abs(np.fft.fft(a_r * w[:, None], axis=0)) ** 2
             + np.abs(np.fft.fft(a_t * w[:, None], axis=0)) ** 2)  # (S, K)
    power[np.abs(freqs) < 1.5 * bin_hz] = 0.0  # what is left of a standing deformation
    top = float(power.max())
    if top <= 0.0:
        return []
    out = []
    for sign in (1.0, -1.0):
        half = np.where((sign * freqs > 0)[:, None], power, 0.0)
        for j in np.nonzero(half.max(axis=0) >= floor**2 * top)[0]:
            i = int(np.argmax(half[:, j]))
            f, p = _refine((a_r[:, j], a_t[:, j]), w, t, float(freqs[i]), bin_hz)
            out.append({"k": int(j) + 1, "f": f, "amplitude": math.sqrt(p) / float(w.sum())})
    return out


def _parent(p: dict, bases: list[dict], fs: float, tol_hz: float) -> tuple[dict | None, dict]:
    """The component a peak belongs to, and how: a harmonic m k₁ at m f₁ (``"×m"``), or a
    sum k₁ + k₂ at f₁ + f₂ of two components larger than it (``"k₁+k₂"``, given to the
    larger), frequencies compared folded into [−f_s/2, f_s/2) within ``tol_hz``."""
    for b in bases:
        m = p["k"] // b["k"]
        if p["k"] % b["k"] == 0 and m >= 2 and not b["aliased"] \
                and abs(_fold(p["f"] - m * b["f"], fs)) <= tol_hz:
            return b, {"aliased": bool(abs(m * b["f"]) >= 0.5 * fs), "of": f"×{m}"}
    big = [b for b in bases if b["amplitude"] >= p["amplitude"] and not b["aliased"]]
    for i, a in enumerate(big):
        for b in big[i:]:
            if a["k"] + b["k"] == p["k"] and abs(_fold(p["f"] - a["f"] - b["f"], fs)) <= tol_hz:
                first, second = (a, b) if a["amplitude"] >= b["amplitude"] else (b, a)
                return first, {"aliased": bool(abs(a["f"] + b["f"]) >= 0.5 * fs),
                               "of": f"{first['k']}+{second['k']}"}
    return None, {}


def _probe_amplitude(probe_t: np.ndarray, probe: np.ndarray, f: float) -> float:
    """Amplitude sqrt(A_r² + A_θ²) of the every-step probe signals at |f| (Hann window)."""
    w = np.hanning(probe_t.size)
    x = probe - probe.mean(axis=0)
    p = sum(abs(_dtft(x[:, c], w, probe_t, abs(f))) ** 2 for c in range(x.shape[1]))
    return 2.0 * math.sqrt(p) / w.sum()


def travelling_components(t: np.ndarray, theta: np.ndarray, u_r: np.ndarray,
                          u_theta: np.ndarray, radius: float, *, share_tol: float = SHARE_TOL,
                          probe_t: np.ndarray | None = None,
                          probe: np.ndarray | None = None) -> tuple[Component, ...]:
    """The travelling components of the samples (module docstring), dominant first.

    ``probe_t``, ``probe`` (every-step times and (u_r, u_θ) columns of one probe over the same
    window) let a component folded from above the Nyquist frequency be flagged.
    """
    s = t.size
    if s < 8:
        return ()
    dt_s = (t[-1] - t[0]) / (s - 1)
    fs, bin_hz = 1.0 / dt_s, 1.0 / (s * dt_s)
    peaks = _peaks(t, _mode_series(t, theta, u_r), _mode_series(t, theta, u_theta),
                   0.25 * share_tol)
    peaks.sort(key=lambda p: (p["k"], -p["amplitude"]))
    bases: list[dict] = []
    for p in peaks:  # ascending k: a harmonic's or a sum's parents come first
        parent, label = _parent(p, bases, fs, HARMONIC_BINS * bin_hz)
        if parent is not None:
            sense = -p["f"] if not label["aliased"] else -parent["f"]
            parent["harmonics"].append({"k": p["k"], "amplitude": p["amplitude"],
                                        "aliased": label["aliased"], "of": label["of"],
                                        "direction": "rotation" if sense > 0 else "opposite"})
            continue
        aliased = bool(abs(p["f"]) >= 0.5 * fs - bin_hz)
        if not aliased and probe is not None and probe_t is not None and probe_t.size >= 8:
            aliased = bool(_probe_amplitude(probe_t, probe, p["f"])
                           < PROBE_FRACTION * p["amplitude"])
        bases.append({**p, "aliased": aliased, "harmonics": []})
    for b in bases:
        b["total"] = math.sqrt(b["amplitude"] ** 2 + sum(
            h["amplitude"] ** 2 for h in b["harmonics"] if h["of"].startswith("×")))
    if not bases:
        return ()
    top = max(b["total"] for b in bases)
    comps = []
    for b in sorted(bases, key=lambda b: -b["total"]):
        share = b["total"] / top
        if share < 0.5 * share_tol:
            continue
        f_lab = -b["f"]  # a_k ∝ e^{−ikct}: the peak sits at f = −k c / 2π
        comps.append(Component(
            k=b["k"], direction="rotation" if f_lab > 0 else "opposite", share=share,
            amplitude_m=b["total"], frequency_hz=math.nan if b["aliased"] else f_lab,
            celerity_m_s=math.nan if b["aliased"] else 2 * math.pi * radius * f_lab / b["k"],
            aliased=b["aliased"], weak=share < share_tol,
            harmonics=tuple({"k": h["k"], "share": h["amplitude"] / top,
                             "aliased": h["aliased"], "of": h["of"],
                             "direction": h["direction"]} for h in b["harmonics"])))
    return tuple(comps)


def frame_spread(t: np.ndarray, theta: np.ndarray, u_r: np.ndarray, u_theta: np.ndarray,
                 omega: float, window: float) -> tuple[float, float]:
    """(frame spread, RMS amplitude in m) over the last ``window`` s (``classify``
    module docstring).

    The RMS amplitude is sqrt(mean over samples and nodes of |u − ū(t)|²), u = (u_r, u_θ)
    on the contact circle, ū(t) its circle mean: the size of the travelling part.
    """
    order = np.argsort(theta)
    n = order.size
    sel = t >= t[-1] - window
    if sel.sum() < 2:
        return math.nan, math.nan
    k = np.fft.rfftfreq(n, 1.0 / n)
    shift = np.exp(1j * k[None, :] * omega * (t[sel] - t[-1])[:, None])
    dev = mean_sq = amp_sq = 0.0
    for comp in (u_r, u_theta):
        spectrum = np.fft.rfft(comp[sel][:, order], axis=1)
        spectrum[:, 0] = 0.0  # the axisymmetric part (steady sliding) is not the wave
        amp_sq += float(np.mean(np.fft.irfft(spectrum, n, axis=1) ** 2))
        back = np.fft.irfft(spectrum * shift, n, axis=1)
        mean = back.mean(axis=0)
        dev += float(np.mean((back - mean) ** 2))
        mean_sq += float(np.mean(mean**2))
    spread = math.sqrt(dev / mean_sq) if mean_sq > 0.0 else math.inf
    return spread, math.sqrt(amp_sq)


def _fractions(status: np.ndarray | None) -> dict:
    if status is None or status.size == 0:
        return {}

    return {k: float(v) for k, v in zone_fractions(status).items()}


def window_features(samples: dict, radius: float, t0: float, t1: float, *,
                    share_tol: float = SHARE_TOL) -> Features:
    """The features of ``samples`` (``samples.npz``'s arrays: t, theta, u_r, u_theta, and
    status, probe_t, probe_data where present) over [t0, t1] (module docstring)."""
    t = samples["t"]
    sel = (t >= t0) & (t <= t1)
    ts = t[sel]
    probe_t = probe = None
    if samples.get("probe_t") is not None and len(samples["probe_t"]):
        psel = (samples["probe_t"] >= t0) & (samples["probe_t"] <= t1)
        probe_t = samples["probe_t"][psel]
        probe = samples["probe_data"][0][psel][:, :2]
    comps = travelling_components(ts, samples["theta"], samples["u_r"][sel],
                                  samples["u_theta"][sel], radius, share_tol=share_tol,
                                  probe_t=probe_t, probe=probe)
    status = samples.get("status")
    dev = [samples[c][sel] - samples[c][sel].mean(axis=1, keepdims=True)
           for c in ("u_r", "u_theta")]
    rms = math.sqrt(sum(float(np.mean(d**2)) for d in dev)) if ts.size else math.nan
    dt_s = (ts[-1] - ts[0]) / (ts.size - 1) if ts.size > 1 else math.nan
    spread = math.nan
    if comps and not comps[0].aliased:
        spread, _ = frame_spread(ts, samples["theta"], samples["u_r"][sel],
                                 samples["u_theta"][sel], comps[0].celerity_m_s / radius,
                                 float(t1 - t0))
    return Features(comps, _fractions(status[sel] if status is not None else None), rms,
                    (float(t0), float(t1)), 0.5 / dt_s,
                    1.0 / (ts.size * dt_s) if ts.size > 1 else math.nan, spread)


@dataclass(frozen=True)
class Settled:
    """What ``settle_verdict`` reads from a run's samples."""

    earlier: Features  # the window before the last
    later: Features  # the last window
    settle_time: float  # NaN: unsettled
    drift: tuple[str, ...] = ()  # why the shares still drift across the last leg


def settle_scan(samples: dict, radius: float, window: float, *,
                tol: Tolerances | None = None, spread_tol: float = SPREAD_TOL,
                share_tol: float = SHARE_TOL) -> tuple[Features, Features, float]:
    """(features of the window before the last, of the last, settle time):
    ``settle_verdict``'s, as a tuple."""
    v = settle_verdict(samples, radius, window, tol=tol, spread_tol=spread_tol,
                       share_tol=share_tol)
    return v.earlier, v.later, v.settle_time


def settle_verdict(samples: dict, radius: float, window: float, *,
                   tol: Tolerances | None = None, spread_tol: float = SPREAD_TOL,
                   share_tol: float = SHARE_TOL, growth: float = LEG_GROWTH) -> Settled:
    """The features of the last two windows and the **settle time** t_s of a run's samples.

    Window pairs [t − 2W, t − W], [t − W, t] are taken at t = t_end, t_end − W, … (while
    t − 2W ≥ t_0, the first sample); t_s is the smallest such t from which every later pair
    is ``stationary``: the state has not changed since. NaN where the last pair is not
    stationary, or where the shares still drift across the last leg (``share_drift`` over
    the windows of ``leg_window_ends``, extrapolated over the next leg (growth − 1) t_end):
    unsettled. Each window's features are computed once, from the end back to the first
    pair that is not stationary and over the last leg, so a start that settled long before
    t_end costs (t_end − t_s)/W + 2 windows.
    """
    tol = DEFAULT_TOLERANCES if tol is None else tol
    t = samples["t"]
    t_end, t_first = float(t[-1]), float(t[0])
    computed: dict[int, Features] = {}  # by the number of windows before t_end

    def at(j: int) -> Features:
        if j not in computed:
            end = t_end - j * window
            computed[j] = window_features(samples, radius, end - window, end,
                                          share_tol=share_tol)
        return computed[j]

    settled_at = math.nan
    j = 0
    # a float tolerance of a thousandth of a window: t_end − jW lands on t_0 up to round-off
    while t_end - (j + 2) * window >= t_first - 1e-3 * window:
        if stationary(at(j + 1), at(j), tol, spread_tol=spread_tol):
            break
        settled_at = t_end - j * window
        j += 1
    drift: tuple[str, ...] = ()
    if math.isfinite(settled_at):
        ends = leg_window_ends(t_end, t_first, window, growth)
        drift = tuple(share_drift([at(n) for n in range(len(ends) - 1, -1, -1)],
                                  (growth - 1.0) * t_end, tol))
        if drift:
            settled_at = math.nan
    return Settled(at(1), at(0), settled_at, drift)


def leg_window_ends(t_end: float, t_first: float, window: float,
                    growth: float = LEG_GROWTH) -> list[float]:
    """End times (oldest first) of the windows of length W that tile the last leg of
    settle-or-extend back from t_end: the leg [t_end / growth, t_end], at least two windows
    (the first leg of a census, t_end = 3W, has exactly two), none before t_0."""
    span = max(2.0 * window, (1.0 - 1.0 / growth) * t_end)
    n = max(2, int(math.floor(span / window + 1e-3)))
    ends = [t_end - j * window for j in range(n)
            if t_end - (j + 1) * window >= t_first - 1e-3 * window]
    return ends[::-1]


def share_drift(windows: list[Features], horizon: float,
                tol: Tolerances | None = None) -> list[str]:
    """Why the shares of consecutive windows of one start (oldest first) still drift
    ([] = they do not).

    For every component listed in any window, the least-squares line s(t) = s̄ + b (t − t̄)
    of its share over the windows that hold it (listed, weak, or attached as a harmonic or
    sum tone; t the window centres) must move it by no more than the share tolerance of
    ``match`` over the ``horizon`` (s, the next leg): |b| H ≤ max(share_rel max(s₁, s₂),
    share_abs), s₁ = s(t_last), s₂ = s(t_last + H), both taken as 0 where the line is below.
    A share that only jitters has b ≈ 0; one that decays by a few points per leg fails
    although two consecutive windows pass; one below the listing threshold ``SHARE_TOL``
    at both ends (a companion that has died out, or a weak one) names nothing and is left
    to the frame spread. A combination tone (``joint_tones``) follows its generators and is
    not judged.
    """
    tol = DEFAULT_TOLERANCES if tol is None else tol
    why = []
    keys = sorted({c.key for f in windows for c in f.listed} - joint_tones(windows))
    centre_last = 0.5 * sum(windows[-1].window)
    for key in keys:
        points = []
        for f in windows:
            s = next((c.share for c in f.components if c.key == key), None)
            s = _attached_share(f, key) if s is None else s
            if s is not None:
                points.append((0.5 * sum(f.window), s))
        if len(points) < 2:  # a component in one window only: ``differences`` says so
            continue
        tc, sc = np.array(points).T
        if np.ptp(tc) <= 0.0:
            continue
        slope = float(np.polyfit(tc - tc.mean(), sc, 1)[0])
        now = max(0.0, float(sc.mean() + slope * (centre_last - tc.mean())))
        later = max(0.0, now + slope * horizon)
        if max(now, later) < SHARE_TOL:
            continue
        if abs(later - now) > max(tol.share_rel * max(now, later), tol.share_abs):
            why.append(f"k = {key[0]} {SENSE[key[1]]} share drifts {100 * slope:+.1f} "
                       f"points/s ({100 * now:.0f} % now, {100 * later:.0f} % in "
                       f"{horizon:.2g} s)")
    return why


# ===================================================================== the one rule


@dataclass(frozen=True)
class Tolerances:
    """What ``match`` allows between two feature sets (module docstring)."""

    celerity: float = CELERITY_TOL
    share_rel: float = SHARE_TOL_REL
    share_abs: float = SHARE_TOL_ABS
    fraction: float = FRACTION_TOL


#: The tolerances of the module docstring.
DEFAULT_TOLERANCES = Tolerances()


def differences(a: Features, b: Features, tol: Tolerances = DEFAULT_TOLERANCES) -> list[str]:
    """Why ``a`` and ``b`` are not the same state, one phrase per reason ([] = the same)."""
    why = []
    mine = {c.key: c for c in a.components}
    theirs = {c.key: c for c in b.components}
    tones = joint_tones([a, b])
    for key in sorted({c.key for c in a.listed} | {c.key for c in b.listed}):
        if key in tones:  # follows from the generators
            continue
        ca, cb = mine.get(key), theirs.get(key)
        name = f"k = {key[0]} {SENSE[key[1]]}"
        if ca is None or cb is None:
            # a peak found attached in one (a harmonic or a sum tone of two components) and
            # listed in the other is there in both: compare its share only
            sa = ca.share if ca is not None else _attached_share(a, key)
            sb = cb.share if cb is not None else _attached_share(b, key)
            if sa is None or sb is None:
                why.append(f"{name} in one only")
            elif abs(sa - sb) > max(tol.share_rel * max(sa, sb), tol.share_abs):
                why.append(f"{name} share {100 * sa:.0f} vs {100 * sb:.0f} %")
            continue
        if ca.aliased != cb.aliased:
            why.append(f"{name} aliased in one only")
        elif not ca.aliased and abs(ca.celerity_m_s - cb.celerity_m_s) > tol.celerity * max(
                abs(ca.celerity_m_s), abs(cb.celerity_m_s)):
            why.append(f"{name} celerity {ca.celerity_m_s:+.1f} vs {cb.celerity_m_s:+.1f} m/s")
        if abs(ca.share - cb.share) > max(tol.share_rel * max(ca.share, cb.share),
                                          tol.share_abs):
            why.append(f"{name} share {100 * ca.share:.0f} vs {100 * cb.share:.0f} %")
    for zone in sorted(set(a.fractions) & set(b.fractions)):
        if abs(a.fractions[zone] - b.fractions[zone]) > tol.fraction:
            why.append(f"{zone} fraction {a.fractions[zone]:.3f} vs {b.fractions[zone]:.3f}")
    return why


def joint_tones(feature_sets: list[Features]) -> set[tuple[int, str]]:
    """The (k, direction) of the combination tones of the lattice of several feature sets
    together: each component at its largest share (and that window's frequency), the
    tolerance ``TONE_BINS`` bins of the coarsest resolution. One choice of generators
    for all, so a comparison does not depend on the order of its arguments, nor on a tone
    that outgrows a generator in one window only."""
    best: dict[tuple[int, str], Component] = {}
    for f in feature_sets:
        for c in f.components:
            if c.key not in best or c.share > best[c.key].share:
                best[c.key] = c
    resolutions = [f.resolution_hz for f in feature_sets if math.isfinite(f.resolution_hz)]
    tol = TONE_BINS * max(resolutions) if resolutions else math.nan
    joint = lattice_of(sorted(best.values(), key=lambda c: (-c.share, c.key)), tol)
    return {t.component.key for t in joint.tones}


def _attached_share(f: Features, key: tuple[int, str]) -> float | None:
    """The share of the peak (k, direction) where ``f`` has it attached to a component."""
    for c in f.components:
        for h in c.harmonics:
            if (h["k"], h.get("direction")) == key:
                return float(h["share"])
    return None


def match(a: Features, b: Features, tol: Tolerances = DEFAULT_TOLERANCES) -> bool:
    """True when ``a`` and ``b`` are the same state (module docstring)."""
    return not differences(a, b, tol)


def stationary(earlier: Features, later: Features, tol: Tolerances = DEFAULT_TOLERANCES,
               amplitude_tol: float = AMPLITUDE_TOL, spread_tol: float = SPREAD_TOL
               ) -> list[str]:
    """Why the features of two consecutive windows of one start differ ([] = stationary):
    ``differences``, the RMS amplitude within ``amplitude_tol`` (relative), and, where the
    later window is not a rigid wave (frame spread above ``spread_tol``), the frame spread
    (all that is not the dominant wave, weak companions included) within
    ``SPREAD_CHANGE_REL`` (relative, at least ``SPREAD_CHANGE_ABS``), unless the later window
    has combination tones (module docstring)."""
    why = differences(earlier, later, tol)
    ra, rb = earlier.rms_amplitude_m, later.rms_amplitude_m
    if math.isfinite(ra) and math.isfinite(rb) and abs(rb - ra) > amplitude_tol * max(ra, rb):
        why.append(f"RMS amplitude {ra:.3g} vs {rb:.3g} m")
    if later.lattice().tones:  # the spread holds the tones: not compared
        return why
    sa, sb = earlier.frame_spread, later.frame_spread
    if math.isfinite(sa) and math.isfinite(sb) and sb > spread_tol and abs(sb - sa) > max(
            SPREAD_CHANGE_REL * max(sa, sb), SPREAD_CHANGE_ABS):
        why.append(f"frame spread {sa:.3f} vs {sb:.3f}")
    return why


# ====================================================================== names


#: A component's direction in words: the only words printed for it.
SENSE = {"rotation": "with the rotation", "opposite": "against the rotation"}


def describe(comps: tuple[Component, ...] | list[Component], with_weak: bool = False) -> str:
    """"k = 12 against the rotation, with k = 13 (21 %) and k = 11 (20 %)": the listed
    components (``with_weak``: the weak ones too)."""
    listed = [c for c in comps if with_weak or not c.weak]
    if not listed:
        return "no travelling component"
    top = listed[0]
    text = f"k = {top.k} {SENSE[top.direction]}"
    if top.aliased:
        text += " (aliased)"
    rest = []
    for c in listed[1:]:  # an aliased component's direction is not known: not named
        sense = "" if c.direction == top.direction or c.aliased else f" {SENSE[c.direction]}"
        tag = ", aliased" if c.aliased else ""
        rest.append(f"k = {c.k}{sense} ({100 * c.share:.0f} %{tag})")
    if rest:
        text += ", with " + (rest[0] if len(rest) == 1 else
                             ", ".join(rest[:-1]) + " and " + rest[-1])
    return text


def member_key(comps: tuple[Component, ...] | list[Component], regime: str | None,
               with_weak: bool = False) -> str:
    """Short id of a state from its listed components (``with_weak``: the weak ones too):
    ``k12-opposite-SSS`` (rigid), ``k12-opposite-SSS+k13+k11`` (companions; ``k5r``/``k5o``
    where a companion travels the other way than the dominant)."""
    listed = [c for c in comps if with_weak or not c.weak]
    if not listed:
        return "none"
    top = listed[0]
    text = f"k{top.k}-{top.direction}-{REGIME_SHORT.get(regime, regime)}"
    for c in listed[1:]:
        text += f"+k{c.k}" + ("" if c.direction == top.direction else c.direction[0])
    return text


def components_text(comps: tuple[Component, ...] | list[Component]) -> str:
    """One CSV cell: ``k8+ 1.00 +1929.9; k9+ 0.25 +1768.0; k24- 0.05 aliased``."""
    parts = []
    for c in comps:
        sign = "+" if c.direction == "rotation" else "-"
        speed = "aliased" if c.aliased else f"{c.celerity_m_s:+.1f}"
        parts.append(f"k{c.k}{sign} {c.share:.2f} {speed}{' weak' if c.weak else ''}")
    return "; ".join(parts)
