"""The printed answer of a census: a few lines a person reads in ten seconds."""

from __future__ import annotations

import math

from studies.attractors.certify import certificate_line
from studies.attractors.classify import member_description


def _pct(x: float) -> str:
    return f"{100 * x:.0f} %"


def _member_phrase(m: dict) -> str:
    text = f"{member_description(m['member'])}"
    if m.get("k") is not None and m.get("celerity_m_s") is not None \
            and math.isfinite(m["celerity_m_s"]):
        text += f" {m['celerity_m_s']:+.1f} m/s, {m['frequency_hz']:.1f} Hz"
    return (f"{text} ({m['count']}/{m['starts']} = {_pct(m['share'])}, "
            f"95 % CI {_pct(m['share_lo'])}–{_pct(m['share_hi'])})")


def mesh_lines(n: str, members: list[dict], structured: list[dict]) -> list[str]:
    waves = [m for m in members if m["class"] == "wave"]
    others = [m for m in members if m["class"] != "wave"]
    n_starts = members[0]["starts"] if members else 0
    head = (f"N = {n} ({n_starts} random starts): {len(waves)} attractor"
            f"{'s' if len(waves) != 1 else ''} (rigid waves)")
    if not members:
        head += "; no random start finished yet"
    lines = [head + (":" if waves else "")]
    lines += [f"  {_member_phrase(m)}" for m in waves]
    if others:
        lines.append("  other end states:")
        lines += [f"    {_member_phrase(m)}" for m in others]
    if any(m["class"] == "unsettled" for m in members):
        lines.append("  (unsettled: not yet a limit cycle, or its modulation still decays; "
                     "a longer --end-time settles them)")
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
        if len(m["meshes"]) < 2 or name in ("diverged", "failed", "unsettled",
                                            "steady-sliding"):
            continue
        diffs = m["differences"]["celerity_m_s"]
        text = ", ".join(f"{a}→{b}: {100 * d:+.2f} %" for a, b, d in
                         zip(m["meshes"], m["meshes"][1:], diffs, strict=False))
        orders = [p for p in m["order"]["celerity_m_s"] if math.isfinite(p)]
        if orders:
            text += f"; observed order {orders[-1]:.2f}"
        lines.append(f"  {name}: celerity {text}")
    return lines


def summary_text(answer: dict) -> str:
    """The printed summary (module docstring)."""
    dist = answer["distribution"]
    counts = answer["counts"]
    head = (f"attractors of {answer['scene']['name']}: {dist['starts']} random start(s) "
            f"per mesh (K = {dist['n_modes']}, A = {dist['amplitude']:g} d, seeds "
            f"{dist['seed']}..{dist['seed'] + dist['starts'] - 1}); members: same (k, "
            f"direction, regime), celerity within {100 * answer['celerity_tol']:g} %, "
            f"frame spread ≤ {100 * answer['spread_tol']:g} %")
    lines = [head]
    left = {k: v for k, v in counts.items() if k in ("pending", "running", "interrupted",
                                                       "crashed", "unanalysed")}
    if left:
        lines.append("NOT FINISHED: " + ", ".join(f"{v} {k}" for k, v in left.items())
                     + " (run the same command again to resume)")
    for n, members in answer["members"].items():
        lines += mesh_lines(n, members, answer["structured"].get(n, []))
    lines += ladder_lines(answer)
    certs = answer.get("certificates") or {}
    if certs.get("available") is False:
        lines.append("certification unavailable (studies.travel.wave_from_run not installed)")
    for key, cert in certs.items():
        if key != "available":
            lines.append(f"  certificate {key}: {certificate_line(cert)}")
    return "\n".join(lines)
