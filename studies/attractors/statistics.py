"""Statistics of a census: basin shares, member values, and what the mesh ladder says.

* Basin share of a member at one mesh: p̂ = x / n over the n classified random starts (every
  class counts in n, diverged and failed included), with the 95 % Wilson score interval

      (p̂ + z²/2n ± z sqrt(p̂(1 − p̂)/n + z²/4n²)) / (1 + z²/n),   z = 1.95996

  (Wilson 1927), which unlike p̂ ± z sqrt(p̂(1 − p̂)/n) stays inside [0, 1] and keeps its
  coverage for x = 0 or x = n.
* Member values: mean and sample standard deviation (ddof = 1) over the random starts that
  reach the member.
* Ladder: for a member present on successive meshes N_1 < N_2 < N_3, the differences of its
  mean values, and with three meshes of one ratio r = N_2/N_1 = N_3/N_2 the observed order
  p = ln(|q_1 − q_2| / |q_2 − q_3|) / ln r. Consistency of two meshes' shares: Fisher's exact
  test (two-sided) on the 2 x 2 table (this member / not) x (mesh a / mesh b); the shares are
  called consistent at p ≥ 0.05. The same seeds start both meshes, which makes the two
  samples positively correlated; the test, which assumes independent samples, is then
  conservative (it calls fewer differences significant than a paired test would).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from stickslip.studies.attractors.chaos import verdict_text
from stickslip.studies.attractors.classify import member_label, readable_name
from stickslip.studies.attractors.features import Component, Features, Tolerances, match
from stickslip.studies.attractors.starts import parse_rung_key

Z95 = 1.959963984540054  # the 97.5 % quantile of the standard normal
#: Values averaged per member (row keys of ``attractors.csv``).
VALUE_KEYS = ("celerity_m_s", "frequency_hz", "fraction_separation", "fraction_stick",
              "fraction_slip", "psi1", "psi2", "amplitude_m", "rms_amplitude_m")
#: The classes counted in a basin-share denominator (pending/interrupted starts are not).
COUNTED = ("wave", "multi-wave", "chaotic", "transient", "unsettled", "steady-sliding",
           "diverged", "failed")
#: The class of an unsettled start below its census's cap: its next leg has not run (or
#: failed), so it is no end state yet (``census.answer_of``).
SETTLING = "settling"
#: The states of a start that leave a census's answer not finished (not counted either).
UNFINISHED = ("pending", "running", "interrupted", "crashed", "unanalysed", SETTLING)
ALPHA = 0.05
#: The classes of a settled end state (a rigid wave, a relative periodic orbit, a torus).
SETTLED = ("wave", "multi-wave")
#: The classes whose members make up "the set of attractors" of a mesh: the settled end
#: states and the chaotic ones (``studies.attractors.chaos``).
ATTRACTING = (*SETTLED, "chaotic")
#: The settle criterion of the ladder (``rung_steps``): from one rung to the next the
#: dominant-component distribution moves by less than this total variation ...
SETTLE_TV = 0.1
#: ... and the basin-weighted celerity by at most this relative change.
SETTLE_CELERITY = 0.01


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval (lo, hi) of a binomial share successes / n (module doc)."""
    if n <= 0:
        return (0.0, 1.0)
    p = successes / n
    centre = p + z * z / (2 * n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    den = 1 + z * z / n
    return (max(0.0, (centre - half) / den), min(1.0, (centre + half) / den))


def mean_spread(values: Sequence[float | None]) -> tuple[float, float, int]:
    """(mean, sample standard deviation, count) of the finite values; NaN where undefined."""
    xs = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    if not xs:
        return math.nan, math.nan, 0
    m = sum(xs) / len(xs)
    sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else 0.0
    return m, sd, len(xs)


#: The classes whose label names a dominant component (the others: their class only).
NAMED = ("wave", "multi-wave", "chaotic", "transient", "unsettled", SETTLING)
#: The classes of a settled end state, whose member has a lattice ``type``.
TYPED = (*SETTLED, "transient")


def mesh_members(rows: list[dict]) -> list[dict]:
    """Per member of one mesh's random starts: count, share, Wilson interval, values, its
    readable ``name`` and ``label`` (``classify.readable_name``, ``classify.member_label``)."""
    counted = [r for r in rows if r["class"] in COUNTED]
    n = len(counted)
    by_member: dict[str, list[dict]] = {}
    for r in counted:
        by_member.setdefault(r["member"], []).append(r)
    out = []
    for member, group in by_member.items():
        lo, hi = wilson(len(group), n)
        entry = {"member": member, "class": group[0]["class"], "k": group[0]["k"],
                 "direction": group[0]["direction"], "regime": group[0]["regime"],
                 "count": len(group), "starts": n, "share": len(group) / n,
                 "share_lo": lo, "share_hi": hi, "seeds": [r["seed"] for r in group],
                 "rejected_because": group[0].get("rejected_because"),
                 "approaching": _approaching(group), **member_components(group)}
        entry["label"] = member_label(entry["class"], member, member_features(entry).named(
            entry["class"] != "multi-wave") if entry["class"] in NAMED else ())
        for key in VALUE_KEYS:
            m, sd, _ = mean_spread([r[key] for r in group])
            entry[key] = m
            entry[f"{key}_sd"] = sd
        settle = [float(r["settle_time_s"]) for r in group
                  if r.get("settle_time_s") is not None and math.isfinite(r["settle_time_s"])]
        entry["settle_time_s"] = float(np.median(settle)) if settle else math.nan
        entry["settle_time_s_max"] = max(settle) if settle else math.nan
        if entry["class"] == "chaotic":
            entry.update(chaos_values(group))
        tested = [r["chaos"] for r in group if r.get("chaos")]
        if entry["class"] == "unsettled" and tested:
            entry["not_chaotic_because"] = verdict_text(tested[0]) + (
                f" (and {len(tested) - 1} more start{'s' if len(tested) > 2 else ''})"
                if len(tested) > 1 else "")
        out.append(entry)
    out.sort(key=lambda e: (-e["count"], e["member"]))
    return out


def chaos_values(rows: list[dict]) -> dict:
    """A chaotic member's largest Lyapunov exponent (the mean over its starts of λ₁, and
    the largest standard error) and the windows its statistics were stationary over."""
    found = [(r.get("chaos") or {}) for r in rows]
    lams = [f["lyapunov"]["lambda1_per_s"] for f in found if f.get("lyapunov")]
    errs = [f["lyapunov"]["lambda1_error_per_s"] for f in found if f.get("lyapunov")]
    windows = [len((f.get("stationarity") or {}).get("windows") or []) for f in found]
    return {"lambda1_per_s": float(np.mean(lams)) if lams else math.nan,
            "lambda1_error_per_s": max(errs) if errs else math.nan,
            "stationary_windows": min(windows) if windows else 0}


def accounting(members: list[dict]) -> dict:
    """Where one mesh's counted random starts are (``mesh_members`` entries): ``starts``,
    ``attractors`` (the settled members that passed every certificate they got, and the
    chaotic ones), ``reached`` (their starts) and ``elsewhere``, one entry per other member:
    {"class", "member", "count", "type", "k", "direction", "because"} (``because``: why
    it is no attractor, ``rejected_because`` of a member that failed a certificate)."""
    settled = [m for m in members if m["class"] in ATTRACTING]
    return {"starts": members[0]["starts"] if members else 0,
            "attractors": len(settled), "reached": sum(m["count"] for m in settled),
            "elsewhere": [{"class": m["class"], "member": m["member"], "count": m["count"],
                           **{q: m.get(q) for q in ("type", "k", "direction")},
                           "because": m.get("rejected_because")}
                          for m in members if m["class"] not in ATTRACTING]}


def _approaching(rows: list[dict]) -> dict:
    """How many of an unsettled member's rows already match each settled member."""
    out: dict[str, int] = {}
    for r in rows:
        if r.get("approaching"):
            out[r["approaching"]] = out.get(r["approaching"], 0) + 1
    return out


def member_components(rows: list[dict]) -> dict:
    """The member's components (those of its first row's last window): per component the
    mean and sample standard deviation over the rows of its celerity, share and frequency;
    the frequency lattice of the means (``studies.attractors.lattice``, at the first row's
    resolution): ``type``, ``generators`` and ``combinations`` (the tones, each with its
    ``coefficients`` on the generators), ``period_s`` and ``shift_deg`` of a relative
    periodic orbit; its readable ``name`` (``classify.readable_name`` of the generators)
    and ``n_components`` (the generators)."""

    have = [Features.from_dict(r["features"]) for r in rows if r.get("features")]
    if not have:
        return {"components": [], "name": "", "n_components": None, "type": "",
                "generators": [], "combinations": []}
    comps = []
    for c in have[0].components:
        same = [next((d for d in f.components if d.key == c.key), None) for f in have]
        same = [d for d in same if d is not None]
        entry = {"k": c.k, "direction": c.direction, "aliased": c.aliased, "weak": c.weak,
                 "starts": len(same), "harmonics": [h["k"] for h in c.harmonics]}
        for key in ("celerity_m_s", "share", "frequency_hz", "amplitude_m"):
            entry[key], entry[f"{key}_sd"], _ = mean_spread([getattr(d, key) for d in same])
        comps.append(entry)
    mean = [Component(k=e["k"], direction=e["direction"], share=e["share"],
                      amplitude_m=e["amplitude_m"], frequency_hz=e["frequency_hz"],
                      celerity_m_s=e["celerity_m_s"], aliased=e["aliased"], weak=e["weak"])
            for e in comps]
    resolution = have[0].resolution_hz
    lattice = Features(tuple(mean), resolution_hz=resolution).lattice(
        rows[0].get("class") != "multi-wave")
    facts = lattice.to_dict()
    by_key = {(e["k"], e["direction"]): e for e in comps}
    named = lattice.generators
    return {"components": comps, "name": readable_name(named), "n_components": len(named),
            "resolution_hz": resolution if math.isfinite(resolution) else None,
            "type": facts["type"] if rows[0].get("class") in TYPED else "",
            "generators": [by_key[g.key] for g in named],
            "combinations": [{**{q: by_key[t.component.key][q] for q in
                                 ("k", "direction", "frequency_hz", "share", "weak")},
                              "coefficients": list(t.coefficients)} for t in lattice.tones],
            **{q: facts[q] for q in ("period_s", "shift_deg", "frame_frequency_hz")}}


def fisher_consistent(x_a: int, n_a: int, x_b: int, n_b: int) -> float:
    """Two-sided p-value of Fisher's exact test: equal shares x_a/n_a and x_b/n_b?"""
    from scipy.stats import fisher_exact

    if n_a == 0 or n_b == 0:
        return math.nan
    return float(fisher_exact([[x_a, n_a - x_a], [x_b, n_b - x_b]])[1])


def observed_order(meshes: Sequence[int | str], values: Sequence[float]) -> float:
    """p = ln(|q1 − q2| / |q2 − q3|) / ln r for three meshes of one ratio r and one element
    degree (rung labels, ``starts.parse_rung_key``); NaN otherwise."""
    if len(meshes) != 3 or not all(math.isfinite(v) for v in values):
        return math.nan
    rungs = [parse_rung_key(m) for m in meshes]
    if len({p for _, p in rungs}) != 1:
        return math.nan
    (n0, _), (n1, _), (n2, _) = rungs
    r1, r2 = n1 / n0, n2 / n1
    if abs(r1 - r2) > 1e-9 * r1 or r1 <= 1.0:
        return math.nan
    d1, d2 = abs(values[0] - values[1]), abs(values[1] - values[2])
    if d1 == 0.0 or d2 == 0.0:
        return math.nan
    return math.log(d1 / d2) / math.log(r1)


#: How far a member may move between two meshes of the ladder and still be the same
#: attractor (``features.match``): celerities move 0.3 – 2 % per mesh doubling (measured,
#: docs/attractors.md), companions' shares by up to about 10 points.
LADDER_TOLERANCES = {"celerity": 0.05, "share_rel": 0.5, "share_abs": 0.10, "fraction": 0.05}


def member_features(entry: dict):  # noqa: ANN201 - features.Features
    """The features of a member (``mesh_members`` entry): its mean components and zones, at
    its resolution (so that its lattice finds the same tones)."""

    comps = tuple(Component(k=c["k"], direction=c["direction"], share=c["share"],
                            amplitude_m=c["amplitude_m"], frequency_hz=c["frequency_hz"],
                            celerity_m_s=c["celerity_m_s"], aliased=c["aliased"],
                            weak=c["weak"]) for c in entry.get("components") or ())
    if not comps and entry.get("k") is not None:  # a row set without features
        comps = (Component(k=int(entry["k"]), direction=entry["direction"], share=1.0,
                           amplitude_m=math.nan, frequency_hz=entry.get("frequency_hz"),
                           celerity_m_s=entry.get("celerity_m_s")),)
    fr = {z: entry[f"fraction_{z}"] for z in ("separation", "stick", "slip")
          if entry.get(f"fraction_{z}") is not None and math.isfinite(entry[f"fraction_{z}"])}
    resolution = entry.get("resolution_hz")
    return Features(comps, fr, resolution_hz=math.nan if resolution is None else resolution)


def align(per_mesh: dict[int, list[dict]], tol=None, lookback: bool = False  # noqa: ANN001
          ) -> None:
    """Give every member entry its ``ladder_id`` (in place): a settled member that matches a
    settled member of the previous key (the next coarser mesh; same dominant k and
    direction, ``features.match`` with ``tol``, default ``LADDER_TOLERANCES``) takes its id;
    with ``lookback`` also one of an earlier key, the most recent first (an attractor that
    vanishes and comes back along a parameter); otherwise its own name (``@N`` added where
    that name is already taken). Other entries keep their name."""

    tol = tol or Tolerances(**LADDER_TOLERANCES)
    meshes = list(per_mesh)  # in ladder order (the caller's: by dofs)
    taken: set[str] = set()
    for i, n in enumerate(meshes):
        earlier = meshes[i - 1::-1] if lookback and i else meshes[i - 1:i] if i else []
        coarse = [e for m in earlier for e in per_mesh[m] if e["class"] in SETTLED]
        used: set[str] = set()
        for e in per_mesh[n]:
            if e["class"] not in SETTLED:
                e["ladder_id"] = e["member"]
                continue
            mine = member_features(e)
            found = next((c for c in coarse if c["ladder_id"] not in used
                          and member_features(c).dominant is not None
                          and mine.dominant is not None
                          and member_features(c).dominant.key == mine.dominant.key
                          and match(member_features(c), mine, tol)), None)
            if found is not None:
                e["ladder_id"] = found["ladder_id"]
            else:
                e["ladder_id"] = e["member"] if e["member"] not in taken else f"{e['member']}@{n}"
            used.add(e["ladder_id"])
        taken |= {e["ladder_id"] for e in per_mesh[n]}


def _changes(meshes: list[int], vals: list[float]) -> dict:
    """Values along the ladder, their successive relative differences and observed orders."""
    return {"values": vals,
            "differences": [(b - a) / abs(a) if a and math.isfinite(a) and math.isfinite(b)
                            else math.nan for a, b in zip(vals, vals[1:], strict=False)],
            "order": [observed_order(meshes[i:i + 3], vals[i:i + 3])
                      for i in range(len(meshes) - 2)]}


def coarse_observables(per_mesh: dict[int, list[dict]]) -> dict:
    """Per mesh: the distribution of the dominant component (``"k8+"``, + with the
    rotation) over the counted random starts, and the basin-weighted celerity
    Σ x_m c_m / Σ x_m over the members m with a dominant component, settled or not (x_m
    starts, c_m the dominant celerity: where each start ends, averaged over the starts);
    along the ladder: the total-variation distance ½ Σ |p_a − p_b| between successive
    distributions and the change of the weighted celerity."""
    meshes = list(per_mesh)  # in ladder order (the caller's: by dofs)
    dist, celerity = {}, {}
    for n in meshes:
        counts: dict[str, int] = {}
        total = 0
        num = den = 0.0
        for e in per_mesh[n]:
            label = (f"k{e['k']}{'+' if e['direction'] == 'rotation' else '-'}"
                     if e.get("k") else e["class"])
            counts[label] = counts.get(label, 0) + e["count"]
            total += e["count"]
            c = e.get("celerity_m_s")
            if e.get("k") and c is not None and math.isfinite(c):
                num += e["count"] * c
                den += e["count"]
        dist[n] = {k: v / total for k, v in sorted(counts.items())} if total else {}
        celerity[n] = num / den if den else math.nan
    tv = [0.5 * sum(abs(dist[a].get(k, 0.0) - dist[b].get(k, 0.0))
                    for k in set(dist[a]) | set(dist[b]))
          for a, b in zip(meshes, meshes[1:], strict=False)]
    return {"dominant_k": {str(n): dist[n] for n in meshes},
            "dominant_k_distance": tv,
            "weighted_celerity_m_s": _changes(meshes, [celerity[n] for n in meshes])}


def ladder(per_mesh: dict[int, list[dict]]) -> dict:
    """What the mesh ladder says (module docstring), from ``mesh_members`` per mesh.

    Members are matched across meshes by their features (``align``). Returns ``members``
    (per ladder id: its values per mesh, successive relative differences, observed orders,
    and the same per component: celerity and share), ``tests`` (Fisher's test per member
    and pair of successive meshes), ``sets`` (the settled members reached per mesh),
    ``stable_from`` (the smallest mesh from which that set is the same on every finer mesh
    and every share test passes; None if no such mesh short of the finest, where nothing can
    be said), ``coarse`` (``coarse_observables``), ``steps`` (``rung_steps``: the settle
    criterion per pair of successive rungs) and ``settles_from`` (the first rung from
    which every step holds: set, shares, dominant distribution and weighted celerity). A
    member reached by a single start on one mesh only changes the set: the table shows
    which.
    """
    align(per_mesh)
    meshes = list(per_mesh)  # in ladder order (the caller's: by dofs)
    names = sorted({e["ladder_id"] for es in per_mesh.values() for e in es})
    table = {n: {e["ladder_id"]: e for e in per_mesh[n]} for n in meshes}
    members = {}
    for name in names:
        present = [n for n in meshes if name in table[n]]
        entry: dict = {"meshes": present, "member": [table[n][name]["member"] for n in present],
                       "differences": {}, "order": {}, "components": {}}
        for key in ("celerity_m_s", "frequency_hz", "psi1", "psi2", "rms_amplitude_m"):
            ch = _changes(present, [table[n][name][key] for n in present])
            entry[key] = ch["values"]
            entry["differences"][key] = ch["differences"]
            entry["order"][key] = ch["order"]
        first = table[present[0]][name].get("components") or []
        for c in first:
            label = f"k{c['k']}{'+' if c['direction'] == 'rotation' else '-'}"
            at = [next((d for d in table[n][name].get("components") or []
                        if (d["k"], d["direction"]) == (c["k"], c["direction"])), None)
                  for n in present]
            entry["components"][label] = {
                q: _changes(present, [d[q] if d else math.nan for d in at])
                for q in ("celerity_m_s", "share")}
        members[name] = entry
    tests = []
    for a, b in zip(meshes, meshes[1:], strict=False):
        na = per_mesh[a][0]["starts"] if per_mesh[a] else 0
        nb = per_mesh[b][0]["starts"] if per_mesh[b] else 0
        for name in names:
            xa = table[a][name]["count"] if name in table[a] else 0
            xb = table[b][name]["count"] if name in table[b] else 0
            p = fisher_consistent(xa, na, xb, nb)
            tests.append({"member": name, "mesh_a": a, "mesh_b": b, "count_a": xa,
                          "starts_a": na, "count_b": xb, "starts_b": nb, "p_value": p,
                          "consistent": bool(p >= ALPHA) if math.isfinite(p) else None})
    sets = {n: sorted(m for m, e in table[n].items() if e["class"] in ATTRACTING)
            for n in meshes}
    stable_from = None
    for i, n in enumerate(meshes[:-1]):
        finer = meshes[i:]
        same = all(sets[m] == sets[n] for m in finer)
        passed = all(t["consistent"] is not False for t in tests if t["mesh_a"] in finer)
        if same and passed:
            stable_from = n
            break
    coarse = coarse_observables(per_mesh)
    steps = rung_steps(meshes, sets, tests, coarse)
    return {"members": members, "tests": tests, "sets": sets, "stable_from": stable_from,
            "coarse": coarse, "steps": steps, "settles_from": settles_from(meshes, steps)}


def rung_steps(meshes: list, sets: dict, tests: list[dict], coarse: dict) -> list[dict]:
    """The settle criterion per pair of successive rungs (a, b) of the ladder: the four
    things that must stay the same, each with its number and verdict:
    * ``same_set``: the same attractors (matched by their features, ``align``), with those
      ``added`` at b and ``lost`` from a;
    * ``shares_consistent``: every member's share passes Fisher's exact test (p ≥ 0.05;
      ``fisher_min_p`` the smallest p);
    * ``dominant_tv``: the total-variation distance of the dominant-component distributions
      below ``SETTLE_TV`` = 0.1;
    * ``celerity_change``: the basin-weighted celerity's relative change |c_b − c_a| / |c_a|
      at most ``SETTLE_CELERITY`` = 1 % (0 where neither rung has a travelling member).

    ``holds``: all four."""
    tv = coarse["dominant_k_distance"]
    cel = coarse["weighted_celerity_m_s"]["values"]
    out = []
    for i, (a, b) in enumerate(zip(meshes, meshes[1:], strict=False)):
        pair = [t for t in tests if t["mesh_a"] == a]
        ps = [t["p_value"] for t in pair if math.isfinite(t["p_value"])]
        consistent = all(t["consistent"] is not False for t in pair)
        ca, cb = cel[i], cel[i + 1]
        if math.isfinite(ca) and math.isfinite(cb):
            change = abs(cb - ca) / abs(ca) if ca else math.inf
        else:
            change = 0.0 if not (math.isfinite(ca) or math.isfinite(cb)) else math.inf
        same = sets[a] == sets[b]
        out.append({"from": a, "to": b, "same_set": same,
                    "added": sorted(set(sets[b]) - set(sets[a])),
                    "lost": sorted(set(sets[a]) - set(sets[b])),
                    "shares_consistent": consistent,
                    "fisher_min_p": min(ps) if ps else math.nan,
                    "dominant_tv": tv[i], "celerity_change": change,
                    "holds": bool(same and consistent and tv[i] < SETTLE_TV
                                  and change <= SETTLE_CELERITY)})
    return out


def settles_from(meshes: list, steps: list[dict]) -> object | None:
    """The first rung of the ladder from which every later step holds (``rung_steps``), so
    that the answer stays the same on every finer rung; None where no rung short of the
    finest qualifies (the last step fails) or the ladder has one rung."""
    first = None
    for i in range(len(steps) - 1, -1, -1):
        if not steps[i]["holds"]:
            break
        first = meshes[i]
    return first
