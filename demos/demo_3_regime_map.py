"""
A regime map
============

Which wave does a scene reach as the cylinder's speed Omega and the mismatch delta change?
A sweep runs every variant of a base scene into its own run directory and gathers the
summaries into a table; the regime map draws it with the reduced model's existence
boundaries. Here a 3 x 3 map on the damped Figure-3 scene at a small mesh (N = 36, 0.15 s
per scene; about 15 s in all). For a real map use N >= 132 and ``mpirun``::

    ./dev mpirun -n 2 stickslip sweep sweeps/omega_delta_damped.toml --plot
"""

# %%
# The sweep file
# --------------
# A base scene, overrides for every scene (``set``), and the grid of dotted scene keys.
import os
from pathlib import Path

import matplotlib.pyplot as plt

import stickslip

work = Path(os.environ.get("STICKSLIP_OUTPUT", "runs")) / "demos" / "regime_map"
work.mkdir(parents=True, exist_ok=True)
sweep_file = work / "demo_map.toml"
sweep_file.write_text('''
name = "demo_map"
base = "figure3_n132_damped"
set = ["mesh.n_inner = 36", "time.end_time = 0.15"]

[grid]
"loading.omega" = [10.0, 50.0, 200.0]
"geometry.delta" = [0.0002, 0.001, 0.005]

[map]
xscale = "log"
yscale = "log"
''')

# %%
# Run it
# ------
# ``stickslip.sweep`` returns the table (``sweep.json``): one row per scene. Under
# ``mpirun -n P`` the ranks share the scenes; running it again skips finished scenes.
table = stickslip.sweep(sweep_file, work / "out", plot=True, quiet=True)
print(f"{'Omega':>6} {'delta':>7}  {'regime':24} {'k':>3} {'celerity (m/s)':>15}")
for row in table["rows"]:
    print(f"{row['loading.omega']:6.0f} {row['geometry.delta']:7.4f}  {row['regime']:24} "
          f"{row['mode']:3d} {row['celerity_m_s']:15.1f}")

# %%
# The map
# -------
# ``plot=True`` drew ``regime_map.png`` into the sweep directory: the regime of each cell,
# with the boundaries where the reduced model admits a stick-slip or a
# stick-slip-separation wave.
fig, ax = plt.subplots(figsize=(8, 6))
ax.imshow(plt.imread(work / "out" / "regime_map.png"))
ax.set_axis_off()
fig.tight_layout()

# %%
# At N = 36 and 0.15 s this is a pipeline demonstration, not a converged map: on the damped
# setting the regime is robust from N = 132 on, but the selected wave (k, direction) still
# changes with N in many cells (see the sweeps page).
