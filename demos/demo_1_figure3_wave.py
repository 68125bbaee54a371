"""
The Figure-3 wave
=================

The paper's Figure-3 scene: an elastic tube (inner radius R = 1 m, outer radius 1.25 m,
clamped outside, E = 1 GPa, sqrt(E/rho) = 1000 m/s, nu = 0.3) pressed on a rigid cylinder
of radius R(1 + delta), delta = 4e-4, that turns at Omega = 50 rad/s, with Coulomb friction
f = 0.7. Steady sliding is flutter unstable; a small mode-4 bump grows into a travelling
stick-slip-separation wave. This demo runs it (N = 132 contact nodes, explicit Newmark,
beta2 = 0.6, 0.3 s: about 10 s), then reads the samples and draws the wave.
"""

# %%
# Run the scene
# -------------
# ``stickslip.run`` takes a scene file or the name of a shipped scene, writes a run directory
# and returns its ``summary.json`` as a dict. The wave is measured over the last third of the
# record.
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import stickslip

# Outputs go to $STICKSLIP_OUTPUT/demos (default runs/demos).
out = Path(os.environ.get("STICKSLIP_OUTPUT", "runs")) / "demos"
run_dir = out / "figure3_n132"
summary = stickslip.run("figure3_n132", run_dir, force=True, quiet=True)
print(f"{summary['status']}: {summary['regime']}, k = {summary['mode']}, "
      f"celerity {summary['celerity_m_s']:.1f} m/s, {summary['frequency_hz']:.1f} Hz, "
      f"limit cycle {summary['limit_cycle']}")
print("zone fractions:", {zone: round(share, 3) for zone, share in summary["fractions"].items()})

# %%
# The samples
# -----------
# ``samples.npz`` holds the contact circle every sample: ``u_r`` and ``u_theta`` (T x N,
# metres), the velocities, the reactions and the contact ``status`` (0 separation, 1 stick,
# 2 slip). Every key is described in the output-file reference.
data = stickslip.load_run(run_dir)
s = data.samples
t, theta = s["t"], s["theta"]
d = data.d
print("samples:", {k: v.shape for k, v in s.items() if k in ("t", "theta", "u_r", "status")})

# %%
# Space-time map
# --------------
# The last 5 ms (about 8 periods): the gap u_r - d (the tube lifts off the cylinder where it
# is positive) and the contact status. A travelling wave is a set of parallel stripes; k = 4
# stripes per turn that lean to smaller angles as time grows: the wave travels *against* the
# rotation.
last = t >= t[-1] - 0.005
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
extent = (0, 360, t[last][0] * 1e3, t[-1] * 1e3)
im = ax1.imshow((s["u_r"][last] - d) * 1e3, aspect="auto", origin="lower", extent=extent,
                cmap="viridis")
fig.colorbar(im, ax=ax1, label="u_r - d (mm)")
ax2.imshow(s["status"][last], aspect="auto", origin="lower", extent=extent,
           cmap=plt.matplotlib.colors.ListedColormap(["white", "tab:blue", "tab:orange"]))
ax1.set(xlabel="theta (degree)", ylabel="t (ms)", title="gap")
ax2.set(xlabel="theta (degree)", title="separation (white), stick (blue), slip (orange)")
fig.tight_layout()

# %%
# Profile at the end
# ------------------
# Around the circle at the last sample: separation where u_r > d, stick where the tube
# moves with the cylinder's surface (v_theta = R Omega), slip in between.
fig, ax = plt.subplots(figsize=(8, 3))
deg = np.degrees(theta)
ax.plot(deg, (s["u_r"][-1] - d) * 1e3, label="u_r - d")
ax.plot(deg, (s["u_theta"][-1] - s["u_theta"][-1].mean()) * 1e3, label="u_theta - mean")
for code, colour in ((1, "tab:blue"), (2, "tab:orange")):
    ax.scatter(deg[s["status"][-1] == code], np.zeros(np.sum(s["status"][-1] == code)),
               s=6, color=colour, label=stickslip.STATUS_CODES[code])
ax.set(xlabel="theta (degree)", ylabel="mm")
ax.legend(ncol=4, fontsize=8)
fig.tight_layout()

# %%
# The paper's scene has no physical dissipation, and its selected wave changes with the
# mesh, the time step and the start. For numbers that converge, run the damped twin,
# ``scenes/figure3_n132_damped.toml`` (Kelvin-Voigt loss factor 2 % at 1.6 kHz).
