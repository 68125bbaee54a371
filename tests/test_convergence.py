"""Convergence of the FE limit cycle (issue 13, docs/convergence.md), at CI sizes.

What the study established for Figure-3 physics with Kelvin-Voigt eta = 2 % at 1.6 kHz,
beta2 = 1/2, from the mode-4 seed: the same member of the wave family (k = 12, against the
rotation, ~1.7 kHz) is selected at N = 132, 264 and 528; the time-step error shrinks when dt is
halved (N = 264: f 1691.5 / 1688.3 / 1686.3 Hz, separation 0.745 / 0.762 / 0.768 at dt = 0.9 /
0.45 / 0.225 dt_crit); under mesh refinement the differences are irregular up to N = 528
(f: 13.0, 16.8 Hz) and shrink only on the last doubling (7.9 Hz at N = 528 -> 1056), so a
CI-sized N = 66/132/264 triple shows no asymptotic ratio (N = 66 even selects k = 4). The
tests pin the member and the size of the differences, not a rate the small meshes lack.
"""

import math

import pytest

from studies.convergence import richardson


def test_richardson_recovers_order_and_limit():
    """q = 3 + 0.5 h^p at h = 1, 1/2, 1/4: order p and limit 3 exactly (to round-off); a
    sequence whose differences change sign claims no order."""
    for p in (1.0, 2.0, 0.5):
        qs = [3 + 0.5 * h**p for h in (1.0, 0.5, 0.25)]
        r = richardson([1, 2, 4], qs, 0.0)
        assert r["order"] == pytest.approx(p, rel=1e-10)
        assert r["value"] == pytest.approx(3.0, rel=1e-12)
    r = richardson([1, 2, 4], [1.0, 1.2, 1.1], 0.01)
    assert r["order"] is None and r["err"] == pytest.approx(0.11)


pytest.importorskip("dolfinx")

from studies.convergence import run_case  # noqa: E402


def case(n: int, frac: float = 0.9) -> dict:
    return dict(phys="fig3", damped=True, n=n, seed="mode4", beta2=0.5, frac=frac,
                key=f"test-N{n}-fr{frac}")


def test_damped_figure3_selects_the_same_wave_on_two_meshes():
    """N = 132 and 264 (0.3 s each, ~40 s): both k = 12 against the rotation, on a limit cycle.

    Tolerances: the study measured 0.77 % in frequency, 0.023 in separation and 15 % in RMS
    amplitude between these meshes (docs/convergence.md); the bounds are 2x that, so a change
    of the selected member (k = 4 at N = 66: -8 % in f, +0.14 in stick) or of the branch
    fails, while round-off amplified by the transient does not."""
    a, b = run_case(case(132)), run_case(case(264))
    for r in (a, b):
        assert r["k"] == 12 and r["celerity_m_s"] < 0 and r["limit_cycle"]
        assert r["regime"] == "stick-slip-separation"
    assert abs(a["frequency_hz"] / b["frequency_hz"] - 1) < 0.016
    for z in ("sep", "stick", "slip"):
        assert abs(a[z] - b[z]) < 0.05
    assert abs(a["amp_rms_m"] / b["amp_rms_m"] - 1) < 0.3
    # celerity = 2 pi f R / k: the analysis' celerity agrees with the probe frequency
    assert abs(b["celerity_m_s"]) == pytest.approx(2 * math.pi * b["frequency_hz"] / 12,
                                                   rel=0.01)


@pytest.mark.slow
def test_halving_dt_keeps_the_member_and_moves_it_little():
    """N = 264, dt = 0.9 and 0.45 dt_crit (~1.5 min): the same member (k = 12) and a small
    time-step error. Measured: f 1691.5 -> 1688.3 Hz (0.19 %), separation 0.745 -> 0.762;
    halving once more (0.225) moves them by 2.0 Hz and 0.006, so the differences shrink
    (time convergence; the study, not this test, shows the third point). Bounds: 2-3x the
    measured change. At N = 132 the same halving selects another member (k = 4), which is
    why this test needs N = 264."""
    a, b = run_case(case(264, 0.9)), run_case(case(264, 0.45))
    assert a["k"] == b["k"] == 12
    assert abs(a["frequency_hz"] / b["frequency_hz"] - 1) < 0.005
    for z in ("sep", "stick", "slip"):
        assert abs(a[z] - b[z]) < 0.04
