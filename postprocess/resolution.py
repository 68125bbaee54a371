"""Can the samples resolve the wave they report? The per-step probe against their Nyquist.

The wave analysis (``postprocess.analysis``) reads the inner-circle samples, taken every
``output.sample_interval``. A wave of frequency f is seen correctly only if

    f < f_N = 1 / (2 Δt_s)            (Nyquist; Δt_s the samples' spacing)

and above f_N it is aliased: the samples show a slower wave, often of another mode and
direction, that does not exist. The probes (``output.probes_deg``) record u_r at their node
every time step, so their dominant frequency f_p over the analysis window is the wave's
frequency seen at one point (k |D| / (2π R) for a travelling wave of mode k and celerity
D). A run with f_p > f_N is flagged; its mode, celerity and frequency are not the wave's.
"""

from __future__ import annotations

import numpy as np

from stickslip.solver.field_output import expected_period


def dominant_frequency(t: np.ndarray, x: np.ndarray) -> float:
    """The frequency (Hz) of the largest peak of |FFT(x - mean x)| (Hann window), without
    the zero frequency; ``t`` evenly spaced. NaN for fewer than 4 points."""
    if t.size < 4:
        return float("nan")
    x = (x - x.mean()) * np.hanning(x.size)
    spectrum = np.abs(np.fft.rfft(x))
    freqs = np.fft.rfftfreq(x.size, float(np.median(np.diff(t))))
    return float(freqs[1 + int(np.argmax(spectrum[1:]))])


def sampling_check(sample_t: np.ndarray, probes: dict | None, summary: dict) -> dict:
    """``{"probe_frequency_hz", "nyquist_hz"}`` plus a ``warning`` where the probe's wave is
    above the samples' Nyquist frequency; ``{}`` when there is nothing to check (no probe, no
    wave, fewer than 4 samples).

    ``probes``: ``probe_t``, ``probe_data`` (probe, step, [u_r, u_theta, v_r, v_theta]) of
    :class:`solver.ensemble_observers.BatchRecorder`; ``summary``: the analysed run (its ``regime``,
    ``amplitude_m``, ``frequency_hz`` and ``analysis_window_s``).
    """
    if not probes or "probe_t" not in probes or sample_t.size < 4 or summary.get("regime") in (None,
                                                                         "steady-sliding"):
        return {}
    t, data = probes["probe_t"], probes["probe_data"]
    if t.size < 4 or data.shape[0] == 0:
        return {}
    window = summary.get("analysis_window_s") or (t[-1] - t[0]) / 2
    keep = t >= t[-1] - window
    u_r = data[0, : t.size, 0][keep]
    # a probe that hardly moves (a node inside a contact zone all along) says nothing
    if np.ptp(u_r) < 0.02 * float(summary.get("amplitude_m") or 0.0):
        return {}
    f_probe = dominant_frequency(t[keep], u_r)
    f_nyquist = 0.5 / float(np.median(np.diff(sample_t)))
    out = {"probe_frequency_hz": f_probe, "nyquist_hz": f_nyquist}
    if f_probe > f_nyquist:
        reported = float(summary.get("frequency_hz") or 0.0)
        out["warning"] = (
            f"aliased: the probe oscillates at {f_probe:.4g} Hz, above the samples' Nyquist "
            f"frequency {f_nyquist:.4g} Hz, so the reported wave ({reported:.4g} Hz) is not "
            f"the run's; sample faster: output.sample_interval < {0.5 / f_probe:.3g} s")
    return out


def sampling_problem(scene, override: str) -> str | None:  # noqa: ANN001
    """Why the samples of ``scene`` cannot resolve the wave it is expected to end on (one
    line with the fix; ``override`` names how to run it anyway), or None: the expected wave's
    frequency at or above the samples' Nyquist frequency 1 / (2 output.sample_interval).
    Without friction nothing flutters: None.

    The expected wave's frequency is found without an FE eigensolve: 1 / the period of the
    reduced model's flutter mode k = ``initial.mode`` (paper eq. [2];
    ``solver.field_output.expected_period``, the same estimate that sizes the field-output
    window)."""
    if scene.loading.f <= 0.0 or scene.loading.omega == 0.0:
        return None
    try:
        f_wave = abs(1.0 / expected_period(scene))
    except (ArithmeticError, ValueError):  # no reduced-model estimate: nothing to refuse
        return None
    dt_s = scene.output.sample_interval
    f_nyquist = 0.5 / dt_s
    if f_wave < f_nyquist:
        return None
    return (f"output.sample_interval = {dt_s:g} s samples up to {f_nyquist:.4g} Hz "
            f"(Nyquist, 1/(2 output.sample_interval)), below the expected wave's "
            f"{f_wave:.4g} Hz (the reduced model's flutter mode k = initial.mode = "
            f"{max(1, scene.initial.mode)}, eq. [2]): the samples would alias it; set "
            f"output.sample_interval < {0.5 / f_wave:.3g} s, or {override} to run anyway")
