"""End states of a census's starts: classification, and grouping into members.

Classes (``classify``), from a run's ``summary.json`` and samples:

* ``diverged`` / ``failed``: the run's own status (a blow-up; an error);
* ``steady-sliding``: no stick or separation zone above the analysis threshold;
* ``unsettled``: a wave that fails the limit-cycle test (stationary mode-k envelope and
  zone fractions over two consecutive blocks of three periods, ``postprocess.analysis``);
* ``wave``: a settled cycle whose frame spread is at most ``SPREAD_TOL``: a rigidly
  travelling wave u(θ, t) = W(θ − ωt);
* ``modulated``: a settled cycle with a larger frame spread that does not decay: the frame
  spread of the second half of the analysis window is not below the first half's by more
  than ``DECAY_TOL`` (relative); it is not one rigid wave;
* a larger frame spread that still decays is ``unsettled`` too: the modulation (side-bands
  of the dominant mode) is dying out more slowly than the run lasted, which the envelope
  test alone does not see.

Frame spread (``frame_spread``): over the analysis window, each sample of (u_r, u_θ) on the
contact circle is shifted back by ω(t − t_end) (exact Fourier shift, ω the measured angular
speed) into the wave's frame; the spread is the RMS deviation of the shifted samples from
their mean over the RMS of the mean, both components together, axisymmetric part excluded.
A rigid wave gives 0 up to sampling; measured 0.2 – 6 % for waves and 28 – 46 % for
modulated cycles at N = 66 – 264 (docs/travelling_waves.md), hence ``SPREAD_TOL`` = 10 %.
Both components enter one ratio (not the larger of two ratios): in a stick-slip wave u_r = d
on the whole circle, so u_r's non-axisymmetric part is round-off and its own ratio is noise
(a rigid k = 6 stick-slip wave of the smoke mesh: 0.07 together, 24.6 for u_r alone).

Members (``group_members``): waves (and, separately, modulated cycles) with the same
(k, direction, regime), whose celerities sorted in order differ by at most ``celerity_tol``
(relative) from their neighbour, form one member. A member's id reads, e.g.,
``k11-opposite-SSS`` (``#2`` … for a second celerity cluster of the same key); modulated and
unsettled end states are grouped the same way under ``modulated-…`` and ``unsettled-…``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Frame spread at or below which a settled cycle is a rigidly travelling wave.
SPREAD_TOL = 0.10
#: Relative decrease of the frame spread over the analysis window above which a cycle that is
#: not rigid is still settling (``unsettled``), not ``modulated``.
DECAY_TOL = 0.05
#: Relative celerity gap within which end states of one (k, direction, regime) are a member.
CELERITY_TOL = 0.02
#: The classes, in the order tables list them.
CLASSES = ("wave", "modulated", "unsettled", "steady-sliding", "diverged", "failed")
REGIME_SHORT = {"stick-slip-separation": "SSS", "stick-slip": "SS", "slip-separation": "SSep",
                "steady-sliding": "sliding"}


def frame_spread(t: np.ndarray, theta: np.ndarray, u_r: np.ndarray, u_theta: np.ndarray,
                 omega: float, window: float) -> tuple[float, float]:
    """(frame spread, RMS amplitude in m) over the last ``window`` s (module docstring).

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


def spread_trend(t: np.ndarray, theta: np.ndarray, u_r: np.ndarray, u_theta: np.ndarray,
                 omega: float, window: float) -> float:
    """Frame spread of the window's second half over its first half's, minus 1 (< 0: the
    modulation decays); NaN where either half cannot be measured."""
    first = t <= t[-1] - 0.5 * window
    early, _ = frame_spread(t[first], theta, u_r[first], u_theta[first], omega, 0.5 * window)
    late, _ = frame_spread(t, theta, u_r, u_theta, omega, 0.5 * window)
    return late / early - 1.0 if early > 0.0 and math.isfinite(early) else math.nan


def classify(status: str, summary: dict, spread: float, spread_tol: float = SPREAD_TOL,
             trend: float = math.nan) -> str:
    """The class of one end state (module docstring); ``status`` is the run's status,
    ``trend`` the relative change of the frame spread over the window (``spread_trend``)."""
    if status in ("diverged", "failed"):
        return status
    regime = summary.get("regime")
    if regime is None:  # completed without an analysis (too few samples)
        return "failed"
    if regime == "steady-sliding":
        return "steady-sliding"
    if not summary.get("limit_cycle"):
        return "unsettled"
    if spread <= spread_tol:
        return "wave"
    return "unsettled" if trend < -DECAY_TOL else "modulated"


def start_row(run_dir: Path, params: dict, summary: dict | None, status: str,
              spread_tol: float = SPREAD_TOL) -> dict:
    """One start's row of ``attractors.csv`` from its run directory: where it started, what
    it reached."""
    s = summary or {}
    spread = rms = trend = math.nan
    if status == "completed" and s.get("regime") not in (None, "steady-sliding"):
        spread, rms, trend = _spread_of_run(run_dir, s)
    return end_state_row(run_dir.name, params, s, status, (spread, rms, trend), spread_tol,
                         run_dir=str(run_dir))


def end_state_row(start_id: str, params: dict, summary: dict, status: str,
                  spread: tuple[float, float, float], spread_tol: float = SPREAD_TOL,
                  run_dir: str = "") -> dict:
    """One start's row from its run summary (``studies.rundir.scene_run.summarise``'s keys)
    and its (frame spread, RMS amplitude, spread trend), wherever they were computed (a run
    directory, or a batch's records on another machine)."""
    s = summary
    frame, rms, trend = spread
    row = {
        "id": start_id, "n_inner": params.get("mesh.n_inner"),
        "start": params.get("initial.perturbation"), "seed": params.get("initial.seed"),
        "start_mode": params.get("initial.mode"), "status": status,
    }
    fr = s.get("fractions") or {}
    row.update({
        "class": classify(status, s, frame, spread_tol, trend) if status in (
            "completed", "diverged", "failed") else status,
        "k": s.get("mode"), "direction": s.get("direction"), "regime": s.get("regime"),
        "celerity_m_s": s.get("celerity_m_s"), "frequency_hz": s.get("frequency_hz"),
        "fraction_separation": fr.get("separation"), "fraction_stick": fr.get("stick"),
        "fraction_slip": fr.get("slip"), "psi1": s.get("psi1"), "psi2": s.get("psi2"),
        "amplitude_m": s.get("amplitude_m"), "rms_amplitude_m": rms,
        "limit_cycle": s.get("limit_cycle"), "frame_spread": frame, "spread_trend": trend,
        "dt_s": s.get("dt_s"), "steps": s.get("steps"), "wall_time_s": s.get("wall_time_s"),
        "message": s.get("message"), "run_dir": run_dir, "member": None,
    })
    return row


def spread_of_samples(t: np.ndarray, theta: np.ndarray, u_r: np.ndarray, u_theta: np.ndarray,
                      summary: dict, radius: float) -> tuple[float, float, float]:
    """(frame spread, RMS amplitude, spread trend) over the summary's analysis window, in the
    frame turning at the summary's celerity."""
    omega = float(summary["celerity_m_s"]) / radius
    window = float(summary.get("analysis_window_s") or (t[-1] - t[0]) / 3.0)
    spread, rms = frame_spread(t, theta, u_r, u_theta, omega, window)
    return spread, rms, spread_trend(t, theta, u_r, u_theta, omega, window)


def _spread_of_run(run_dir: Path, summary: dict) -> tuple[float, float, float]:
    """(frame spread, RMS amplitude, spread trend) of a run over its analysis window."""
    try:
        with np.load(run_dir / "samples.npz") as z:
            t, theta, u_r, u_theta = z["t"], z["theta"], z["u_r"], z["u_theta"]
    except (OSError, KeyError, ValueError):
        return math.nan, math.nan, math.nan
    return spread_of_samples(t, theta, u_r, u_theta, summary, _radius(run_dir))


def _radius(run_dir: Path) -> float:
    import tomllib

    scene = tomllib.loads((run_dir / "scene.toml").read_text())
    return float(scene.get("geometry", {}).get("R", 1.0))


@dataclass(frozen=True)
class MemberKey:
    """What makes two end states the same attractor (up to the celerity clustering)."""

    cls: str
    k: int | None = None
    direction: str | None = None
    regime: str | None = None

    def label(self) -> str:
        if self.k is None:
            return self.cls
        tag = "" if self.cls == "wave" else f"{self.cls}-"
        return f"{tag}k{self.k}-{self.direction}-{REGIME_SHORT.get(self.regime, self.regime)}"


def group_members(rows: list[dict], celerity_tol: float = CELERITY_TOL) -> None:
    """Give every classified row of one mesh its ``member`` id (in place).

    Waves, modulated and unsettled cycles: by (k, direction, regime), then celerity clusters
    (neighbours in sorted order within ``celerity_tol`` relative). Other classes: the class
    name.
    """
    keyed: dict[MemberKey, list[dict]] = {}
    for r in rows:
        if r["class"] in ("wave", "modulated") or (r["class"] == "unsettled" and r["k"]):
            keyed.setdefault(MemberKey(r["class"], int(r["k"]), r["direction"], r["regime"]),
                             []).append(r)
        elif r["class"] in CLASSES:
            r["member"] = r["class"]
    for key, group in keyed.items():
        group.sort(key=lambda r: abs(float(r["celerity_m_s"])))
        cluster, prev = 1, None
        for r in group:
            c = abs(float(r["celerity_m_s"]))
            if prev is not None and c - prev > celerity_tol * max(prev, 1e-300):
                cluster += 1
            prev = c
            r["member"] = key.label() + ("" if cluster == 1 else f"#{cluster}")


def member_description(member: str) -> str:
    """``k11-opposite-SSS`` -> "k = 11 against the rotation, stick-slip-separation"."""
    prefix = next((p for p in ("modulated-", "unsettled-") if member.startswith(p)), "")
    if not member.removeprefix(prefix).startswith("k"):
        return member
    body = member.removeprefix(prefix)
    parts = body.split("#")[0].split("-", 2)
    sense = {"opposite": "against the rotation", "rotation": "with the rotation"}
    regime = {v: k for k, v in REGIME_SHORT.items()}.get(parts[2], parts[2])
    text = f"k = {parts[0][1:]} {sense.get(parts[1], parts[1])}, {regime}"
    if prefix:
        text = f"{prefix[:-1]} {text}"
    if "#" in member:
        text += f" (celerity cluster {member.split('#')[1]})"
    return text
