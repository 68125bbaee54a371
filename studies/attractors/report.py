"""The printed answer of a census: a few lines a person reads in ten seconds.

Per mesh, each attractor on one line (class, dominant component, its celerity and
frequency, regime, the starts reaching it, settle times, and its member id in brackets),
then a line of the companions it carries (its lattice's generators), a line of its lattice
type (for a relative periodic orbit its period T and shift s) and combination tones, and
its certificate; the non-attractors apart.
Every component is named with its direction in words (``classify.SENSE``).
"""

from __future__ import annotations

import math
import re

from stickslip.studies.attractors.certify import member_line
from stickslip.studies.attractors.classify import (
    CLASS_WORDS,
    component_words,
    member_description,
)
from stickslip.studies.attractors.lattice import tone_text
from stickslip.studies.attractors.statistics import (
    ATTRACTING,
    NAMED,
    SETTLED,
    SETTLING,
    UNFINISHED,
    accounting,
    member_features,
)


def _pct(x: float) -> str:
    return f"{100 * x:.0f} %"


def _finite(x: float | None) -> bool:
    return x is not None and math.isfinite(x)


def _head(m: dict) -> str:
    """"multi-wave k = 9 with the rotation, +1708.8 m/s, 2447.6 Hz, stick-slip-separation":
    a member's class and dominant component in words, its mean celerity and frequency."""
    words = CLASS_WORDS.get(m["class"], m["class"])
    if m.get("k") is None or m["class"] not in NAMED:
        return words
    text = f"{words} {component_words(m['k'], m['direction'])}"
    if _finite(m.get("celerity_m_s")):
        text += f", {m['celerity_m_s']:+.1f} m/s, {m['frequency_hz']:.1f} Hz"
    return text + (f", {m['regime']}" if m.get("regime") else "")


def _companions(m: dict) -> str:
    """"carrying k = 14 against the rotation, -827.5 m/s (73 %); ...": the companions the
    member's name gives (``Features.named``), each with its celerity and share."""
    named = member_features(m).named(m["class"] != "multi-wave")[1:]
    parts = []
    for c in named:
        tag = ", weak" if c.weak else ""
        parts.append(f"k = {c.k}, aliased: no celerity ({100 * c.share:.0f} %{tag})"
                     if c.aliased else f"{component_words(c.k, c.direction)}, "
                     f"{c.celerity_m_s:+.1f} m/s ({100 * c.share:.0f} %{tag})")
    return "carrying " + "; ".join(parts) if parts else ""


def _lattice(m: dict) -> str:
    """"relative periodic orbit: period 1.804 ms, shift -100.3° in the frame of k = 6
    against the rotation; combination tones k = 2 against the rotation = 2(6) − (10)": a
    multi-wave member's lattice type (``studies.attractors.lattice``), T and s of a
    relative periodic orbit, and its listed tones on the generators (the weak ones counted;
    all are in ``attractors.json``); '' for a rigid wave."""
    kind = m.get("type")
    if not kind or (m["class"] != "multi-wave" and not m.get("combinations")):
        return ""
    gens = m.get("generators") or []
    text = kind
    if _finite(m.get("period_s")) and gens:
        text += (f": period {1e3 * m['period_s']:.3f} ms, shift {m['shift_deg']:+.1f}° in "
                 f"the frame of {component_words(gens[0]['k'], gens[0]['direction'])}")
    elif kind == "torus":
        text += f" of {len(gens)} generators"
    elif kind == "rigid wave" and len(gens) > 1:
        text += ": its generators travel at one celerity"
    tones = m.get("combinations") or []
    listed = [t for t in tones if not t.get("weak")]
    if listed:
        labels = [g["k"] for g in gens]
        text += "; combination tones " + ", ".join(
            f"{component_words(t['k'], t['direction'])} = "
            f"{tone_text(t['coefficients'], labels)}" for t in listed)
    if len(tones) > len(listed):
        text += f" (and {len(tones) - len(listed)} weak)"
    return text


def member_lines(n: str, m: dict, certs: dict) -> list[str]:
    """A member's printed lines (module docstring), unindented; its certificate from
    ``certs`` (keyed ``"N:member"``), taken out of it."""
    share = (f"{m['count']} of {m['starts']} starts = {_pct(m['share'])} "
             f"(95 % CI {_pct(m['share_lo'])}–{_pct(m['share_hi'])})")
    text = f"{_head(m)}: {share}"
    settled = m["class"] in SETTLED or m["class"] == "transient"
    if settled and _finite(m.get("settle_time_s_max")):
        text += (f"; settled by {m['settle_time_s']:.2f} s (median), "
                 f"{m['settle_time_s_max']:.2f} s (last)")
    member = m.get("member") or m["class"]
    if member != m["class"]:
        text += f" [{member}]"
    lines = [text]
    if m["class"] == "chaotic":
        lines.append(f"  largest Lyapunov exponent {m['lambda1_per_s']:.3g} ± "
                     f"{m['lambda1_error_per_s']:.2g} 1/s (> 0 beyond 3 standard errors), "
                     f"statistics stationary over {m['stationary_windows']} windows, up to "
                     "the cap (a larger --max-time can end it: transient chaos)")
    if m.get("rejected_because"):
        lines.append(f"  not an attractor: {m['rejected_because']}")
    if m.get("not_chaotic_because"):
        lines.append(f"  not chaotic: {m['not_chaotic_because']}")
    companions = _companions(m) if settled else ""
    if companions:
        lines.append(f"  {companions}")
    lattice = _lattice(m) if settled else ""
    if lattice:
        lines.append(f"  {lattice}")
    near = m.get("approaching") or {}
    if near:
        lines.append("  in its last window " + ", ".join(
            f"{c} of them match {name}" for name, c in near.items()))
    cert = certs.pop(f"{n}:{member}", None)
    if cert is not None:
        lines.append(f"  certificate: {member_line(cert)}")
    return lines


def elsewhere_text(entries: list[dict], at_cap: bool = True) -> str:
    """"2 unsettled at the cap, 1 on a rigid wave k = 8 with the rotation, unstable in the
    direct solver, at the cap, 1 failed": where the starts that reached no attractor are
    (``statistics.accounting``'s ``elsewhere``): the unsettled, steady, diverged and failed
    starts counted per class, each member that failed a certificate with its state and why
    (``at_cap``: the census has a cap, which such a start has reached)."""
    cap = " at the cap" if at_cap else ""
    counts: dict[str, int] = {}
    rejected = []
    for e in entries:
        if e["class"] != "transient":
            counts[e["class"]] = counts.get(e["class"], 0) + e["count"]
            continue
        where = component_words(e["k"], e["direction"]) if e.get("k") is not None else ""
        why = " and ".join((e.get("because") or "transient").split("; "))
        rejected.append(f"{e['count']} on a {e.get('type') or 'state'} {where}".rstrip()
                        + f", {why}" + (f",{cap}" if cap else ""))
    words = {"unsettled": f"unsettled{cap}", "settling": "still settling below the cap"}
    parts = [f"{counts.pop('unsettled')} {words['unsettled']}"] if "unsettled" in counts else []
    parts += rejected
    parts += [f"{v} {words.get(c) or CLASS_WORDS.get(c, c)}" for c, v in counts.items()]
    return ", ".join(parts)


def mesh_lines(n: str, members: list[dict], structured: list[dict],
               certs: dict | None = None, at_cap: bool = True) -> list[str]:
    """One mesh's lines: the headline (its attractors, the starts that reach them, where
    the others are: ``elsewhere_text``), the attractors, then the non-attractors, then the
    structured starts. ``certs``: the certificates (``"N:member"``); those printed are
    taken out. ``at_cap``: the census has a cap (its unsettled starts are at it)."""
    certs = {} if certs is None else certs
    counted = accounting(members)
    settled = [m for m in members if m["class"] in ATTRACTING]
    rigid = sum(m["class"] == "wave" for m in settled)
    chaotic = sum(m["class"] == "chaotic" for m in settled)
    others = [m for m in members if m["class"] not in ATTRACTING]
    n_starts = counted["starts"]
    head = (f"N = {n} ({n_starts} random starts): {len(settled)} attractor"
            f"{'s' if len(settled) != 1 else ''} ({rigid} rigid, "
            f"{len(settled) - rigid - chaotic} multi-wave"
            + (f", {chaotic} chaotic" if chaotic else "")
            + f"), reached by {counted['reached']} of {n_starts} starts")
    if counted["elsewhere"]:
        head += "; " + elsewhere_text(counted["elsewhere"], at_cap)
    if not members:
        head += "; no random start finished yet"
    lines = [head + (":" if settled else "")]
    lines += [f"  {line}" for m in settled for line in member_lines(n, m, certs)]
    if others:
        lines.append("  not attractors:")
        lines += [f"    {line}" for m in others for line in member_lines(n, m, certs)]
    if any(m["class"] == "unsettled" for m in members):
        tested = any(m.get("not_chaotic_because") for m in members)
        lines.append("  (unsettled: its features still change between the last two windows, "
                     "or its shares drift across the last leg, at the cap"
                     + (", and it is not chaotic: its statistics drift or λ₁ is not > 0"
                        if tested else "") + "; a larger --max-time continues them)")
    if structured:
        lines.append("  structured starts: " + "; ".join(
            f"mode {r['start_mode']} -> " + (f"{member_description(r['member'])} "
                                             f"[{r['member']}]" if r["member"] else r["class"])
            for r in structured))
    return lines


def ladder_lines(answer: dict) -> list[str]:
    """What the mesh ladder says: whether the set of attractors stops changing, the shares
    that differ, per attractor on several meshes how each component's celerity and share
    move, and the coarse observables; every component in words."""
    lad = answer["ladder"]
    meshes = list(answer["members"])  # rung keys ("132", "132p2"), in ladder order
    if len(meshes) < 2:
        return ["ladder: one mesh; the set of attractors is not checked under refinement"]
    lines = settle_lines(lad.get("steps") or [], lad.get("settles_from"))
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
        for i, (label, comp) in enumerate(m.get("components", {}).items()):
            steps = _steps(m["meshes"], comp["celerity_m_s"])
            parts.append(f"{_sign_words(label)}, celerity {steps}"
                         + (f", share {_share_steps(comp['share']['values'])}" if i else ""))
        if not parts:
            parts.append(f"celerity {_steps(m['meshes'], _as_changes(m, 'celerity_m_s'))}")
        lines.append(f"  {name}: " + "; ".join(parts))
    coarse = lad.get("coarse") or {}
    if coarse:
        dist = coarse["dominant_k"]
        lines.append("  dominant component of the starts: " + " → ".join(
            f"N = {n}: " + ", ".join(f"{_pct(p)} {_sign_words(k)}" for k, p in
                                     sorted(d.items(), key=lambda kp: -kp[1]))
            for n, d in dist.items()))
        tv = coarse["dominant_k_distance"]
        if tv:
            lines.append("    change (total variation) " + ", ".join(f"{x:.2f}" for x in tv))
        wc = coarse["weighted_celerity_m_s"]
        vals = wc["values"]
        steps = [b - a for a, b in zip(vals, vals[1:], strict=False)
                 if math.isfinite(a) and math.isfinite(b)]
        lines.append("  basin-weighted celerity (+: with the rotation): " + " → ".join(
            f"{v:+.1f}" if math.isfinite(v) else "–" for v in vals) + " m/s"
            + (" (change " + ", ".join(f"{d:+.1f} m/s" for d in steps) + ")" if steps else ""))
    return lines


def _step_text(step: dict) -> str:
    """"132 → 264: set changes (+2, −3), Fisher p = 6.8e-06, TV 0.88, celerity 31 %"."""
    moved = ("same set" if step["same_set"] else
             f"set changes (+{len(step['added'])}, −{len(step['lost'])})")
    p = step["fisher_min_p"]
    fisher = f"Fisher p = {p:.2g}" if math.isfinite(p) else "Fisher –"
    change = step["celerity_change"]
    cel = f"celerity {100 * change:.3g} %" if math.isfinite(change) else "celerity –"
    return (f"{step['from']} → {step['to']}: {moved}, {fisher}, TV "
            f"{step['dominant_tv']:.2f}, {cel}" + (" (holds)" if step["holds"] else ""))


def settle_lines(steps: list[dict], first: object | None) -> list[str]:
    """The settle criterion in words (``statistics.rung_steps``): the first rung from which
    the answer stays the same, or that none does, with every step's numbers."""
    if not steps:
        return []
    rule = ("same attractors, shares consistent (Fisher p ≥ 0.05), dominant distribution "
            "within TV 0.1, basin-weighted celerity within 1 %")
    head = (f"answer settled from N = {first} on ({rule})" if first is not None else
            f"no rung from which the answer stays the same ({rule}): refine further")
    return [head] + [f"  {_step_text(s)}" for s in steps]


def _sign_words(label: str) -> str:
    """A component key of the ladder (``k9+``: with the rotation, ``k9-``: against) in
    words; anything else (a class) as it is."""
    found = re.fullmatch(r"k(\d+)([+-])", label)
    if not found:
        return CLASS_WORDS.get(label, label)
    return component_words(int(found[1]), "rotation" if found[2] == "+" else "opposite")


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
    (a settling start: unsettled, or on a state that failed a certificate, below the cap,
    its next leg not run), and the fix."""
    left = [f"{v} {k}" + (f" (unsettled, or on a state that failed a certificate, below "
                          f"the cap of {answer['max_time_s']:g} s)"
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
            f"{dist['seed']}..{dist['seed'] + dist['starts'] - 1})\nan attractor: the same "
            f"travelling components (share ≥ {100 * tol.get('share_listed', 0.1):g} % of "
            f"the dominant's) in the last two windows and across starts, celerities within "
            f"{100 * answer['celerity_tol']:g} %, shares within "
            f"{100 * tol.get('share_rel', 0.1):g} % (≥ {100 * tol.get('share_abs', 0.02):g} "
            "points)")
    lines = [head]
    if answer.get("finished") is False or any(k in UNFINISHED for k in counts):
        lines.append(unfinished_line(answer))
    certs = answer.get("certificates") or {}
    left = dict(certs)  # those not printed under their random starts' member
    at_cap = answer.get("max_time_s") is not None
    for n, members in answer["members"].items():
        lines += mesh_lines(n, members, answer["structured"].get(n, []), left, at_cap)
    lines += ladder_lines(answer)
    for key, cert in left.items():  # the structured starts' members
        lines.append(f"  certificate {key}: {member_line(cert)}")
    timing = answer.get("timing") or {}
    if certs and timing.get("certification_s") is not None and timing.get("sweep_s"):
        # the kicks' time is part of the certificates'
        total = sum(timing.get(k) or 0 for k in ("sweep_s", "features_s", "certification_s",
                                                  "chaos_s"))
        kicks = (f", of which kicks {timing['kick_s']:.1f} s" if timing.get("kick_s")
                 is not None else "")
        chaos = (f", chaos tests {timing['chaos_s']:.1f} s" if timing.get("chaos_s")
                 is not None else "")
        lines.append(f"time: runs {timing['sweep_s']:.1f} s, features "
                     f"{timing.get('features_s') or 0:.1f} s, certificates "
                     f"{timing['certification_s']:.1f} s{kicks} "
                     f"({_pct(timing['certification_s'] / total)} of the census){chaos}")
    return "\n".join(lines)
