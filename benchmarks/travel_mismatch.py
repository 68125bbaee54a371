"""Is a transient's limit cycle a rigidly turning wave? (why the travel
solver finds no wave near the transient's speed at some N;
archive/travel/travelling_waves_history.md 2d).

``./dev python3 benchmarks/travel_mismatch.py RUN_DIR [RUN_DIR ...]``

A travelling wave u(θ, t) = W(θ − ω0 t) is what ``stickslip travel`` solves for. On the
transient's inner-circle samples over its analysis window (last third of the run), with ω0 the
measured angular speed:

* ``frame_spread``: each sample shifted back by ω0 (t − t_end) (exact Fourier shift) into the
  wave's frame; RMS deviation from their mean over the RMS of the mean (axisymmetric part
  excluded), for u_r and u_θ: 0 for a rigidly turning wave;
* ``rate_mismatch``: at the last sample, ‖v − (−ω0 ∂_φ W)‖ / ‖v‖ at the contact nodes, v the
  transient's nodal velocity, ∂_φ spectral (``_spectral``) or BDF2 upwind (the travel solver's
  material rate, ``_bdf2``).
One JSON line per run.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np


def rigidity(run_dir: Path) -> dict:
    """frame_spread and rate_mismatch of one run directory (module doc)."""
    from stickslip.postprocess.analysis import analyse_run, load_run
    from stickslip.studies.travel.newton import material_rate

    run = load_run(run_dir)
    s = run.samples
    o = np.argsort(s["theta"])
    n = o.size
    wave = analyse_run(run)
    om = wave.angular_speed_rad_s
    k = np.fft.rfftfreq(n, 1.0 / n)
    sel = s["t"] >= s["t"][-1] - (s["t"][-1] - s["t"][0]) / 3.0
    rec = {"run": str(run_dir), "n": n, "mode": wave.mode, "omega": om,
           "samples": int(sel.sum())}
    for comp in ("u_r", "u_theta"):
        F = np.fft.rfft(s[comp][sel][:, o], axis=1)
        F *= np.exp(1j * k[None, :] * om * (s["t"][sel] - s["t"][-1])[:, None])
        F[:, 0] = 0.0  # the axisymmetric part (steady sliding) is excluded
        back = np.fft.irfft(F, n, axis=1)
        mean = back.mean(axis=0)
        rec[f"frame_spread_{comp}"] = float(np.sqrt(np.mean((back - mean) ** 2))
                                            / np.sqrt(np.mean(mean**2)))
    W = np.concatenate([s["u_r"][-1][o], s["u_theta"][-1][o]])
    v = np.concatenate([s["v_r"][-1][o], s["v_theta"][-1][o]])
    spec = np.concatenate([np.fft.irfft(1j * k * np.fft.rfft(W[i * n:(i + 1) * n]), n)
                           for i in (0, 1)])
    bdf2 = np.concatenate([material_rate(W[:n], om), material_rate(W[n:], om)])
    rec["rate_mismatch_spectral"] = float(np.linalg.norm(v + om * spec) / np.linalg.norm(v))
    rec["rate_mismatch_bdf2"] = float(np.linalg.norm(v - bdf2) / np.linalg.norm(v))
    return rec


def main() -> None:
    for run_dir in map(Path, sys.argv[1:]):
        print(json.dumps(rigidity(run_dir)), flush=True)


if __name__ == "__main__":
    main()
