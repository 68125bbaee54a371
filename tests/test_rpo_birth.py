"""Where a two-wave state is born (``studies.rpo.birth``): the sideband's growth rate and
frequencies read from samples.

A manufactured state of two travelling waves on N = 36 nodes, u_r = cos(3θ − 2π f_w t) +
ε e^{σt} cos(2θ − 2π f_s t), is what a rigid wave k = 3 with a growing (σ > 0) or decaying
(σ < 0) sideband k = 2 looks like on the contact circle. ``sideband_fit`` must return σ, the
sideband's lab frequency f_s and the shares ε e^{σt} exactly (the discrete Fourier sums of a
pure harmonic on the uniform circle are exact: round-off only, asserted to 1e-9 relative),
and the frame frequency f_s − (2/3) f_w.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from stickslip.studies.rpo.birth import mode_series, sideband_fit, sideband_row


def _samples(sigma: float, eps: float = 0.05, f_w: float = -1638.4, f_s: float = -1567.6):
    n, t = 36, np.linspace(0.0, 1.0, 10001)  # 10 kHz, as output.sample_interval
    theta = 2.0 * math.pi * np.arange(n) / n
    u_r = (np.cos(3.0 * theta[None, :] - 2.0 * math.pi * f_w * t[:, None])
           + eps * np.exp(sigma * t)[:, None]
           * np.cos(2.0 * theta[None, :] - 2.0 * math.pi * f_s * t[:, None]))
    return {"t": t, "theta": theta, "u_r": u_r}, (f_w, f_s, eps)


@pytest.mark.parametrize("sigma", [-0.642, 0.345])
def test_sideband_fit_returns_the_manufactured_rate_frequency_and_shares(sigma):
    samples, (f_w, f_s, eps) = _samples(sigma)
    fit = sideband_fit(samples, 2, 3, fit_fraction=0.5)
    assert fit.sigma == pytest.approx(sigma, rel=1e-9)
    assert fit.frequency_hz == pytest.approx(f_s, rel=1e-9)
    assert fit.misfit < 1e-9
    assert (fit.t0, fit.t1) == (0.5, 1.0)
    # the shares are means over the first and last twentieth of the fit window
    t = samples["t"][samples["t"] >= 0.5]
    edge = t.size // 20
    assert fit.share_start == pytest.approx(eps * np.exp(sigma * t[:edge]).mean(), rel=1e-9)
    assert fit.share_end == pytest.approx(eps * np.exp(sigma * t[-edge:]).mean(), rel=1e-9)
    # the linear range only: the samples whose share is below its value at t = 0.75 s, the
    # half of the window at the small end (its later half decaying, its earlier growing)
    middle = eps * math.exp(0.75 * sigma)
    low = sideband_fit(samples, 2, 3, fit_fraction=0.5, below=middle)
    assert low.sigma == pytest.approx(sigma, rel=1e-9)
    assert max(low.share_start, low.share_end) < middle
    assert low.t1 - low.t0 == pytest.approx(0.25, abs=2e-4)
    assert (low.t0 > 0.74) == (sigma < 0.0)
    row = sideband_row(samples, 67.5, 1e-5, 3, 2)
    assert row["wave_hz"] == pytest.approx(f_w, rel=1e-9)
    assert row["frame_hz"] == pytest.approx(f_s - 2.0 / 3.0 * f_w, rel=1e-9)


def test_mode_series_is_half_the_amplitude_of_a_cosine():
    samples, _ = _samples(0.0, eps=0.0)
    _, a3 = mode_series(samples, 3)
    np.testing.assert_allclose(np.abs(a3), 0.5, rtol=1e-12)
    _, a2 = mode_series(samples, 2)
    assert np.abs(a2).max() < 1e-12  # phases up to 2π·1638 Hz·1 s: round-off ~1e-14


def test_a_sideband_that_vanishes_is_refused():
    samples, _ = _samples(0.0, eps=0.0)
    with pytest.raises(ValueError, match="sideband k = 2"):
        sideband_fit(samples, 2, 3)


@pytest.mark.parametrize(("sigma", "verdict"), [(-0.642, "decays"), (0.375, "grows"),
                                                 (0.0, "holds")])
def test_the_census_sideband_test_tells_a_transient_from_a_torus(tmp_path, sigma, verdict):
    """Two starts of a member k = 3 carrying k = 2 whose sideband decays, grows or holds:
    the census's ``sideband_test`` reads σ over each start's last leg (its last third), and
    a sideband that decays or grows beyond 0.2 1/s fails the member (``failures``)."""
    from stickslip.studies.attractors.certify import failures, sideband_line, sideband_test

    rows = []
    for start in range(2):
        samples, _ = _samples(sigma, eps=0.05 * (1 + start))
        samples["u_theta"] = np.zeros_like(samples["u_r"])
        run_dir = tmp_path / f"start-{start}"
        run_dir.mkdir()
        np.savez(run_dir / "samples.npz", **samples)
        rows.append({"run_dir": str(run_dir)})
    side = sideband_test(rows, 3, 2)
    assert side["verdict"] == verdict
    assert side["sigma_per_start"] == pytest.approx([sigma, sigma], abs=1e-9)
    assert side["misfit"] < 1e-9
    why = failures({"sideband": side})
    assert (why == []) == (verdict == "holds")
    assert f"k = 2 sideband σ = {sigma:+.2f} 1/s" in sideband_line(side)


def test_a_sideband_test_without_samples_is_no_verdict(tmp_path):
    from stickslip.studies.attractors.certify import failures, sideband_test

    side = sideband_test([{"run_dir": str(tmp_path)}], 3, 2)
    assert side["verdict"] == "unclear" and "no samples" in side["message"]
    assert failures({"sideband": side}) == []
