"""Certificates of a census's members: what each kind of attractor can cheaply prove.

``certify_member(rows)`` gives every settled member (its rows, first start first):
* **reproducibility**: how many starts reach it; they agree by construction to the grouping
  tolerances (``features.match``), and the largest spread of their dominant celerity and of
  every listed share is stated; reproduced when at least two starts reach it;
* **persistence**: the largest change of the dominant celerity and of the listed shares
  between the two consecutive windows of each start (every row of a member is stationary by
  its class; the numbers say by how much);
* a member of two generators, the second moving in the first one's frame, gets an **RPO
  screen**
  (``studies.rpo.rpo_screen``, no Newton): its half-node commutation defect and its
  residuals over T and 2T at the generators' guess; a defect well above round-off makes it a
  torus of the scheme's map, not an exact RPO (docs/theory/rpo.md); and a **sideband
  test** (``sideband_test``, from the starts' own samples): the growth rate σ of the second
  generator's amplitude over each start's last leg. A sideband that decays
  (σ < −``SIDEBAND_RATE_TOL``) belongs to a slow transient onto the rigid wave of the first
  (a stable wave whose least-damped complex pair is close to a Hopf bifurcation), one that
  grows to a state leaving it: either is no attractor (``failures``); a torus holds it;
* a **rigid wave** (one component) is also handed to the direct solver (``certify`` below):
  one Newton solve at the run's step, and its stability; an unstable one is no attractor
  (``failures``, ``census.answer_of``). The Δt → 0 ladder runs only with ``dt_limit``
  (``--dt-limit``).
* a **kick test** (``kick_members``, every member, rigid or not, unless ``--no-kick``): one
  start of the member (the first whose checkpoint is a batch member's) is perturbed where it
  stands, at t_k, by ``KICK_FRACTION`` (1 %) of its RMS displacement and velocity, each
  along a random start's smooth radial bump (``BatchColumns.kick``: the perturbation
  a start gets, clamped outside, spread through the thickness by eq. [1]), and run on for
  ``KICK_WINDOWS`` census windows W into ``DIR/kicks/``; its last window [t_k + W, t_k + 2W]
  must ``match`` (``features.differences``) the start's own last window before the kick;
  one that does not is no attractor (``failures``).
  All members' kicks continue as one batch per mesh and checkpoint step
  (``studies.rundir.continue_batch``), so they cost 2W per member in a batch.

Certification by the direct travelling-wave solver, through one adapter:
``certify(run_dir)`` hands one of the member's runs to ``studies.travel.wave_from_run`` with
``dt_limit=True``: the transient's own discrete wave at the run's step (its residual, its
celerity and the relative difference to the transient's) and the wave as Δt → 0 at that mesh
(with the run's own Δt error), and its **stability at the run's own step**: the largest
Lyapunov exponent λ₁ of the start where its checkpoint stands (``chaos.fe_lyapunov``: the
chaos test's twin, 10⁻⁸ away, renormalised every W/20 over ``STABILITY_WINDOWS`` census
windows W); the wave is unstable when λ₁ > ``GROWTH_TOL`` = 1 1/s beyond 3 standard errors
(a stable wave has λ₁ ≤ 0: its translation is neutral, its other directions decay; measured
−4 to +0.1 1/s over 2W on the tutorial's rigid members). Two other tests were found wanting:
* a 0.05 s transient started next to the travel solver's wave (kept for a one-scene run,
  which has no twin; ``stability_test`` says which judged) runs at the matched step
  h = τ/S, not at Δt, and is short;
* the Floquet multipliers of the wave as an orbit at a held whole-node shift
  (``stickslip rpo --nodes``) are those of the orbit locked to p steps per M node passages
  at h = Mτ/p. With few steps per passage they hang on that ratio, not on the physics: the
  tutorial's N = 132 rigid k = 8 wave (0.94 steps per passage) grows at +9.5, +90 and
  +21 1/s at h/Δt = 0.971, 0.995 and 1.021 (another guess of T finds another locked orbit
  with other multipliers), while its census starts hold it for seconds and λ₁ at Δt is
  −0.1 ± 0.8 1/s (docs/howto/rpo.md).
Where the finer levels of the Δt → 0 wave
have no wave (the free-ω Newton stagnates with an inequality violated), the wave at the run's
step still stands and ``dt_to_0`` says why its limit is unknown. A run that is not a rigid
wave (``NotRigidWave``) or a solver failure is reported, never raised.
"""

from __future__ import annotations

import math
from pathlib import Path

import stickslip.studies.attractors.chaos as chaos
from stickslip.studies import travel
from stickslip.studies.attractors.classify import _radius, _samples
from stickslip.studies.attractors.features import (
    DEFAULT_TOLERANCES,
    LEG_GROWTH,
    Features,
    components_text,
    differences,
    window_features,
)
from stickslip.studies.attractors.step_check import at_checkpoint, half_step_line
from stickslip.studies.rpo.birth import sideband_fit
from stickslip.studies.rpo.certificate import rpo_screen
from stickslip.studies.rundir import continue_batch
from stickslip.studies.rundir.readers import ReadError

UNAVAILABLE = "certification unavailable"


def certify(run_dir: Path, *, stability: bool = True, stability_end_time: float = 0.05,
            dt_limit: bool = False, window: float | None = None) -> dict:
    """The member's certificate from one of its runs (module docstring); never raises.
    ``dt_limit = False`` leaves the Δt → 0 wave out (its finest level, 4S points per node, is
    a dense Newton system whose cost grows as the cube). ``window``: the end state's window
    (s; default the run's analysis window), e.g. a census's W for a start it extended."""
    out: dict = {"available": True, "run": str(run_dir)}
    try:  # one solve: the wave at the run's step, and from it the Δt → 0 wave
        wave = travel.wave_from_run(run_dir, dt_limit=dt_limit, window=window)
    except Exception as err:  # NotRigidWave or a solver failure: a fact of the member
        out["at_dt"] = {"converged": False, "message": f"{type(err).__name__}: {err}"}
        return out
    out["at_dt"] = {key: _plain(wave.get(key)) for key in (
        "converged", "message", "residual", "k", "direction", "regime", "celerity_m_s",
        "frequency_hz", "psi1", "psi2", "amplitude_m", "frame_spread", "samples",
        "difference", "run")}
    if wave.get("dt_limit") is not None:
        out["dt_to_0"] = _plain({k: v for k, v in wave["dt_limit"].items() if k != "levels"})
    else:  # no wave at 2S or 4S, or not asked for: the Δt → 0 value is not known
        out["dt_to_0"] = {"message": wave.get("dt_limit_message") or (
            "no Δt → 0 wave from this run" if dt_limit else "not computed (dt_limit = False)")}
    if stability and wave.get("converged"):
        out.update(_stability(run_dir, wave, stability_end_time, window))
    return out


#: the λ₁ test of a rigid wave: the twin runs this many census windows W, renormalised
#: every W/20 (the chaos test's τ)
STABILITY_WINDOWS = 2
#: W where a caller gives none (s): the census's default window
DEFAULT_WINDOW = 0.1
#: a wave is unstable when λ₁ exceeds this (1/s) by more than 3 standard errors: a slower
#: growth needs ln(10³)/λ₁ > 7 s to take a 10⁻³ perturbation to the state's size, longer
#: than a census's cap
GROWTH_TOL = 1.0


def _stability(run_dir: Path, wave: dict, end_time: float, window: float | None) -> dict:
    """The rigid wave's stability at the run's own step (module docstring): λ₁ of the
    start where its checkpoint stands (``chaos.fe_lyapunov``, the twin of the chaos test),
    unstable when λ₁ > ``GROWTH_TOL`` beyond 3 standard errors. A run with no twin (the
    implicit scheme's, ``chaos.NoTwin``) gets the transient started next to the wave
    (``travel.wave_stability``); ``stability_test`` says which judged. Never raises."""
    W = float(window or DEFAULT_WINDOW)
    try:
        lyap = chaos.fe_lyapunov(run_dir, STABILITY_WINDOWS * W, W / 20.0)
    except chaos.NoTwin:
        out = {"stability_test": "transient"}
        try:
            st = travel.wave_stability(run_dir, end_time=end_time, window=window)
        except Exception as err:  # reported, the census goes on
            return {**out, "stable": None, "stability_message": f"{type(err).__name__}: {err}"}
        out.update(stable=bool(st.get("stable")), drift=_plain(st.get("drift")))
        if st.get("samples") is not None and st["samples"] != wave.get("samples"):
            out["stability_samples"] = int(st["samples"])  # S' = ceil(τ/Δt)
        return out
    except Exception as err:  # a failed twin: reported, the census goes on
        return {"stability_test": "lyapunov", "stable": None,
                "stability_message": f"{type(err).__name__}: {err}"}
    growing = lyap.exponent - chaos.ERROR_SIGMAS * lyap.error > GROWTH_TOL
    return {"stability_test": "lyapunov", "stable": not growing,
            "lyapunov": _plain(lyap.to_dict())}


def certify_member(rows: list[dict], *, dt_limit: bool = False,
                   window: float | None = None) -> dict:
    """The certificate of one settled member from its rows (module docstring), its features
    read over the last ``window`` seconds (the census's W); never raises."""

    out: dict = {"starts": len(rows), "reproduced": len(rows) >= 2,
                 "rigid": rows[0]["class"] == "wave"}
    later = [Features.from_dict(r["features"]) for r in rows if r.get("features")]
    earlier = [Features.from_dict(r["features_before"]) for r in rows
               if r.get("features_before")]
    if later:
        out["spread_between_starts"] = _spread(later)
    if earlier and len(earlier) == len(later):
        out["change_between_windows"] = max(
            (_spread([a, b]) for a, b in zip(earlier, later, strict=True)),
            key=lambda d: (d["celerity_rel"], d["share"]))
    if out["rigid"]:
        out["direct"] = certify(Path(rows[0]["run_dir"]), dt_limit=dt_limit, window=window)
        out["stable"] = out["direct"].get("stable")
    elif later:  # two generators that move against each other: an RPO or a torus
        lattice = later[0].lattice(False)
        if len(lattice.generators) == 2 and lattice.moving:
            named = [{"k": g.k, "frequency_hz": g.frequency_hz}
                     for g in (lattice.generators[0], lattice.moving[0])]
            out["rpo"] = rpo_screen(Path(rows[0]["run_dir"]), named)
            out["sideband"] = sideband_test(rows, named[0]["k"], named[1]["k"])
    out["kick"] = "not run"
    return _plain(out)


#: A kick's size: this fraction of the state's RMS displacement and velocity.
KICK_FRACTION = 0.01
#: A kicked start runs on this many census windows W; its last window is compared.
KICK_WINDOWS = 2
#: The seeds of the kick's two bumps (displacement, velocity: ``KICK_SEED`` and + 1).
KICK_SEED = 0
KICKS = "kicks"


def kick_members(out_dir: Path, groups: dict[str, list[dict]], window: float,
                 tol=None, stream=None) -> dict[str, dict]:  # noqa: ANN001
    """The kick test (module docstring) of every member in ``groups`` (key: "N:member", its
    rows, first start first), run into ``out_dir/kicks/``; never raises. Per key:
    {"returned", "differences", "start", "kicked_at_s", "until_s", "components", the
    kick's RMS sizes} or {"message"} where it could not run."""
    import json


    tol = DEFAULT_TOLERANCES if tol is None else tol
    out: dict[str, dict] = {}
    chosen: dict[str, tuple[dict, Path, float]] = {}
    for key, rows in groups.items():
        row = next((r for r in rows if r.get("features") and at_checkpoint(r)), None)
        if row is None:
            out[key] = {"message": "not run: no start of it ended at a checkpoint"}
            continue
        t_k = float(row["sim_time_s"])
        chosen[key] = (row, out_dir / KICKS / _slug(key), t_k + KICK_WINDOWS * window)
    by_until: dict[float, list[str]] = {}
    for key, (_, _, until) in chosen.items():
        by_until.setdefault(round(until, 12), []).append(key)
    (out_dir / KICKS).mkdir(parents=True, exist_ok=True)
    with open(out_dir / KICKS / "kicks.log", "a") as log:
        for until, keys in by_until.items():
            try:
                continue_batch([chosen[k][0]["run_dir"] for k in keys], until,
                               [chosen[k][1] for k in keys], force=True, stream=log,
                               kick=KICK_FRACTION, kick_seed=KICK_SEED, compress=False)
            except (ReadError, ValueError, OSError, RuntimeError) as err:
                for k in keys:
                    out[k] = {"message": f"not run: {str(err).splitlines()[0]}"}
    for key, (row, kicked_dir, _) in chosen.items():
        if key in out:
            continue
        try:
            summary = json.loads((kicked_dir / "summary.json").read_text())
            samples = _samples(kicked_dir)
            if summary.get("status") != "completed" or samples is None:
                raise ValueError(f"the kicked run ended {summary.get('status')}")
            t_end = float(samples["t"][-1])
            after = window_features(samples, _radius(kicked_dir), t_end - window, t_end)
            why = differences(Features.from_dict(row["features"]), after, tol)
            out[key] = {"returned": not why, "differences": why, "start": row["id"],
                        "kicked_at_s": float(row["sim_time_s"]), "until_s": t_end,
                        "components": components_text(after.components),
                        "run": str(kicked_dir), **{k: v for k, v in (summary.get("kick")
                                                                      or {}).items()}}
        except (OSError, ValueError, KeyError, IndexError) as err:
            out[key] = {"message": f"not run: {type(err).__name__}: {err}"}
    return _plain(out)


def _slug(key: str) -> str:
    import re

    return re.sub(r"[^A-Za-z0-9_.+\-]", "_", key.replace(":", "-"))


def _spread(features: list) -> dict:
    """The largest relative spread of the dominant celerity and the largest spread of a
    listed component's share (absolute) over ``features``."""
    top = features[0].dominant
    cel = [f.dominant.celerity_m_s for f in features if f.dominant is not None
           and f.dominant.key == top.key and not f.dominant.aliased]
    cel_rel = (max(cel) - min(cel)) / abs(sum(cel) / len(cel)) if len(cel) > 1 else 0.0
    share = 0.0
    for c in features[0].listed:
        vals = [d.share for f in features for d in f.components if d.key == c.key]
        if len(vals) > 1:
            share = max(share, max(vals) - min(vals))
    return {"celerity_rel": cel_rel, "share": share}


def _plain(value):  # noqa: ANN001, ANN202
    """JSON-safe scalars and dicts (numpy numbers -> float, non-finite -> None)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def failures(cert: dict | None) -> list[str]:
    """Why a member's certificate (``certify_member``) says it is no attractor: one phrase
    per certificate it got and failed; [] where it passed every one it got. Failing means
    a verdict against it: the direct solver calls the rigid wave unstable (``stable``
    False), or the kicked start did not return (``kick.returned`` False). A certificate
    not made (no solver, a kick that could not run, stability unknown) is no verdict.
    Reproducibility and persistence hold by construction for a settled member (its starts
    match, its two windows match) and only state their spreads, so they fail nothing."""
    if not isinstance(cert, dict):
        return []
    why = []
    if cert.get("stable") is False:
        why.append("unstable in the direct solver"
                   + _stability_how(cert.get("direct") or {}))
    kick = cert.get("kick")
    if isinstance(kick, dict) and kick.get("returned") is False:  # what moved: kick_line
        why.append(f"not returned after a {100 * KICK_FRACTION:.0f} % kick")
    side = cert.get("sideband")
    if isinstance(side, dict) and side.get("verdict") in ("decays", "grows"):
        why.append(sideband_line(side))
    return why


def member_line(cert: dict | None) -> str:
    """One short line for a member's certificate (``certify_member``)."""
    if not cert:
        return "not certified"
    parts = []
    n = cert.get("starts", 0)
    between = cert.get("spread_between_starts") or {}
    if cert.get("reproduced"):
        parts.append(f"reproduced by {n} starts (celerity within "
                     f"{_rel(between.get('celerity_rel'))}, shares within "
                     f"{_pct_abs(between.get('share'))})")
    else:
        parts.append("one start: not reproduced")
    windows = cert.get("change_between_windows")
    if windows:
        parts.append(f"persistent over two windows (celerity {_rel(windows['celerity_rel'])}"
                     f", shares {_pct_abs(windows['share'])})")
    if cert.get("rigid"):
        parts.append(certificate_line(cert.get("direct")))
    if isinstance(cert.get("rpo"), dict):
        parts.append(rpo_line(cert["rpo"]))
    if isinstance(cert.get("sideband"), dict):
        parts.append(sideband_line(cert["sideband"]))
    kick = cert.get("kick")
    if isinstance(kick, dict):
        parts.append(kick_line(kick))
    if isinstance(cert.get("half_step"), dict):
        parts.append(half_step_line(cert["half_step"]))
    return "; ".join(parts)


def rpo_line(screen: dict) -> str:
    """One short phrase for a two-generator member's RPO screen (``rpo_screen``)."""
    if "commutation_defect" not in screen:
        return f"RPO screen: {screen.get('message', 'not run')}"
    return (f"RPO screen: half-node commutation defect {screen['commutation_defect']:.2g}, "
            f"residual {screen['residual']:.2g} over T, {screen['residual_two_periods']:.2g} "
            "over 2T")


#: |σ| (1/s) of a two-generator member's sideband above which it is a transient: its amplitude
#: halves (or doubles) within ln 2 / 0.2 = 3.5 s, less than the census's default cap of 4 s.
#: A saturated torus holds its sideband: |σ| ≤ 0.06 1/s on Figure 3 damped's k = 8 carrying
#: 9 (N = 132); P's k = 11 carrying 10 at N = 264 decays at −0.54 to −0.83 1/s
#: (docs/theory/rpo.md, "Where a two-wave state is born").
SIDEBAND_RATE_TOL = 0.2
#: RMS misfit of log|a| above which the last leg is no single exponential (beats of several
#: modes, a state still switching): no verdict.
SIDEBAND_MISFIT = 0.05


def sideband_test(rows: list[dict], k_wave: int, k_side: int) -> dict:
    """The sideband test of a two-generator member (``k_wave`` carrying ``k_side``): each
    start's growth rate σ of |a_{k_side}| over its last leg (the last 1 − 1/LEG_GROWTH of its
    samples, ``studies.rpo.birth.sideband_fit``), and the verdict from their median:
    "decays" (σ < −``SIDEBAND_RATE_TOL``: a slow transient onto the rigid wave k_wave),
    "grows" (σ > ``SIDEBAND_RATE_TOL``: the state is leaving), "holds" (a torus), or
    "unclear" where a start's log|a| is no exponential (misfit > ``SIDEBAND_MISFIT``) or its
    samples cannot be read. Never raises."""
    out: dict = {"k_wave": k_wave, "k_side": k_side, "sigma_per_start": [],
                 "share_end": [], "misfit": 0.0}
    for r in rows:
        samples = _samples(Path(r["run_dir"]))
        if samples is None:
            return {**out, "verdict": "unclear", "message": f"no samples in {r['run_dir']}"}
        try:
            fit = sideband_fit(samples, k_side, k_wave, 1.0 - 1.0 / LEG_GROWTH)
        except ValueError as err:
            return {**out, "verdict": "unclear", "message": str(err)}
        out["sigma_per_start"].append(fit.sigma)
        out["share_end"].append(fit.share_end)
        out["misfit"] = max(out["misfit"], fit.misfit)
    sigma = float(sorted(out["sigma_per_start"])[len(rows) // 2])
    out["sigma"] = sigma
    if out["misfit"] > SIDEBAND_MISFIT:
        out["verdict"] = "unclear"
    elif sigma < -SIDEBAND_RATE_TOL:
        out["verdict"] = "decays"
    elif sigma > SIDEBAND_RATE_TOL:
        out["verdict"] = "grows"
    else:
        out["verdict"] = "holds"
    return out


def sideband_line(side: dict) -> str:
    """One short phrase for a sideband test (``sideband_test``)."""
    verdict = side.get("verdict")
    if "sigma" not in side:
        return f"sideband test: {side.get('message', 'not run')}"
    head = (f"k = {side['k_side']} sideband {'σ' if verdict != 'unclear' else 'fit'} = "
            f"{side['sigma']:+.2f} 1/s over the last leg")
    if verdict == "decays":
        return (f"{head}: decays (e-folding {-1.0 / side['sigma']:.2g} s), a transient onto "
                f"the rigid k = {side['k_wave']}")
    if verdict == "grows":
        return f"{head}: grows, a transient leaving k = {side['k_wave']}"
    if verdict == "holds":
        return f"{head}: holds"
    return f"{head}: unclear (misfit {side['misfit']:.2g})"


def kick_line(kick: dict) -> str:
    """One short phrase for a kick test (``kick_members``)."""
    if "returned" not in kick:
        return f"kick {kick.get('message', 'not run')}"
    head = (f"kicked by {100 * KICK_FRACTION:.0f} % at {kick['kicked_at_s']:.2f} s "
            f"(start {kick['start']})")
    if kick["returned"]:
        return f"{head}: returned by {kick['until_s']:.2f} s"
    return f"{head}: not returned by {kick['until_s']:.2f} s ({'; '.join(kick['differences'])})"


def _rel(x: float | None) -> str:
    return "?" if x is None else f"{x:.1e}"


def _pct_abs(x: float | None) -> str:
    return "?" if x is None else f"{100 * x:.1f} points"


def certificate_line(cert: dict | None) -> str:
    """One short line for the direct solver's certificate (``certify``)."""
    if not cert:
        return "not certified"
    if not cert.get("available"):
        return cert.get("message", UNAVAILABLE)
    at = cert.get("at_dt", {})
    if not at.get("converged"):
        return f"direct solver: {at.get('message', 'no wave')}"
    text = (f"direct solver residual {at.get('residual') or math.nan:.1e}, "
            f"{at.get('celerity_m_s') or math.nan:+.1f} m/s")
    diff = at.get("difference")
    if isinstance(diff, dict) and diff.get("celerity_rel") is not None:
        text += f" ({100 * diff['celerity_rel']:+.2f} % vs the transient)"
    lim = cert.get("dt_to_0") or {}
    if lim.get("celerity_m_s") is not None:
        text += f"; Δt → 0: {lim['celerity_m_s']:+.1f} m/s"
        if lim.get("run_dt_error") is not None:
            text += f" (the run's Δt error {100 * lim['run_dt_error']:+.2f} %)"
    elif lim.get("message") and not lim["message"].startswith("not computed"):
        text += f"; Δt → 0 wave not found ({lim['message'].split(':')[0]})"
    if "stable" in cert:
        text += {True: "; stable", False: "; unstable", None: "; stability unknown"}[
            cert["stable"]] + _stability_how(cert)
    return text


def _stability_how(cert: dict) -> str:
    """By what the stability was judged: λ₁ at the run's step, or the transient."""
    lyap = cert.get("lyapunov")
    if isinstance(lyap, dict) and lyap.get("lambda1_per_s") is not None:
        return (f" (λ₁ = {lyap['lambda1_per_s']:.2g} ± {lyap['lambda1_error_per_s']:.2g} 1/s "
                "at the run's step)")
    if cert.get("stability_test") == "transient":
        return " (a transient next to the wave)"
    return ""
