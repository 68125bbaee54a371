"""A run's own signals: the every-step probe histories as a table, their spectrum and their
spectrogram, with the frequencies other analyses predict marked on them.

The probes (``output.probes_deg``) record u_r, u_θ, v_r, v_θ of the contact node nearest each
angle at every time step (``solver.observers.ProbeChoice``), so their spectra are free of the
aliasing that the sparser field samples can have. A point fixed in space sees a wave of mode k
and angular speed c at f = k |c| / (2π) (``postprocess.analysis``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from stickslip.solver.atomic import atomic_write

#: The four quantities of each probe, in ``samples.npz``'s ``probe_data[:, :, j]`` order, with
#: their units.
QUANTITIES = (("u_r", "m"), ("u_theta", "m"), ("v_r", "m/s"), ("v_theta", "m/s"))


def probe_table(samples: Mapping[str, np.ndarray]) -> tuple[list[str], np.ndarray]:
    """The probes' time histories as (column names, rows): ``t_s``, then for each probe angle
    a the columns ``u_r@a_m``, ``u_theta@a_m``, ``v_r@a_m_s``, ``v_theta@a_m_s``."""
    t = np.asarray(samples["probe_t"], dtype=float)
    data = np.asarray(samples["probe_data"], dtype=float)  # (probes, steps, 4)
    angles = np.asarray(samples["probe_deg"], dtype=float)
    names = ["t_s"]
    columns = [t]
    for i, angle in enumerate(angles):
        for j, (name, unit) in enumerate(QUANTITIES):
            names.append(f"{name}@{angle:g}deg_{unit.replace('/', '_')}")
            columns.append(data[i, :, j])
    return names, np.column_stack(columns)


def write_probe_csv(samples: Mapping[str, np.ndarray], path: str | Path) -> int:
    """Write ``probe_table`` as CSV (atomically: a reader never sees half a file); returns
    the number of rows."""
    names, rows = probe_table(samples)
    atomic_write(path, lambda fh: np.savetxt(fh, rows, delimiter=",", fmt="%.10g",
                                             header=",".join(names), comments=""))
    return rows.shape[0]


def spectrum(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum of an evenly sampled signal (mean removed, Hann window,
    scaled so that A cos(2π f t) at a bin's frequency reads A)."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = x.size
    dt = float(np.mean(np.diff(t)))
    window = np.hanning(n)
    amplitude = 2.0 * np.abs(np.fft.rfft(x * window)) / window.sum()
    return np.fft.rfftfreq(n, dt), amplitude


def signal_figure(samples: Mapping[str, np.ndarray], title: str,
                  marks: Mapping[str, Sequence[float]], probe: int = 0,
                  quantity: str = "u_r") -> Any:
    """Spectrogram (top) and spectrum (bottom) of one probe's ``quantity``; each entry of
    ``marks`` (a label and its frequencies in Hz, sign ignored) is drawn as dashed lines of
    one colour on both panels."""
    import matplotlib.pyplot as plt

    j = [q for q, _ in QUANTITIES].index(quantity)
    t = np.asarray(samples["probe_t"], dtype=float)
    x = np.asarray(samples["probe_data"], dtype=float)[probe, :, j]
    angle = float(np.asarray(samples["probe_deg"])[probe])
    freqs, amplitude = spectrum(t, x)
    fs = 1.0 / float(np.mean(np.diff(t)))
    peak = float(freqs[int(np.argmax(amplitude[1:])) + 1])
    highest = max([peak, *(abs(float(f)) for fl in marks.values() for f in fl)])
    top = min(fs / 2.0, 2.0 * highest)  # the peak and every mark, not the empty band above
    fig, (ax_s, ax_f) = plt.subplots(2, 1, figsize=(9, 7), constrained_layout=True)
    nfft = int(2 ** np.clip(np.floor(np.log2(t.size / 8)), 6, 14))
    ax_s.specgram(x - x.mean(), NFFT=nfft, Fs=fs, noverlap=nfft // 2, xextent=(t[0], t[-1]),
                  cmap="viridis")
    ax_s.set(xlabel="t (s)", ylabel="frequency (Hz)", ylim=(0.0, top),
             title=f"spectrogram of {quantity} at the probe θ = {angle:g}°")
    ax_f.semilogy(freqs[1:], amplitude[1:], color="k", lw=0.8)
    ax_f.set(xlabel="frequency (Hz)", ylabel=f"amplitude of {quantity}", xlim=(0.0, top),
             title=f"spectrum over the whole record ({t.size} steps)")
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for (label, fl), colour in zip(marks.items(), colours, strict=False):
        for i, f in enumerate(sorted({abs(float(v)) for v in fl})):
            for ax in (ax_s, ax_f):
                line = ax.axvline if ax is ax_f else ax.axhline
                line(f, color=colour, ls="--", lw=0.9,
                     label=label if (i == 0 and ax is ax_f) else None)
    if marks:
        ax_f.legend(fontsize=8, loc="upper right")
    fig.suptitle(title, fontsize=9)
    return fig
