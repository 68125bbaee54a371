"""Wave analysis of sampled inner-circle fields: mode, celerity, frequency, zones, limit cycle.

Pure numpy on arrays (t, theta, u_r(t, theta), u_theta(t, theta), status(t, theta)), so it works
on a run directory's ``samples.npz`` as well as on synthetic travelling waves in tests.

Conventions (paper eq. [3]): a wave u(theta - c t) travels in the sense of rotation when its
angular speed c > 0. For mode k, the Fourier coefficient U_k(t) = sum_j u_j exp(-i k theta_j)
of u = A cos(k (theta - c t)) has phase -k c t, so c = -(d phase/dt) / k. Celerity in m/s is
c R (signed; the paper's c-bar = |c| R Omega with its non-dimensional c = c_here / Omega), the
frequency a fixed point sees is k |c| / (2 pi) Hz (the paper's "|c| k Omega" is this in rad/s).

Zones as the paper defines them (section 3, after Figure 1): over one period T = 2 pi / k of
the co-moving coordinate, separation [0, psi1 T], stick [psi1 T, psi2 T], slip [psi2 T, T],
in the order a material point meets them (time order). ``comoving_profile`` bins the status
map in the time-ordered co-moving coordinate s = -sign(c) (theta + phase_k(t) / k) mod T
(``semianalytic.waves`` uses the same s); ``zone_layout`` reads the cyclic zone sequence from
it. psi1 is the separation fraction and psi2 - psi1 the stick fraction *whatever the order*;
``WaveSummary.zone_order`` gives the measured order and ``paper_order`` says whether it is the
paper's separation -> stick -> slip (a different order is reported, never silently relabelled).
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from stickslip.solver.contact import SEPARATION, STICK, zone_fractions

ZONE_THRESHOLD = 0.005  # a zone counts as present above 0.5 % of node-samples
#: A pattern travels when its mode-k travel purity (``travel_purity``) is at least this: the
#: same bound as the CEA's doublet table (``studies.flutter_fe.shapes``), where a mode of
#: purity below 0.5 carries more standing than travelling content.
TRAVEL_PURITY_MIN = 0.5
ZONE_NAMES = ("separation", "stick", "slip")
PAPER_ORDER = ("separation", "stick", "slip")


@dataclass
class WaveSummary:
    """Wave measured on the inner circle over ``window_s`` (SI units, c > 0 = rotation sense)."""

    regime: str
    mode: int
    angular_speed_rad_s: float
    celerity_m_s: float
    frequency_hz: float
    fractions: dict
    amplitude_m: float
    limit_cycle: bool
    window_s: float
    psi1: float = 0.0
    psi2: float = 0.0
    zone_order: str = ""
    paper_order: bool = False
    amplitude_r_m: float = 0.0
    amplitude_theta_m: float = 0.0
    direction: str = "none"
    layout: list = field(default_factory=list)
    travel_purity: float = 1.0

    def to_dict(self) -> dict:
        return asdict(self)


def mode_coefficients(field: np.ndarray, theta: np.ndarray, kmax: int) -> np.ndarray:
    """Fourier coefficients U_k(t), k = 0..kmax, of ``field`` (samples x nodes) on angles theta.

    A direct sum over the node angles (works for non-uniform node spacing), normalised so that
    A cos(k theta + phi) has |U_k| = A.
    """
    k = np.arange(kmax + 1)
    basis = np.exp(-1j * np.outer(theta, k)) * (2.0 / theta.size)
    coeffs = np.atleast_2d(field) @ basis
    coeffs[:, 0] *= 0.5
    return coeffs


def dominant_mode(field: np.ndarray, theta: np.ndarray, kmax: int | None = None) -> int:
    """The wavenumber k >= 1 with the largest mean amplitude over the samples."""
    kmax = kmax or theta.size // 2
    amp = np.abs(mode_coefficients(field, theta, kmax)).mean(axis=0)
    return int(np.argmax(amp[1:]) + 1)


def mode_phase(field: np.ndarray, theta: np.ndarray, k: int) -> np.ndarray:
    """Unwrapped phase arg U_k(t) of mode k at each sample (radians)."""
    return np.unwrap(np.angle(mode_coefficients(field, theta, k)[:, k]))


def angular_speed(t: np.ndarray, field: np.ndarray, theta: np.ndarray, k: int,
                  frequency_hz: float | None = None) -> float:
    """Signed angular phase speed c (rad/s) of mode k, from a line fit of the unwrapped phase.

    The phase of U_k advances by -k c dt_s per sample. If the wave is under-sampled in time
    (|k c dt_s| > pi), ``frequency_hz`` (e.g. from an every-step probe, ``probe_frequency``)
    fixes the aliasing: the per-sample increment is taken as the signed multiple of
    2 pi f dt_s closest to the measured one.
    """
    if t.size < 2:
        return 0.0
    coeff = mode_coefficients(field, theta, k)[:, k]
    if frequency_hz is None or t.size < 3:
        # Amplitude-weighted mean of the wrapped per-sample phase increments. Equal to the
        # slope of the unwrapped phase for a clean wave, but where |U_k| passes near zero
        # (transients, mode competition) the ill-defined increments get ~no weight, so
        # round-off cannot flip an unwrap by 2 pi and change the result.
        prod = coeff[1:] * np.conj(coeff[:-1])
        weight = np.abs(prod)
        if weight.sum() == 0.0:
            return 0.0
        slope = float(np.sum(weight * np.angle(prod)) / np.sum(weight * np.diff(t)))
        return float(-slope / k)
    dts = float(np.mean(np.diff(t)))
    inc = np.angle(coeff[1:] * np.conj(coeff[:-1]))  # wrapped increments
    true = 2.0 * np.pi * frequency_hz * dts
    # the sign whose aliased increment matches the measured mean increment best
    best = min((1.0, -1.0), key=lambda sg: abs(np.angle(np.exp(1j * (inc.mean() - sg * true)))))
    residual = np.angle(np.exp(1j * (inc - best * true)))
    slope = (best * true + residual.mean()) / dts
    return float(-slope / k)


def travel_purity(field: np.ndarray, theta: np.ndarray, k: int) -> tuple[float, float]:
    """How much mode k travels, and the frequency (Hz) a fixed point sees.

    U_k(t) = A₊ e^{-iωt} + A₋ e^{+iωt} + ... : a wave cos(k θ − ω t) travelling with the
    rotation puts all of |U_k|'s spectral energy at negative frequencies, one against it at
    positive ones, and a standing (pinned) pattern cos(k θ) cos(ω t) half at each. The purity
    |E₋ − E₊| / (E₋ + E₊) is 1 for a travelling wave and 0 for a standing one; the frequency
    is the peak of the two-sided spectrum (the samples' own, so alias-prone as they are).
    """
    coeff = mode_coefficients(field, theta, k)[:, k]
    n = coeff.size
    if n < 8:
        return 1.0, 0.0
    spec = np.abs(np.fft.fft((coeff - coeff.mean()) * np.hanning(n))) ** 2
    freq = np.fft.fftfreq(n)
    e_neg, e_pos = float(spec[freq < 0].sum()), float(spec[freq > 0].sum())
    if e_neg + e_pos == 0.0:
        return 1.0, 0.0
    i = int(np.argmax(spec))
    return abs(e_neg - e_pos) / (e_neg + e_pos), abs(float(freq[i]))


def probe_frequency(t: np.ndarray, signal: np.ndarray) -> float:
    """Dominant frequency (Hz) of an every-step time history (FFT peak, parabolic refinement)."""
    x = signal - signal.mean()
    n = x.size
    if n < 8:
        return 0.0
    spec = np.abs(np.fft.rfft(x * np.hanning(n)))
    spec[0] = 0.0
    i = int(np.argmax(spec))
    dtp = float(np.mean(np.diff(t)))
    if 0 < i < spec.size - 1:
        a, b, c = spec[i - 1], spec[i], spec[i + 1]
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den != 0 else 0.0
    else:
        shift = 0.0
    return float((i + shift) / (n * dtp))


def classify(fractions: dict[str, float], threshold: float = ZONE_THRESHOLD) -> str:
    """Regime name from zone fractions (slip is always present while the cylinder drives)."""
    sep = fractions["separation"] > threshold
    stick = fractions["stick"] > threshold
    if sep and stick:
        return "stick-slip-separation"
    if sep:
        return "slip-separation"
    if stick:
        return "stick-slip"
    return "steady-sliding"


def comoving_coordinate(theta: np.ndarray, phase: np.ndarray, k: int, c: float) -> np.ndarray:
    """Time-ordered co-moving coordinate s in [0, T), T = 2 pi / k (eq. [3]), per sample/node.

    phi = theta + phase_k(t) / k equals theta - c t up to a constant; s = -sign(c) phi, so
    that s grows in time at a material point, as in ``semianalytic.waves`` (for c < 0, s = phi:
    the paper's layout).
    """
    T = 2.0 * np.pi / k
    phi = theta[None, :] + phase[:, None] / k
    sigma = -1.0 if c > 0 else 1.0
    return np.mod(sigma * phi, T)


def comoving_profile(s: np.ndarray, fields: dict[str, np.ndarray], status: np.ndarray,
                     k: int, nbins: int = 200) -> dict[str, np.ndarray]:
    """Bin fields and status fractions over one period of the co-moving coordinate s.

    Returns ``s`` (bin centres, rad), ``count``, the bin means of every entry of ``fields``
    and ``frac_separation``, ``frac_stick``, ``frac_slip`` (share of node-samples per bin).
    Empty bins are filled by periodic linear interpolation.
    """
    T = 2.0 * np.pi / k
    idx = np.minimum((s.ravel() / T * nbins).astype(np.int64), nbins - 1)
    count = np.bincount(idx, minlength=nbins).astype(float)
    out: dict[str, np.ndarray] = {"s": (np.arange(nbins) + 0.5) * T / nbins, "count": count}
    safe = np.maximum(count, 1.0)
    have = count > 0
    for name, arr in fields.items():
        out[name] = _fill(np.bincount(idx, weights=arr.ravel(), minlength=nbins) / safe, have)
    st = status.ravel()
    for code, name in enumerate(ZONE_NAMES):
        w = (st == code).astype(float)
        out[f"frac_{name}"] = _fill(np.bincount(idx, weights=w, minlength=nbins) / safe, have)
    return out


def _fill(values: np.ndarray, have: np.ndarray) -> np.ndarray:
    if have.all() or not have.any():
        return values
    x = np.arange(values.size)
    return np.interp(x, x[have], values[have], period=values.size)


def zone_layout(profile: dict[str, np.ndarray],
                min_bins: int = 2) -> list[tuple[str, float, float]]:
    """Cyclic zone sequence over one period: [(zone, start/T, end/T), ...] in time order.

    Each bin takes its majority status; runs shorter than ``min_bins`` bins (status noise at a
    moving boundary) are merged into their predecessor. The list starts at the beginning of a
    separation zone when there is one (else of a stick zone), as in the paper's layout.
    """
    fr = np.vstack([profile[f"frac_{n}"] for n in ZONE_NAMES])
    lab = np.argmax(fr, axis=0)
    nb = lab.size
    runs = _runs(lab)
    changed = True
    while changed and len(runs) > 1:
        changed = False
        for i, (_code, _start, length) in enumerate(runs):
            if length < min_bins:
                prev = runs[i - 1]
                runs[i - 1] = (prev[0], prev[1], prev[2] + length)
                del runs[i]
                runs = _merge_equal(runs)
                changed = True
                break
    first = next((i for i, r in enumerate(runs) if r[0] == SEPARATION),
                 next((i for i, r in enumerate(runs) if r[0] == STICK), 0))
    runs = runs[first:] + runs[:first]
    origin = runs[0][1]
    out = []
    for code, start, length in runs:
        a = ((start - origin) % nb) / nb
        out.append((ZONE_NAMES[code], a, a + length / nb))
    return out


def _runs(lab: np.ndarray) -> list[tuple[int, int, int]]:
    """Cyclic run-length encoding (code, start, length), first run starting at a change."""
    nb = lab.size
    change = np.flatnonzero(lab != np.roll(lab, 1))
    if change.size == 0:
        return [(int(lab[0]), 0, nb)]
    starts = list(change)
    runs = []
    for i, a in enumerate(starts):
        b = starts[(i + 1) % len(starts)]
        runs.append((int(lab[a]), int(a), int((b - a) % nb) or nb))
    return runs


def _merge_equal(runs: list[tuple[int, int, int]]) -> list[tuple[int, int, int]]:
    out: list[tuple[int, int, int]] = []
    for r in runs:
        if out and out[-1][0] == r[0]:
            out[-1] = (r[0], out[-1][1], out[-1][2] + r[2])
        else:
            out.append(r)
    if len(out) > 1 and out[0][0] == out[-1][0]:
        last = out.pop()
        out[0] = (last[0], last[1], last[2] + out[0][2])
    return out


def psi_from_profile(profile: dict[str, np.ndarray]) -> tuple[float, float]:
    """(psi1, psi2) = (separation fraction, separation + stick fraction) over one period."""
    sep = float(np.mean(profile["frac_separation"]))
    stick = float(np.mean(profile["frac_stick"]))
    return sep, sep + stick


def order_string(layout: list[tuple[str, float, float]]) -> str:
    return "->".join(z for z, _, _ in layout)


def is_paper_order(layout: list[tuple[str, float, float]]) -> bool:
    """True for separation -> stick -> slip (or stick -> slip for a stick-slip wave)."""
    names = tuple(z for z, _, _ in layout)
    return names in (PAPER_ORDER, ("stick", "slip"))


def analyse(
    t: np.ndarray,
    theta: np.ndarray,
    u_r: np.ndarray,
    u_theta: np.ndarray,
    status: np.ndarray,
    *,
    d: float,
    radius: float,
    window: float | None = None,
    frequency_hint_hz: float | None = None,
    nbins: int = 200,
) -> WaveSummary:
    """Analyse the last ``window`` seconds (default: last third of the record).

    The mode and phase come from u_r - d when the tube separates, else from u_theta minus its
    mean (paper section 3: a stick-slip wave has U = delta). ``frequency_hint_hz`` resolves
    temporal aliasing of the sampled phase (``angular_speed``).
    """
    if t.size == 0:
        raise ValueError("no samples to analyse")
    span = t[-1] - t[0]
    window = span / 3.0 if window is None else min(window, span)
    sel = t >= t[-1] - window
    tw, ur, ut, st = t[sel], u_r[sel], u_theta[sel], status[sel]
    fractions = zone_fractions(st)
    regime = classify(fractions)
    separated = fractions["separation"] > ZONE_THRESHOLD
    amp_r = float(max(0.0, np.max(ur - d)))
    amp_t = float(0.5 * (ut.max(axis=0) - ut.min(axis=0)).mean())
    signal = ur - d if separated else ut - ut.mean()
    amplitude = amp_r if separated else amp_t
    k = dominant_mode(signal, theta)
    c = (angular_speed(tw, signal, theta, k, frequency_hint_hz)
         if regime != "steady-sliding" else 0.0)
    purity, f_index = travel_purity(signal, theta, k)
    standing = regime != "steady-sliding" and purity < TRAVEL_PURITY_MIN
    frequency = abs(c) * k / (2.0 * np.pi)
    if standing:  # a pattern that does not travel: its frequency, and no celerity
        dts = float(np.mean(np.diff(tw))) if tw.size > 1 else 0.0
        frequency = frequency_hint_hz or (f_index / dts if dts > 0 else 0.0)
        c = 0.0
    limit = _limit_cycle(t, u_r - d if separated else u_theta - u_theta.mean(),
                         theta, status, k, c)
    psi1, psi2, layout = 0.0, fractions["stick"], []
    if c != 0.0:
        phase = mode_phase(signal, theta, k)
        s = comoving_coordinate(theta, phase, k, c)
        prof = comoving_profile(s, {}, st, k, nbins)
        psi1, psi2 = psi_from_profile(prof)
        layout = zone_layout(prof)
    return WaveSummary(
        regime=regime,
        mode=k,
        angular_speed_rad_s=c,
        celerity_m_s=c * radius,
        frequency_hz=frequency,
        fractions=fractions,
        amplitude_m=amplitude,
        limit_cycle=limit,
        window_s=float(window),
        psi1=psi1,
        psi2=psi2,
        zone_order=order_string(layout),
        paper_order=is_paper_order(layout),
        amplitude_r_m=amp_r,
        amplitude_theta_m=amp_t,
        direction=("standing" if standing else
                   "rotation" if c > 0 else ("opposite" if c < 0 else "none")),
        layout=[[z, round(a, 5), round(b, 5)] for z, a, b in layout],
        travel_purity=purity,
    )


def _limit_cycle(t, signal, theta, status, k, c, periods: int = 3, tol: float = 0.05) -> bool:
    """Stationary mode-k envelope and zone fractions over two consecutive blocks of periods."""
    if c == 0.0 or t.size < 8:
        return False
    period = 2.0 * np.pi / (k * abs(c))
    block = periods * period
    if t[-1] - t[0] < 2 * block:
        return False
    late = t >= t[-1] - block
    early = (t >= t[-1] - 2 * block) & ~late
    amp = np.abs(mode_coefficients(signal, theta, k)[:, k])
    a_late, a_early = amp[late].mean(), amp[early].mean()
    if a_late <= 0 or abs(a_late - a_early) > tol * a_late:
        return False
    f_late, f_early = zone_fractions(status[late]), zone_fractions(status[early])
    return all(abs(f_late[z] - f_early[z]) < 0.02 for z in f_late)


# ---------------------------------------------------------------------------------------------
# Run directories


@dataclass
class RunData:
    """A run directory's samples and scene parameters (SI units)."""

    path: Path
    scene: dict
    summary: dict
    samples: dict

    @property
    def d(self) -> float:
        g = self.scene["geometry"]
        return float(g["delta"]) * float(g["R"])

    @property
    def radius(self) -> float:
        return float(self.scene["geometry"]["R"])


def load_run(run_dir: Path | str) -> RunData:
    """Read ``scene.toml``, ``summary.json`` and ``samples.npz`` of a run directory."""
    run_dir = Path(run_dir)
    with np.load(run_dir / "samples.npz") as npz:
        samples = {key: npz[key] for key in npz.files}
    scene = tomllib.loads((run_dir / "scene.toml").read_text())
    summary = json.loads((run_dir / "summary.json").read_text())
    return RunData(run_dir, scene, summary, samples)


def analyse_run(run: RunData | Path | str, window: float | None = None,
                nbins: int = 200) -> WaveSummary:
    """``analyse`` on a run directory.

    The every-step probe history gives the frequency a fixed point sees; it is passed as the
    aliasing hint of ``angular_speed`` only when it is close to or above the Nyquist frequency
    of the inner-circle samples (elsewhere the sampled phase is unambiguous and the probe
    spectrum of a nearly still coordinate is noise).
    """
    run = run if isinstance(run, RunData) else load_run(run)
    s = run.samples
    if window is None:
        window = run.summary.get("analysis_window_s")
    hint = None
    t = s["t"]
    if "probe_data" in s and s["probe_data"].shape[0] > 0 and s["probe_t"].size > 16 \
            and t.size > 2:
        pt = s["probe_t"]
        span = pt[-1] - pt[0]
        w = span / 3.0 if window is None else min(window, span)
        sel = pt >= pt[-1] - w
        tsel = t >= t[-1] - w
        separated = zone_fractions(s["status"][tsel])["separation"] > ZONE_THRESHOLD
        # the probe's u_r (separation) or u_theta (stick-slip: u_r = d there)
        f_probe = probe_frequency(pt[sel], s["probe_data"][0, sel, 0 if separated else 1])
        nyquist = 0.5 / float(np.mean(np.diff(t)))
        if f_probe > 0.45 * nyquist:  # only where the sampled phase may be aliased
            hint = f_probe
    return analyse(s["t"], s["theta"], s["u_r"], s["u_theta"], s["status"], d=run.d,
                   radius=run.radius, window=window, frequency_hint_hz=hint, nbins=nbins)


def run_profile(run: RunData, wave: WaveSummary, nbins: int = 200) -> dict[str, np.ndarray]:
    """Co-moving profile (one period, time order s) of u_r - d, u_theta, velocities, zones.

    Also the contact pressures p, q (Pa) when the samples carry nodal forces ``r_r``,
    ``r_theta`` (N/m) and the node arc-length weights ``ds`` (m).
    """
    s_ = run.samples
    t = s_["t"]
    sel = t >= t[-1] - wave.window_s
    ur = s_["u_r"][sel] - run.d
    ut = s_["u_theta"][sel]
    signal = ur if wave.regime in ("stick-slip-separation", "slip-separation") \
        else ut - ut.mean()
    phase = mode_phase(signal, s_["theta"], wave.mode)
    s = comoving_coordinate(s_["theta"], phase, wave.mode, wave.angular_speed_rad_s)
    fields = {"u_r": ur, "u_theta": ut - ut.mean(), "v_r": s_["v_r"][sel],
              "v_theta": s_["v_theta"][sel]}
    if "r_r" in s_ and "ds" in s_:
        fields["p"] = s_["r_r"][sel] / s_["ds"][None, :]
        fields["q"] = s_["r_theta"][sel] / s_["ds"][None, :]
    prof = comoving_profile(s, fields, s_["status"][sel], wave.mode, nbins)
    if wave.zone_order:  # rotate so the first zone of the layout starts at s = 0
        origin = _layout_origin(prof, wave)
        shift = int(round(origin * nbins))
        for key, arr in prof.items():
            if key != "s":
                prof[key] = np.roll(arr, -shift)
    return prof


def _layout_origin(prof: dict[str, np.ndarray], wave: WaveSummary) -> float:
    fr = np.vstack([prof[f"frac_{n}"] for n in ZONE_NAMES])
    lab = np.argmax(fr, axis=0)
    first = ZONE_NAMES.index(wave.layout[0][0]) if wave.layout else SEPARATION
    runs = [r for r in _runs(lab) if r[0] == first]
    if not runs:
        return 0.0
    longest = max(runs, key=lambda r: r[2])
    return longest[1] / lab.size


def phase_diagram(run: RunData, window: float | None = None,
                  probe: int = 0) -> dict[str, np.ndarray | float]:
    """(u_r - d, du_r/dt) and (u_theta, du_theta/dt) at a contact point (paper Figures 4-6).

    Uses the every-step probe history when present (else the nearest sampled node at the
    first probe angle), over the last ``window`` seconds.
    """
    s = run.samples
    if window is None:
        window = run.summary.get("analysis_window_s") or (s["t"][-1] - s["t"][0]) / 3.0
    if "probe_data" in s and s["probe_data"].shape[0] > probe and s["probe_t"].size > 1:
        pt = s["probe_t"]
        sel = pt >= pt[-1] - window
        pd = s["probe_data"][probe, sel]
        return {"t": pt[sel], "u_r": pd[:, 0] - run.d, "v_r": pd[:, 2], "u_theta": pd[:, 1],
                "v_theta": pd[:, 3], "theta_deg": float(s["probe_deg"][probe])}
    probes = run.scene.get("output", {}).get("probes_deg", [0.0])
    deg = np.degrees(s["theta"])
    j = int(np.argmin(np.abs(((deg - probes[min(probe, len(probes) - 1)] + 180.0) % 360.0)
                             - 180.0)))
    t = s["t"]
    sel = t >= t[-1] - window
    return {"t": t[sel], "u_r": s["u_r"][sel, j] - run.d, "v_r": s["v_r"][sel, j],
            "u_theta": s["u_theta"][sel, j], "v_theta": s["v_theta"][sel, j],
            "theta_deg": float(deg[j])}
