"""
The attractors of a point
=========================

Several travelling waves (members: wavenumber k, direction, regime) coexist at one scene
point, and which one a transient reaches depends on its start. So the answer for a point is
its set of attractors and the share of starts that reaches each. This demo takes a small
census by hand on the damped Figure-3 scene at N = 66: six starts (mode bumps k = 2, 3, 4
and three random perturbations), 0.3 s each (about 20 s in all). The ``stickslip
attractors`` command runs such a census in batches and on several meshes.
"""

# %%
# Six starts
# ----------
import os
from collections import Counter
from pathlib import Path

import matplotlib.pyplot as plt

import stickslip

scene = stickslip.load_scene("figure3_n132_damped", {"mesh.n_inner": 66})
starts = {f"mode {k}": {"initial.perturbation": "mode", "initial.mode": k} for k in (2, 3, 4)}
starts |= {f"random {s}": {"initial.perturbation": "random", "initial.seed": s}
           for s in (1, 2, 3)}
work = Path(os.environ.get("STICKSLIP_OUTPUT", "runs")) / "demos" / "census"
reached = {}
for name, start in starts.items():
    s = stickslip.run(scene, work / name.replace(" ", "_"), overrides=start, force=True,
                      quiet=True)
    reached[name] = (s["mode"], s["direction"], s["regime"])
    print(f"{name:>9}: k = {s['mode']:2d}, {s['direction']:8}, {s['regime']}, "
          f"{s['frequency_hz']:.0f} Hz, limit cycle {s['limit_cycle']}")

# %%
# The members and their shares
# ----------------------------
members = Counter(reached.values())
fig, ax = plt.subplots(figsize=(6, 3))
labels = [f"k = {k}, {direction}" for k, direction, _ in members]
ax.bar(labels, [n / len(starts) for n in members.values()])
ax.set(ylabel="share of starts", title="members reached at N = 66 (damped Figure 3)")
fig.tight_layout()

# %%
# A census is complete only when the set stops changing under refinement: repeat on N = 132,
# 264 and 528. At coarse meshes members appear that finer meshes never reach, so report a
# member with its start, N, dt, beta2 and damping.
