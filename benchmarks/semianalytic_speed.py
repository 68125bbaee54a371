"""Timings of the semi-analytical solver against their targets.

Run: ``python3 benchmarks/semianalytic_speed.py`` (repository root on PYTHONPATH).
Targets: one Newton solve (continuation step) < 50 ms; full multistart search at one
parameter set < 5 s; continuation over 1000 Ω values < 30 s.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical  # noqa: E402
from stickslip.semianalytic.waves import (  # noqa: E402
    continuation_omega,
    find_waves,
    refine_wave,
    stick_slip_separation_waves,
    stick_slip_waves,
)

warnings.simplefilter("ignore", RuntimeWarning)


def _co(omega: float):  # noqa: ANN202
    return coefficients(0.3, 1.25, gamma_from_physical(1000.0, 1.0, omega))


def _best_of(fun, n: int) -> float:  # noqa: ANN001
    best = np.inf
    for _ in range(n):
        t0 = time.perf_counter()
        fun()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> int:
    co = _co(40.0)
    ss = stick_slip_waves(co, 0.7, 4, 0.001)[0]
    sss = stick_slip_separation_waves(co, 0.7, 4, 0.001, junction="impact")[0]
    co2 = _co(40.04)
    rows = []
    t = _best_of(lambda: refine_wave(ss, co2), 20)
    rows.append(("Newton step, stick-slip (incl. 2000-pt admissibility check)", t, 0.050))
    t = _best_of(lambda: refine_wave(sss, co2), 20)
    rows.append(("Newton step, stick-slip-separation (incl. check)", t, 0.050))
    t = _best_of(lambda: find_waves(co, 0.7, 4, 0.001), 3)
    rows.append(("multistart find_waves, Figure-1 parameters (both kinds, 2 closures)", t, 5.0))
    t = _best_of(lambda: find_waves(_co(100.0), 1.0, 8, 0.005), 3)
    rows.append(("multistart find_waves, stick-slip example (k = 8)", t, 5.0))
    omegas = np.linspace(10.0, 60.0, 1000)
    t0 = time.perf_counter()
    branch = continuation_omega(ss, omegas)
    t = time.perf_counter() - t0
    n_ok = sum(w is not None for w in branch)
    n_adm = sum(bool(w and w.admissible) for w in branch)
    rows.append(
        (
            f"continuation 1000 Ω in [10, 60] (stick-slip; {n_ok} converged, {n_adm} admissible)",
            t,
            30.0,
        )
    )
    omegas = np.linspace(40.0, 41.0, 1000)
    t0 = time.perf_counter()
    branch = continuation_omega(sss, omegas)
    t = time.perf_counter() - t0
    n_ok = sum(w is not None for w in branch)
    rows.append(
        (f"continuation 1000 Ω in [40, 41] (separation candidate; {n_ok} converged)", t, 30.0)
    )
    width = max(len(r[0]) for r in rows)
    print(f"{'case':<{width}}  {'measured':>10}  {'target':>8}  ok")
    fail = 0
    for name, t, target in rows:
        ok = t < target
        fail += not ok
        print(
            f"{name:<{width}}  {t * 1e3:>8.1f}ms  {target * 1e3:>6.0f}ms  {'yes' if ok else 'NO'}"
        )
    return 1 if fail else 0


if __name__ == "__main__":
    raise SystemExit(main())
