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

Z95 = 1.959963984540054  # the 97.5 % quantile of the standard normal
#: Values averaged per member (row keys of ``attractors.csv``).
VALUE_KEYS = ("celerity_m_s", "frequency_hz", "fraction_separation", "fraction_stick",
              "fraction_slip", "psi1", "psi2", "amplitude_m", "rms_amplitude_m")
#: The classes counted in a basin-share denominator (pending/interrupted starts are not).
COUNTED = ("wave", "modulated", "unsettled", "steady-sliding", "diverged", "failed")
ALPHA = 0.05
#: The classes whose members make up "the set of attractors" of a mesh (settled cycles).
SETTLED = ("wave", "modulated")


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


def mesh_members(rows: list[dict]) -> list[dict]:
    """Per member of one mesh's random starts: count, share, Wilson interval, values."""
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
                 "share_lo": lo, "share_hi": hi, "seeds": [r["seed"] for r in group]}
        for key in VALUE_KEYS:
            m, sd, _ = mean_spread([r[key] for r in group])
            entry[key] = m
            entry[f"{key}_sd"] = sd
        out.append(entry)
    out.sort(key=lambda e: (-e["count"], e["member"]))
    return out


def fisher_consistent(x_a: int, n_a: int, x_b: int, n_b: int) -> float:
    """Two-sided p-value of Fisher's exact test: equal shares x_a/n_a and x_b/n_b?"""
    from scipy.stats import fisher_exact

    if n_a == 0 or n_b == 0:
        return math.nan
    return float(fisher_exact([[x_a, n_a - x_a], [x_b, n_b - x_b]])[1])


def observed_order(meshes: Sequence[int], values: Sequence[float]) -> float:
    """p = ln(|q1 − q2| / |q2 − q3|) / ln r for three meshes of one ratio r; NaN otherwise."""
    if len(meshes) != 3 or not all(math.isfinite(v) for v in values):
        return math.nan
    r1, r2 = meshes[1] / meshes[0], meshes[2] / meshes[1]
    if abs(r1 - r2) > 1e-9 * r1 or r1 <= 1.0:
        return math.nan
    d1, d2 = abs(values[0] - values[1]), abs(values[1] - values[2])
    if d1 == 0.0 or d2 == 0.0:
        return math.nan
    return math.log(d1 / d2) / math.log(r1)


def ladder(per_mesh: dict[int, list[dict]]) -> dict:
    """What the mesh ladder says (module docstring), from ``mesh_members`` per mesh.

    Returns ``members`` (per member: its values per mesh, successive relative differences,
    observed orders), ``tests`` (Fisher's test per member and pair of successive meshes),
    ``sets`` (the settled members, waves and modulated cycles, reached per mesh) and
    ``stable_from`` (the smallest mesh from which that set is the same on every finer mesh
    and every share test passes; None if no such mesh short of the finest, where nothing can
    be said). A member reached by a single start on one mesh only changes the set: the table
    shows which.
    """
    meshes = sorted(per_mesh)
    names = sorted({e["member"] for es in per_mesh.values() for e in es})
    table = {n: {e["member"]: e for e in per_mesh[n]} for n in meshes}
    members = {}
    for name in names:
        present = [n for n in meshes if name in table[n]]
        entry: dict = {"meshes": present, "differences": {}, "order": {}}
        for key in ("celerity_m_s", "frequency_hz", "psi1", "psi2", "rms_amplitude_m"):
            vals = [table[n][name][key] for n in present]
            entry[key] = vals
            entry["differences"][key] = [
                (b - a) / abs(a) if a and math.isfinite(a) and math.isfinite(b) else math.nan
                for a, b in zip(vals, vals[1:], strict=False)]
            orders = [observed_order(present[i:i + 3], vals[i:i + 3])
                      for i in range(len(present) - 2)]
            entry["order"][key] = orders
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
    sets = {n: sorted(m for m, e in table[n].items() if e["class"] in SETTLED)
            for n in meshes}
    stable_from = None
    for i, n in enumerate(meshes[:-1]):
        finer = meshes[i:]
        same = all(sets[m] == sets[n] for m in finer)
        passed = all(t["consistent"] is not False for t in tests if t["mesh_a"] in finer)
        if same and passed:
            stable_from = n
            break
    return {"members": members, "tests": tests, "sets": sets, "stable_from": stable_from}
