"""The printed answer of a census: a few lines a person reads in ten seconds."""

from __future__ import annotations

import math

from stickslip.studies.attractors.certify import member_line
from stickslip.studies.attractors.classify import member_description
from stickslip.studies.attractors.statistics import SETTLED, SETTLING, UNFINISHED


def _pct(x: float) -> str:
    return f"{100 * x:.0f} %"


def _member_phrase(m: dict) -> str:
    settled = m["class"] in SETTLED or m["class"] == "transient"
    text = (m.get("name") if settled else "") or member_description(m["member"])
    if settled:
        text += f", {_regime(m)}"
    if m.get("k") is not None and m.get("celerity_m_s") is not None \
            and math.isfinite(m["celerity_m_s"]):
        text += f"; {m['celerity_m_s']:+.1f} m/s, {m['frequency_hz']:.1f} Hz"
        comps = [c for c in m.get("components") or [] if not c["weak"]][1:] if settled else []
        if comps:
            text += " (" + ", ".join(
                f"k = {c['k']}: " + ("aliased" if c["aliased"] else
                                     f"{c['celerity_m_s']:+.1f} m/s") for c in comps) + ")"
    text = (f"{text} [{m['member']}] ({m['count']}/{m['starts']} = {_pct(m['share'])}, "
            f"95 % CI {_pct(m['share_lo'])}–{_pct(m['share_hi'])})")
    if settled and m.get("settle_time_s_max") is not None \
            and math.isfinite(m["settle_time_s_max"]):
        text += (f"; settled by {m['settle_time_s']:.2f} s (median), "
                 f"{m['settle_time_s_max']:.2f} s (last)")
    near = m.get("approaching") or {}
    if near:
        text += "; in its last window " + ", ".join(
            f"{c} of them match {name}" for name, c in near.items())
    return text


def _regime(m: dict) -> str:
    return m.get("regime") or "?"


def mesh_lines(n: str, members: list[dict], structured: list[dict]) -> list[str]:
    settled = [m for m in members if m["class"] in SETTLED]
    rigid = sum(m["class"] == "wave" for m in settled)
    others = [m for m in members if m["class"] not in SETTLED]
    n_starts = members[0]["starts"] if members else 0
    reached = sum(m["count"] for m in settled)
    head = (f"N = {n} ({n_starts} random starts): {len(settled)} attractor"
            f"{'s' if len(settled) != 1 else ''} ({rigid} rigid, {len(settled) - rigid} "
            f"multi-wave), reached by {reached} of {n_starts} starts")
    if not members:
        head += "; no random start finished yet"
    lines = [head + (":" if settled else "")]
    lines += [f"  {_member_phrase(m)}" for m in settled]
    if others:
        lines.append("  not attractors:")
        lines += [f"    {m['class']}: {_member_phrase(m)}" if m["class"] == "transient"
                  else f"    {_member_phrase(m)}" for m in others]
    if any(m["class"] == "unsettled" for m in members):
        lines.append("  (unsettled: its features still change between the last two windows, "
                     "or its shares drift across the last leg, at the cap; a larger "
                     "--max-time continues them)")
    if structured:
        lines.append("  structured: " + "; ".join(
            f"mode {r['start_mode']} -> {r['member'] or r['class']}" for r in structured))
    return lines


def ladder_lines(answer: dict) -> list[str]:
    lad = answer["ladder"]
    meshes = [int(n) for n in answer["members"]]
    if len(meshes) < 2:
        return ["ladder: one mesh; the set of attractors is not checked under refinement"]
    lines = []
    stable = lad.get("stable_from")
    lines.append(f"set of attractors: the same, shares consistent (Fisher p ≥ 0.05), from "
                 f"N = {stable} on" if stable is not None else
                 "set of attractors: still changing within the ladder (refine further)")
    differ = [t for t in lad["tests"] if t["consistent"] is False]
    if differ:
        lines.append("  shares that differ (Fisher's exact test, p < 0.05): " + "; ".join(
            f"{t['member']} {t['count_a']}/{t['starts_a']} at N = {t['mesh_a']} vs "
            f"{t['count_b']}/{t['starts_b']} at N = {t['mesh_b']} (p = {t['p_value']:.2g})"
            for t in differ))
    for name, m in lad["members"].items():
        if len(m["meshes"]) < 2 or name in ("diverged", "failed", "steady-sliding") \
                or name.startswith("unsettled"):
            continue
        parts = []
        for label, comp in m.get("components", {}).items():
            parts.append(f"{label} celerity {_steps(m['meshes'], comp['celerity_m_s'])}")
            if len(m.get("components", {})) > 1:
                parts.append(f"{label} share {_share_steps(comp['share']['values'])}")
        if not parts:
            parts.append(f"celerity {_steps(m['meshes'], _as_changes(m, 'celerity_m_s'))}")
        lines.append(f"  {name}: " + "; ".join(parts))
    coarse = lad.get("coarse") or {}
    if coarse:
        dist = coarse["dominant_k"]
        lines.append("  dominant component of the starts: " + " → ".join(
            f"N = {n}: " + ", ".join(f"{k} {_pct(p)}" for k, p in d.items())
            for n, d in dist.items()))
        tv = coarse["dominant_k_distance"]
        if tv:
            lines.append("    change (total variation) " + ", ".join(f"{x:.2f}" for x in tv))
        wc = coarse["weighted_celerity_m_s"]
        vals = wc["values"]
        steps = [b - a for a, b in zip(vals, vals[1:], strict=False)
                 if math.isfinite(a) and math.isfinite(b)]
        lines.append("  basin-weighted celerity: " + " → ".join(
            f"{v:+.1f}" if math.isfinite(v) else "–" for v in vals) + " m/s"
            + (" (change " + ", ".join(f"{d:+.1f} m/s" for d in steps) + ")" if steps else ""))
    return lines


def _as_changes(m: dict, key: str) -> dict:
    return {"values": m[key], "differences": m["differences"][key], "order": m["order"][key]}


def _steps(meshes: list[int], ch: dict) -> str:
    text = ", ".join(f"{a}→{b}: {100 * d:+.2f} %" if math.isfinite(d) else f"{a}→{b}: –"
                     for a, b, d in zip(meshes, meshes[1:], ch["differences"], strict=False))
    orders = [p for p in ch["order"] if math.isfinite(p)]
    if orders:
        text += f" (observed order {orders[-1]:.2f})"
    return text


def _share_steps(values: list[float]) -> str:
    return " → ".join(_pct(v) if math.isfinite(v) else "–" for v in values)


def unfinished_line(answer: dict) -> str:
    """The NOT FINISHED line: why the session stopped, the starts left and their states
    (a settling start: unsettled below the cap, its next leg not run), and the fix."""
    left = [f"{v} {k}" + (f" (unsettled below the cap of {answer['max_time_s']:g} s)"
                          if k == SETTLING and answer.get("max_time_s") else "")
            for k, v in answer["counts"].items() if k in UNFINISHED]
    why = f" ({answer['stopped']})" if answer.get("stopped") else ""
    return (f"NOT FINISHED{why}: " + (", ".join(left) or "the certificates are not all made")
            + "; run the same command again to resume")


def summary_text(answer: dict) -> str:
    """The printed summary (module docstring)."""
    dist = answer["distribution"]
    counts = answer["counts"]
    tol = answer.get("tolerances") or {}
    head = (f"attractors of {answer['scene']['name']}: {dist['starts']} random start(s) "
            f"per mesh (K = {dist['n_modes']}, A = {dist['amplitude']:g} d, seeds "
            f"{dist['seed']}..{dist['seed'] + dist['starts'] - 1}); an attractor: the same "
            f"travelling components (share ≥ {100 * tol.get('share_listed', 0.1):g} % of "
            f"the dominant's) in the last two windows and across starts, celerities within "
            f"{100 * answer['celerity_tol']:g} %, shares within "
            f"{100 * tol.get('share_rel', 0.1):g} % (≥ {100 * tol.get('share_abs', 0.02):g} "
            "points)")
    lines = [head]
    if answer.get("finished") is False or any(k in UNFINISHED for k in counts):
        lines.append(unfinished_line(answer))
    for n, members in answer["members"].items():
        lines += mesh_lines(n, members, answer["structured"].get(n, []))
    lines += ladder_lines(answer)
    certs = answer.get("certificates") or {}
    for key, cert in certs.items():
        lines.append(f"  certificate {key}: {member_line(cert)}")
    timing = answer.get("timing") or {}
    if certs and timing.get("certification_s") is not None and timing.get("sweep_s"):
        # the kicks' time is part of the certificates'
        total = sum(timing.get(k) or 0 for k in ("sweep_s", "features_s", "certification_s"))
        kicks = (f", of which kicks {timing['kick_s']:.1f} s" if timing.get("kick_s")
                 is not None else "")
        lines.append(f"time: runs {timing['sweep_s']:.1f} s, features "
                     f"{timing.get('features_s') or 0:.1f} s, certificates "
                     f"{timing['certification_s']:.1f} s{kicks} "
                     f"({_pct(timing['certification_s'] / total)} of the census)")
    return "\n".join(lines)
