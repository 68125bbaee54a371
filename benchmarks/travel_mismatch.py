"""How far a transient's last sample is from a solution of the wave-frame FE equations.

``./dev python3 benchmarks/travel_mismatch.py RUN_DIR [RUN_DIR ...]`` (issue 14, item 3: why the
travel solver finds no wave near the transient's speed at some N; docs/travelling_waves.md 2d).

For the last sample (W = (u_r, u_θ) at the N contact nodes, the contact forces λ_tr = (r_r, r_θ)
the transient applied, its nodal velocity v) and the measured angular speed ω0, with the run's own
mesh and Kelvin–Voigt τ:

* ``force_mismatch``: ‖S(ω0) W − λ_tr‖ / ‖λ_tr‖, S the condensed wave-frame operator, for the
  consistent G and the vertex-rule ("lumped") G: 0 if the sample is a travelling wave of the
  wave-frame FE equations with the transient's forces;
* ``frame_spread``: the samples of the analysis window (last third of the run) shifted back by
  ω0 t (exact Fourier shift) to the wave frame: RMS deviation from their mean over the RMS of
  the mean's deviation from axisymmetry, for u_r and u_θ; 0 for a rigidly turning wave;
* ``rate_mismatch``: ‖v − (−ω0 ∂_φ W)‖ / ‖v‖ at the contact nodes (BDF2 upwind ∂_φ, the travel
  solver's material rate, and a centred spectral ∂_φ): 0 if the sample moves as a rigid wave.
One JSON line per run.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np


def main() -> None:
    from postprocess.analysis import analyse_run, load_run
    from solver.scene import load_scene
    from studies.travel import driver as D
    from studies.travel.newton import material_rate

    for run_dir in map(Path, sys.argv[1:]):
        scene = load_scene(str(run_dir / "scene.toml"), [])
        run = load_run(run_dir)
        s = run.samples
        o = np.argsort(s["theta"])
        W = np.concatenate([s["u_r"][-1][o], s["u_theta"][-1][o]])
        lam_tr = np.concatenate([s["r_r"][-1][o], s["r_theta"][-1][o]])
        v = np.concatenate([s["v_r"][-1][o], s["v_theta"][-1][o]])
        om = analyse_run(run).angular_speed_rad_s
        n = o.size
        k = np.fft.rfftfreq(n, 1.0 / n)
        spec = np.concatenate([np.fft.irfft(1j * k * np.fft.rfft(W[i * n:(i + 1) * n]), n)
                               for i in (0, 1)])
        rate_bdf2 = np.concatenate([material_rate(W[:n], om), material_rate(W[n:], om)])
        sel = s["t"] >= s["t"][-1] - (s["t"][-1] - s["t"][0]) / 3.0
        spread = {}
        for comp in ("u_r", "u_theta"):
            F = np.fft.rfft(s[comp][sel][:, o], axis=1)
            F *= np.exp(1j * k[None, :] * om * (s["t"][sel] - s["t"][-1])[:, None])
            F[:, 0] = 0.0  # axisymmetric part (steady sliding) excluded
            back = np.fft.irfft(F, n, axis=1)
            mean = back.mean(axis=0)
            spread[comp] = float(np.sqrt(np.mean((back - mean) ** 2)) / np.sqrt(np.mean(mean**2)))
        rec = {"run": str(run_dir), "frame_spread_u_r": spread["u_r"],
               "frame_spread_u_theta": spread["u_theta"], "n": n, "omega": om, "celerity_m_s": om * scene.geometry.R,
               "rate_mismatch_bdf2": float(np.linalg.norm(v - rate_bdf2) / np.linalg.norm(v)),
               "rate_mismatch_spectral": float(np.linalg.norm(v + om * spec)
                                               / np.linalg.norm(v))}
        for lumped in (False, True):
            st = D.setup(scene, float(scene.damping.tau), lumped=lumped)
            S, _ = st.prob.stiffness(om, False)
            lam = S @ W
            # sign convention of the stored forces: take the one that matches (reported)
            errs = {sg: float(np.linalg.norm(lam - sg * lam_tr) / np.linalg.norm(lam_tr))
                    for sg in (1.0, -1.0)}
            sg = min(errs, key=errs.get)
            key = "lumped" if lumped else "consistent"
            rec[f"force_mismatch_{key}"] = errs[sg]
            rec["force_sign"] = sg
            # the same with the pressure only on contact nodes (where the law sets it)
            cont = s["status"][-1][o] != 0
            rec[f"pressure_mismatch_{key}"] = float(
                np.linalg.norm((lam[:n] - sg * lam_tr[:n])[cont])
                / np.linalg.norm(lam_tr[:n][cont]))
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
