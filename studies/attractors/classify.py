"""End states of a census's starts: classification, and grouping into members.

Each completed start is described by its features (``studies.attractors.features``: the
travelling components of the space-time spectrum, the zone fractions, the RMS amplitude)
over two consecutive windows of length W, [t_end − 2W, t_end − W] and [t_end − W, t_end]:
in a census W is a third of its first leg (``--end-time``), elsewhere the run's analysis
window (the last third). Its settle time (``features.settle_scan``) is the end of the first
window pair from which the features stayed stationary. Classes (``classify_features``):

* ``diverged`` / ``failed``: the run's own status (a blow-up; an error);
* ``steady-sliding``: no stick or separation zone above the analysis threshold;
* ``unsettled``: the features of the two windows differ (``features.stationary``: a
  component appears or vanishes, a celerity, share or zone fraction moves beyond its
  tolerance, or the RMS amplitude by more than 5 %), or a share still drifts across the
  last leg (``features.share_drift``: its linear trend over the leg's windows, extrapolated
  over the next leg, leaves the share tolerance);
* ``wave``: settled, one listed component (with its harmonics) and a frame spread at most
  ``SPREAD_TOL``: a rigidly travelling wave u(θ, t) = W(θ − ωt);
* ``multi-wave``: settled, several components each travelling at its own celerity (a
  torus, a relative periodic orbit): an attractor that is not one rigid wave; also one
  listed component whose weak companions (5 – 10 % each) together leave a frame spread
  above ``SPREAD_TOL`` (named with them).

Frame spread (``frame_spread``), a feature: over the analysis window, each sample of
(u_r, u_θ) on the contact circle is shifted back by ω(t − t_end) (exact Fourier shift, ω the
dominant component's angular speed) into its frame; the spread is the RMS deviation of the
shifted samples from their mean over the RMS of the mean, both components together,
axisymmetric part excluded. 0 for a rigid wave; about the companions' RMS share otherwise.

Members (``group_members``): the settled end states of one mesh are grouped by
``features.match`` (same listed components, celerities, shares and zone fractions within
their tolerances), transitively (single linkage, as a DBSCAN with one neighbour). A member's
id is its first start's ``features.member_key`` (``k12-opposite-SSS`` for a rigid wave,
``k12-opposite-SSS+k11+k13`` with companions; ``#2`` for a second group of the same id);
unsettled end states are grouped by (k, direction, regime) of the dominant component and
celerity (``unsettled-k12-opposite-SSS``), and so are the chaotic ones
(``chaotic-k3-opposite-SSS``: unsettled at the cap, with stationary statistics and λ₁ > 0,
``studies.attractors.chaos``). Rows from elsewhere that carry no features (a
summary and a frame spread only) are classified by the frame spread (``classify``).

Names a person reads (``readable_name``, ``member_label``, ``member_description``) and
member ids give the generators of the state's frequency lattice (``Features.named``,
``studies.attractors.lattice``), never a combination tone; a settled row's ``type`` is the
lattice's ("rigid wave", "relative periodic orbit", "torus"). They give every component's
direction in words, "with the rotation" or "against the rotation", and use those words for
nothing else: a dominant wave is "carrying" its companions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stickslip.studies.attractors.features import (
    CELERITY_TOL,
    DEFAULT_TOLERANCES,
    REGIME_SHORT,
    SENSE,
    SPREAD_TOL,
    Component,
    Features,
    Tolerances,
    _num,
    components_text,
    frame_spread,
    match,
    member_key,
    settle_verdict,
    stationary,
)

#: Relative decrease of the frame spread over the analysis window above which a cycle that is
#: not rigid is still settling, for rows without features.
DECAY_TOL = 0.05
#: The classes, in the order tables list them (``transient``: an end state at the cap whose
#: member failed a certificate, unstable in the direct solver or not returned after its
#: kick, set on its member after certification: ``census.answer_of``).
CLASSES = ("wave", "multi-wave", "chaotic", "transient", "unsettled", "steady-sliding",
           "diverged", "failed")
#: The classes of an attractor.
SETTLED = ("wave", "multi-wave")


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
    """The class of an end state known only by its summary and frame spread (a row computed
    elsewhere, without features): a settled cycle (the summary's limit-cycle test) is a
    ``wave`` at a frame spread ≤ ``spread_tol``, else a ``multi-wave`` unless its spread
    still decays by more than ``DECAY_TOL`` over the window (``trend``)."""
    early = _early_class(status, summary)
    if early:
        return early
    if not summary.get("limit_cycle"):
        return "unsettled"
    if spread <= spread_tol:
        return "wave"
    return "unsettled" if trend < -DECAY_TOL else "multi-wave"


def classify_features(status: str, summary: dict, earlier: Features | None,
                      later: Features | None, tol: Tolerances = DEFAULT_TOLERANCES,
                      spread: float = math.nan, spread_tol: float = SPREAD_TOL,
                      drift: tuple[str, ...] | list[str] = ()) -> tuple[str, list[str]]:
    """(class, why unsettled) of an end state from its features over two consecutive
    windows (``features.window_features`` of any two windows), its frame spread
    (default: the later window's own, ``Features.frame_spread``) and why its shares still
    drift across the last leg (``features.share_drift``); module docstring."""
    early = _early_class(status, summary)
    if early:
        return early, []
    if later is None or not later.listed:
        return "unsettled", ["no travelling component"]
    why = (stationary(earlier, later, tol, spread_tol=spread_tol) if earlier is not None
           else ["one window only"]) or list(drift)
    if why:
        return "unsettled", why
    spread = later.frame_spread if math.isnan(spread) else spread
    rigid = later.rigid and not spread > spread_tol
    return ("wave" if rigid else "multi-wave"), []


def _early_class(status: str, summary: dict) -> str:
    if status in ("diverged", "failed"):
        return status
    regime = summary.get("regime")
    if regime is None:  # completed without an analysis (too few samples)
        return "failed"
    return "steady-sliding" if regime == "steady-sliding" else ""


def start_row(run_dir: Path, params: dict, summary: dict | None, status: str,
              spread_tol: float = SPREAD_TOL, tol: Tolerances = DEFAULT_TOLERANCES,
              cached: dict | None = None, window: float | None = None) -> dict:
    """One start's row of ``attractors.csv`` from its run directory: where it started, what
    it reached, and when it settled. ``cached``: its features as an earlier row stored them
    (``row_cache``), so the samples are not read again. ``window``: the length W of the
    windows compared (default: the run's analysis window, the last third)."""
    s = summary or {}
    spread = (math.nan, math.nan, math.nan)
    features = None
    settle_time = math.nan
    drift: tuple[str, ...] = ()
    if status == "completed" and s.get("regime") not in (None, "steady-sliding"):
        if cached and cached.get("features"):
            features = (Features.from_dict(cached["features_before"]),
                        Features.from_dict(cached["features"]))
            spread = tuple(math.nan if v is None else float(v) for v in cached["spread"])
            settle_time = _num(cached.get("settle_time_s"))
            drift = tuple(cached.get("drift") or ())
        else:
            samples = _samples(run_dir)
            if samples is not None:
                features, spread, settle_time, drift = settled_features(
                    samples, s, _radius(run_dir), window, tol, spread_tol)
    return end_state_row(run_dir.name, params, s, status, spread, spread_tol,
                         run_dir=str(run_dir), features=features, tol=tol,
                         settle_time=settle_time, drift=drift)


def row_cache(row: dict) -> dict:
    """What ``start_row(cached=...)`` needs of a row to rebuild it without its samples."""
    return {"features": row.get("features"), "features_before": row.get("features_before"),
            "spread": [row.get("frame_spread"), row.get("rms_amplitude_m"),
                       row.get("spread_trend")], "settle_time_s": row.get("settle_time_s"),
            "drift": list(row.get("drift") or ())}


def settled_features(samples: dict, summary: dict, radius: float, window: float | None = None,
                     tol: Tolerances = DEFAULT_TOLERANCES, spread_tol: float = SPREAD_TOL
                     ) -> tuple[tuple[Features, Features], tuple[float, float, float], float,
                                tuple[str, ...]]:
    """(features of the two consecutive windows, (frame spread, RMS amplitude, spread
    trend) in the dominant component's frame) of a run's samples (``samples.npz``'s arrays,
    with the every-step probe where recorded): what ``end_state_row`` classifies; over
    windows of length ``window`` (default: the run's analysis window), the settle time and
    why the shares still drift across the last leg (``features.settle_verdict``; NaN, and
    the reasons: unsettled)."""
    t = samples["t"]
    if window is None:
        window = float(summary.get("analysis_window_s") or (t[-1] - t[0]) / 3.0)
    window = min(window, 0.5 * float(t[-1] - t[0]))
    v = settle_verdict(samples, radius, window, tol=tol, spread_tol=spread_tol)
    spread = spread_of_samples(t, samples["theta"], samples["u_r"], samples["u_theta"],
                               _with_dominant(summary, v.later), radius, window)
    return (v.earlier, v.later), spread, v.settle_time, v.drift


def _with_dominant(summary: dict, later: Features) -> dict:
    """The summary with the dominant component's celerity (the frame of the frame spread)."""
    top = later.dominant
    if top is None or top.aliased:
        return summary
    return {**summary, "celerity_m_s": top.celerity_m_s}


def end_state_row(start_id: str, params: dict, summary: dict, status: str,
                  spread: tuple[float, float, float], spread_tol: float = SPREAD_TOL,
                  run_dir: str = "", features: tuple[Features, Features] | None = None,
                  tol: Tolerances = DEFAULT_TOLERANCES, settle_time: float = math.nan,
                  drift: tuple[str, ...] = ()) -> dict:
    """One start's row from its run summary (``studies.rundir.scene_run.summarise``'s keys),
    its (frame spread, RMS amplitude, spread trend) and its features over two consecutive
    windows, wherever they were computed (a run directory, or a batch's records on another
    machine; without features the frame spread classifies it, ``classify``), and its settle
    time (``features.settle_scan``: the end of the first window pair from which its
    features stayed stationary; NaN where not settled) and why its shares still drift
    across the last leg (``features.share_drift``)."""
    s = summary
    frame, rms, trend = spread
    row = {
        "id": start_id, "n_inner": params.get("mesh.n_inner"),
        "start": params.get("initial.perturbation"), "seed": params.get("initial.seed"),
        "start_mode": params.get("initial.mode"), "status": status,
    }
    fr = s.get("fractions") or {}
    known = status in ("completed", "diverged", "failed")
    why: list[str] = []
    if features is not None and known:
        cls, why = classify_features(status, s, *features, tol, frame, spread_tol, drift)
    else:
        cls = classify(status, s, frame, spread_tol, trend) if known else status
    row.update({
        "class": cls, "k": s.get("mode"), "direction": s.get("direction"),
        "regime": s.get("regime"),
        "celerity_m_s": s.get("celerity_m_s"), "frequency_hz": s.get("frequency_hz"),
        "fraction_separation": fr.get("separation"), "fraction_stick": fr.get("stick"),
        "fraction_slip": fr.get("slip"), "psi1": s.get("psi1"), "psi2": s.get("psi2"),
        "amplitude_m": s.get("amplitude_m"), "rms_amplitude_m": rms,
        "limit_cycle": s.get("limit_cycle"), "frame_spread": frame, "spread_trend": trend,
        "settle_time_s": settle_time if cls in ("wave", "multi-wave") else math.nan,
        "sim_time_s": s.get("sim_time_s"),
        "dt_s": s.get("dt_s"), "steps": s.get("steps"), "wall_time_s": s.get("wall_time_s"),
        "message": s.get("message"), "run_dir": run_dir, "member": None,
        "components": "", "name": "", "n_components": None, "type": "",
        "unsettled_because": "; ".join(why),
        "features": None, "features_before": None, "drift": list(drift),
    })
    if features is not None and features[1].dominant is not None:
        earlier, later = features
        top = later.dominant
        lattice = later.lattice(cls != "multi-wave")
        named = lattice.generators
        row.update(k=top.k, direction=top.direction, n_components=len(named),
                   name=readable_name(named), type=lattice.type if cls in SETTLED else "",
                   components=components_text(later.components),
                   features=later.to_dict(), features_before=earlier.to_dict())
        if not top.aliased:
            row.update(celerity_m_s=top.celerity_m_s, frequency_hz=abs(top.frequency_hz))
    return row


def row_features(row: dict) -> Features:
    """The features of a row (its last window), or one component from its summary values
    where the row carries none."""
    if row.get("features"):
        return Features.from_dict(row["features"])
    fr = {z: row[f"fraction_{z}"] for z in ("separation", "stick", "slip")
          if row.get(f"fraction_{z}") is not None}
    c = row.get("celerity_m_s")
    comp = Component(k=int(row["k"]), direction=row["direction"], share=1.0,
                     amplitude_m=row.get("rms_amplitude_m") or math.nan,
                     frequency_hz=row.get("frequency_hz") or math.nan,
                     celerity_m_s=float(c) if c is not None else math.nan)
    return Features((comp,), fr)


def spread_of_samples(t: np.ndarray, theta: np.ndarray, u_r: np.ndarray, u_theta: np.ndarray,
                      summary: dict, radius: float, window: float | None = None
                      ) -> tuple[float, float, float]:
    """(frame spread, RMS amplitude, spread trend) over the last ``window`` (default: the
    summary's analysis window), in the frame turning at the summary's celerity."""
    omega = float(summary["celerity_m_s"]) / radius
    if window is None:
        window = float(summary.get("analysis_window_s") or (t[-1] - t[0]) / 3.0)
    spread, rms = frame_spread(t, theta, u_r, u_theta, omega, window)
    return spread, rms, spread_trend(t, theta, u_r, u_theta, omega, window)


SAMPLE_KEYS = ("t", "theta", "u_r", "u_theta", "status", "probe_t", "probe_data")


def _samples(run_dir: Path) -> dict | None:
    """The arrays of a run's samples.npz that the features need (None if unreadable)."""
    try:
        with np.load(run_dir / "samples.npz") as z:
            return {k: z[k] for k in SAMPLE_KEYS if k in z.files}
    except (OSError, KeyError, ValueError):
        return None


def _radius(run_dir: Path) -> float:
    import tomllib

    scene = tomllib.loads((run_dir / "scene.toml").read_text())
    return float(scene.get("geometry", {}).get("R", 1.0))


@dataclass(frozen=True)
class MemberKey:
    """How unsettled end states are grouped: (k, direction, regime), then celerity."""

    cls: str
    k: int | None = None
    direction: str | None = None
    regime: str | None = None

    def label(self) -> str:
        if self.k is None:
            return self.cls
        tag = "" if self.cls == "wave" else f"{self.cls}-"
        return f"{tag}k{self.k}-{self.direction}-{REGIME_SHORT.get(self.regime, self.regime)}"


def group_members(rows: list[dict], celerity_tol: float = CELERITY_TOL,
                  tol: Tolerances | None = None) -> None:
    """Give every classified row of one mesh its ``member`` id (in place; module docstring).

    Settled rows: connected groups under ``features.match`` (``tol``, or the defaults with
    ``celerity_tol``). Unsettled and chaotic rows with a wavenumber: (k, direction,
    regime), then celerity
    clusters (neighbours in sorted order within ``celerity_tol``); each also gets
    ``approaching``, the settled member its last window matches (None if none). Other
    classes: the class name.
    """
    tol = tol or Tolerances(celerity=celerity_tol)
    settled = sorted((r for r in rows if r["class"] in SETTLED),
                     key=lambda r: (r.get("seed") is None, r.get("seed") or 0, r["id"]
                                    if "id" in r else ""))
    feats = [row_features(r) for r in settled]
    group = list(range(len(settled)))  # union-find over the pairwise rule

    def root(i: int) -> int:
        while group[i] != i:
            group[i] = group[group[i]]
            i = group[i]
        return i

    for i in range(len(settled)):
        for j in range(i):
            if root(i) != root(j) and settled[i]["class"] == settled[j]["class"] \
                    and match(feats[i], feats[j], tol):
                group[root(i)] = root(j)
    used: dict[str, int] = {}
    names: dict[int, str] = {}
    for i, r in enumerate(settled):
        g = root(i)
        if g not in names:
            base = member_key(feats[g].named(settled[g]["class"] == "wave"),
                              settled[g]["regime"], with_weak=True)
            if settled[g]["class"] == "multi-wave" and not settled[g].get("features"):
                base = f"multi-wave-{base}"  # known by its frame spread only
            used[base] = used.get(base, 0) + 1
            names[g] = base + ("" if used[base] == 1 else f"#{used[base]}")
        r["member"] = names[g]
    firsts = {}
    for i, r in enumerate(settled):
        firsts.setdefault(r["member"], feats[i])
    keyed: dict[MemberKey, list[dict]] = {}
    for r in rows:
        if r["class"] == "unsettled" and r.get("features"):  # its last window already there?
            mine = row_features(r)
            r["approaching"] = next((m for m, f in firsts.items() if match(mine, f, tol)), None)
        if r["class"] in ("unsettled", "chaotic") and r["k"]:
            keyed.setdefault(MemberKey(r["class"], int(r["k"]), r["direction"], r["regime"]),
                             []).append(r)
        elif r["class"] not in SETTLED and r["class"] in CLASSES:
            r["member"] = r["class"]
    for key, grp in keyed.items():
        grp.sort(key=lambda r: abs(float(r["celerity_m_s"])))
        cluster, prev = 1, None
        for r in grp:
            c = abs(float(r["celerity_m_s"]))
            if prev is not None and c - prev > celerity_tol * max(prev, 1e-300):
                cluster += 1
            prev = c
            r["member"] = key.label() + ("" if cluster == 1 else f"#{cluster}")


#: A member's class as the printed answer and the plots say it.
CLASS_WORDS = {"wave": "rigid wave", "multi-wave": "multi-wave", "chaotic": "chaotic",
               "transient": "transient",
               "unsettled": "unsettled", "steady-sliding": "steady sliding",
               "diverged": "diverged", "failed": "failed", "settling": "settling"}


def component_words(k: int, direction: str | None) -> str:
    """"k = 14 against the rotation": a component's wavenumber and direction in words."""
    return f"k = {k} {SENSE.get(direction, direction)}" if direction else f"k = {k}"


def _and(parts: list[str]) -> str:
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def readable_name(comps: tuple[Component, ...] | list[Component]) -> str:
    """"k = 9 with the rotation, carrying k = 14 against the rotation (73 %) and k = 5
    against the rotation (16 %)": the named components (``Features.named``), dominant first,
    each with its direction in words and the companions with their shares (an aliased
    companion's direction is not known: "k = 24 (5 %, aliased)")."""
    if not comps:
        return "no travelling component"
    top, *rest = comps
    text = component_words(top.k, top.direction) + (" (aliased)" if top.aliased else "")
    parts = [f"k = {c.k} ({100 * c.share:.0f} %, aliased)" if c.aliased else
             f"{component_words(c.k, c.direction)} ({100 * c.share:.0f} %)" for c in rest]
    return text + (", carrying " + _and(parts) if parts else "")


def member_label(cls: str, member: str | None, comps: tuple[Component, ...] | list[Component]
                 ) -> str:
    """A member's short readable label (plots, the first word of its printed line): its
    class in words, the dominant component and, for a multi-wave member, the companions by
    direction without shares: "multi-wave k = 9 with the rotation carrying k = 14, 5 against
    the rotation"; "(group 2)" for a second group of the same id (``#2``)."""
    words = CLASS_WORDS.get(cls, cls)
    if not comps:
        return words
    top, *rest = comps
    text = f"{words} {component_words(top.k, top.direction)}"
    if cls == "multi-wave" and rest:
        by_sense: dict[str | None, list[str]] = {}
        for c in rest:
            by_sense.setdefault(None if c.aliased else c.direction, []).append(str(c.k))
        text += " carrying " + _and([
            f"k = {', '.join(ks)}" + (f" {SENSE.get(d, d)}" if d else " (aliased)")
            for d, ks in by_sense.items()])
    cluster = (member or "").partition("#")[2]
    return text + (f" (group {cluster})" if cluster else "")


def member_description(member: str) -> str:
    """``k11-opposite-SSS+k12+k5r`` -> "k = 11 against the rotation, stick-slip-separation,
    carrying k = 12 against the rotation and k = 5 with the rotation" (a companion's
    ``o``/``r``: it travels the other way than the dominant); the readable name with shares
    comes from the features (``readable_name``)."""
    prefix = next((p for p in ("unsettled-", "chaotic-", "multi-wave-")
                   if member.startswith(p)), "")
    body = member.removeprefix(prefix)
    if not body.startswith("k"):
        return member
    main, _, cluster = body.partition("#")
    head, *companions = main.split("+")
    parts = head.split("-", 2)
    regime = {v: k for k, v in REGIME_SHORT.items()}.get(parts[2], parts[2])
    text = f"{component_words(int(parts[0][1:]), parts[1])}, {regime}"
    if companions:  # "k6o": k = 6 against the rotation; "k6": the dominant's direction
        other = {"o": "opposite", "r": "rotation"}
        text += ", carrying " + _and([component_words(int(c[1:].rstrip("or")),
                                                      other.get(c[-1], parts[1]))
                                      for c in companions])
    if prefix:
        text = f"{prefix[:-1]} {text}"
    if cluster:
        text += f" (group {cluster})"
    return text
