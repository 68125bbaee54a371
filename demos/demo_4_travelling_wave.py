"""
A travelling wave and a branch
==============================

A transient reaches a wave after thousands of time steps. The wave-frame solver finds it
directly: nodal displacements W(theta - omega t) that travel rigidly, solved together with
omega by a semismooth Newton method on the contact nodes. This demo solves the damped
Figure-1 wave k = 4 on a small mesh (N = 36) from a start speed, then follows it as the
cylinder's speed Omega changes (about 10 s).
"""

# %%
# One wave
# --------
# ``stickslip.travel`` returns the summary (the keys of a run's summary.json, plus the
# Newton residual) and the profiles over one wavelength. ``fixed_omega=True`` keeps the
# nearest admissible speed to the start.
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import stickslip

scene = stickslip.load_scene("figure1_n132_damped", {"mesh.n_inner": 36})
summary, profiles = stickslip.travel(scene, 4, celerity=-2300.0, fixed_omega=True)
for key in ("regime", "mode", "celerity_m_s", "frequency_hz", "psi1", "psi2", "residual"):
    print(f"{key:>13}: {summary[key]}")
print("inequalities of the contact law satisfied:", summary["inequalities"]["all_satisfied"])

# %%
# The profile over one wavelength
# -------------------------------
# U = u_r - d (the lift-off) and V = u_theta in the co-moving angle phi = theta - omega t,
# coloured by the contact status of each point.
phi = np.degrees(profiles["phi"])
fig, ax = plt.subplots(figsize=(7, 3.5))
ax.plot(phi, profiles["U"] * 1e3, "-o", ms=3, label="U = u_r - d")
ax.plot(phi, (profiles["V"] - profiles["V"].mean()) * 1e3, "-o", ms=3, label="V - mean")
colours = {0: "lightgrey", 1: "tab:blue", 2: "tab:orange"}
for p, code in zip(phi, profiles["status"], strict=True):
    ax.axvspan(p - 0.5 * (phi[1] - phi[0]), p + 0.5 * (phi[1] - phi[0]),
               color=colours[int(code)], alpha=0.25, lw=0)
ax.set(xlabel="phi (degree)", ylabel="mm",
       title="grey separation, blue stick, orange slip")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# A branch in Omega
# -----------------
# ``travel_branch`` solves each value from the previous wave (loading keys reuse the
# operators). The branch ends where a solve fails (its row says which inequality failed) or
# where it jumps to another solution (status ``jumped``: a value far off the trend of the
# points before). With ``fixed_omega`` the speed is held: no wave of this family exists at
# the start's -2300 m/s, so the search took the nearest admissible speed, -2357.5 m/s
# (``celerity_note`` says so), and the amplitude follows Omega until, at Omega = 50, the
# solution jumps to another wave. The discrete waves form bands of admissible speeds, not
# isolated points.
omegas = [40.0, 42.5, 45.0, 47.5, 50.0]
out = Path(os.environ.get("STICKSLIP_OUTPUT", "runs")) / "demos" / "branch_k4"
rows = stickslip.travel_branch(scene, 4, "loading.omega", omegas, out,
                               celerity=-2300.0, fixed_omega=True, force=True)
ok = [r for r in rows if r["status"] == "converged"]
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot([r["value"] for r in ok], [r["amplitude_m"] * 1e3 for r in ok], "-o")
ax.set(xlabel="Omega (rad/s)", ylabel="amplitude (mm)",
       title="branch of the k = 4 wave at -2357.5 m/s, N = 36")
fig.tight_layout()

# %%
# On the command line: ``stickslip travel scenes/figure1_n132_damped.toml --k 4
# --celerity -2300 --fixed-omega --continue loading.omega=40:50:5 --plot``.
