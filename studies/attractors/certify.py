"""Certificates of a census's members: what each kind of attractor can cheaply prove.

``certify_member(rows)`` gives every settled member (its rows, first start first):

* **reproducibility**: how many starts reach it; they agree by construction to the grouping
  tolerances (``features.match``), and the largest spread of their dominant celerity and of
  every listed share is stated; reproduced when at least two starts reach it;
* **persistence**: the largest change of the dominant celerity and of the listed shares
  between the two consecutive windows of each start (every row of a member is stationary by
  its class; the numbers say by how much);
* a **rigid wave** (one component) is also handed to the direct solver (``certify`` below):
  one Newton solve at the run's step, and a short transient started next to the wave; an
  unstable one is a transient (``census.answer_of``). The Δt → 0 ladder runs only with
  ``dt_limit`` (``--dt-limit``).
* A kick test (a 1 % perturbation of a multi-wave state, run on) is not run: it costs a
  transient per member, as much as a start.

Certification by the direct travelling-wave solver, through one adapter:

``certify(run_dir)`` hands one of the member's runs to ``studies.travel.wave_from_run`` with
``dt_limit=True``: the transient's own discrete wave at the run's step (its residual, its
celerity and the relative difference to the transient's) and the wave as Δt → 0 at that mesh
(with the run's own Δt error), and, where ``studies.travel.wave_stability`` exists, whether
a transient started next to the wave keeps it. Where the finer levels of the Δt → 0 wave
have no wave (the free-ω Newton stagnates with an inequality violated), the wave at the run's
step still stands and ``dt_to_0`` says why its limit is unknown. When the
travel solver is not installed the answer says "certification unavailable" and the census
goes on; a run that is not a rigid wave (``NotRigidWave``) or a solver failure is reported,
never raised.
"""

from __future__ import annotations

import math
from pathlib import Path

UNAVAILABLE = "certification unavailable"


def _travel():  # noqa: ANN202
    try:
        import studies.travel as travel

        return travel if hasattr(travel, "wave_from_run") else None
    except ImportError:
        return None


def available() -> bool:
    """True when the direct solver's ``wave_from_run`` can be called."""
    return _travel() is not None


def certify(run_dir: Path, *, stability: bool = True, stability_end_time: float = 0.05,
            dt_limit: bool = False, window: float | None = None) -> dict:
    """The member's certificate from one of its runs (module docstring); never raises.
    ``dt_limit = False`` leaves the Δt → 0 wave out (its finest level, 4S points per node, is
    a dense Newton system whose cost grows as the cube). ``window``: the end state's window
    (s; default the run's analysis window), e.g. a census's W for a start it extended."""
    travel = _travel()
    if travel is None:
        return {"available": False, "message": f"{UNAVAILABLE}: studies.travel.wave_from_run "
                "is not installed"}
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
    if stability and wave.get("converged") and hasattr(travel, "wave_stability"):
        try:
            st = travel.wave_stability(run_dir, end_time=stability_end_time,
                                       window=window)
            out["stable"] = bool(st.get("stable"))
            out["drift"] = _plain(st.get("drift"))
            if st.get("samples") is not None and st["samples"] != wave.get("samples"):
                out["stability_samples"] = int(st["samples"])  # S' = ceil(τ/Δt)
        except Exception as err:  # reported, the census goes on
            out["stable"] = None
            out["stability_message"] = f"{type(err).__name__}: {err}"
    return out


def certify_member(rows: list[dict], *, dt_limit: bool = False,
                   window: float | None = None) -> dict:
    """The certificate of one settled member from its rows (module docstring), its features
    read over the last ``window`` seconds (the census's W); never raises."""
    from studies.attractors.features import Features

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
    out["kick"] = "not run"
    return _plain(out)


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
    return "; ".join(parts)


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
            cert["stable"]]
    return text
