"""
Your own geometry
=================

The tube of the paper is clamped all around its outside. A real part is not: a brake pad sits
on a caliper, a ring is bolted through lugs, a support holds only part of the outside. Give
the solver your cross-section as a gmsh file and it runs, analyses and plots it like the tube.
This demo uses the shipped ``scenes/tube_four_clamps.toml``: the same tube, clamped only on
four 70-degree arcs of its outside (four free 20-degree windows), and shows what the geometry
changes: the even-k doublets split, and k = 2 and 4 stop fluttering (about 20 s).
"""

# %%
# The mesh file and the scene
# ---------------------------
# The cross-section is a gmsh ``.geo`` (or a ready ``.msh``) with two physical curve groups:
# ``"contact"``, the circle r = R that the rotating cylinder touches (here N = 72 nodes), and
# ``"clamped"``, the part of the outside that is fixed. Everything else is free. The scene
# names the file and the groups in its ``[mesh]`` table:
#
# .. code-block:: toml
#
#    [mesh]
#    file = "meshes/tube_four_clamps.geo"   # working directory, then the scenes folder
#    contact_group = "contact"
#    clamped_group = "clamped"
#    n_inner = 72                           # checked: the contact group has 72 nodes
#
# Loading the scene reads the file and checks it: a missing group, contact nodes off r = R, a
# node count other than ``n_inner``, a 3D or mixed mesh each stop it with one line that says
# what to change (``stickslip run`` exits with status 2).
from pathlib import Path

import matplotlib.pyplot as plt

import stickslip
from stickslip.solver.scene import SCENES_DIR

geo = SCENES_DIR / "meshes" / "tube_four_clamps.geo"
print("\n".join(line for line in geo.read_text().splitlines() if line.startswith("Physical")))
scene = stickslip.load_scene("tube_four_clamps")
print(scene.mesh)

# %%
# Split doublets (CEA)
# --------------------
# On the tube every wavenumber k has two modes of one frequency (cos kθ, sin kθ). The four
# clamps have 4-fold symmetry, which splits the doublets whose 2k is a multiple of 4
# (k = 2, 4, 6) and leaves the odd k degenerate. With friction, a degenerate pair couples into
# a flutter pair (one travelling wave grows, the other decays); a pair split far enough stays
# two stable standing modes: at f = 0.7 the split k = 2 and k = 4 do (the tube's k = 4 grows
# at 3.2 1/s), k = 6, split by 125 Hz, couples again, and every odd k flutters.
# ``stickslip flutter-fe SCENE`` prints this table.
from stickslip.studies.flutter_fe.doublets import doublet_lines, doublets  # noqa: E402

tube = stickslip.cea_friction_sweep("figure3_n132", [0.0, 0.7], overrides={"mesh.n_inner": 72},
                                    fmax_hz=1500.0)
clamps = stickslip.cea_friction_sweep("tube_four_clamps", [0.0, 0.7], fmax_hz=1500.0)
for name, (free, rough) in (("tube, N = 72", tube), ("four clamps, N = 72", clamps)):
    print(f"{name}, f = 0:")
    print("\n".join(doublet_lines(free, 7)))
    print(f"{name}, f = 0.7:")
    print("\n".join(doublet_lines(rough, 7)))

# %%
# The frequencies of each doublet without friction: one dot per member. The tube's pairs sit
# on each other; the clamps pull the even-k pairs apart.
fig, ax = plt.subplots(figsize=(7, 3.6))
for (free, _), label, style, shift in ((tube, "tube", "oC0", -0.1),
                                       (clamps, "four clamps", "sC3", 0.1)):
    for d in doublets(free, 7):
        ax.plot([d.k + shift] * len(d.frequencies_hz), d.frequencies_hz, style, mfc="none",
                label=label if d.k == 1 else None)
ax.set(xlabel="wavenumber k", ylabel="frequency (Hz)",
       title="±k doublets without friction (CEA, f = 0)")
ax.legend()
fig.tight_layout()

# %%
# A transient with its fields
# ---------------------------
# The run starts from the steady sliding state plus a mode-4 bump, as the tube's scenes do.
# With ``output.fields = true`` it also writes ``fields.bp`` and ``stress.bp`` for ParaView
# (the how-to "Export to ParaView"); ``plot=True`` draws the von Mises and contact-pressure
# maps of the last step. The free windows open wide: the wave is no longer a rigid travelling
# wave of the tube but a pattern pinned to the four windows.
import tempfile  # noqa: E402

out = Path(tempfile.mkdtemp()) / "four_clamps"
summary = stickslip.run("tube_four_clamps", out, quiet=True, plot=True,
                        overrides={"time.end_time": 0.1, "output.fields": True})
print({k: summary[k] for k in ("status", "regime", "mode", "frequency_hz", "limit_cycle")})
print(sorted(p.name for p in out.iterdir() if p.suffix in (".bp", ".png")))
fig, ax = plt.subplots(figsize=(9, 5.2))
ax.imshow(plt.imread(out / "stress.png"))
ax.set_axis_off()
fig.tight_layout()

# %%
# The same from the command line:
#
# .. code-block:: bash
#
#    ./dev stickslip flutter-fe tube_four_clamps --fmax-hz 1500
#    ./dev stickslip run tube_four_clamps --set output.fields=true --plot
#    ./dev stickslip attractors tube_four_clamps --starts 4 --end-time 0.05 --no-certify
#
# ``stickslip travel`` solves waves in a frame that turns with the wave, so it needs a mesh
# that a rotation by one contact edge maps onto itself, and refuses this one in one line.
