"""
The attractors of a point
=========================

Several attractors coexist at one scene point: rigidly travelling waves, and multi-wave
states (a dominant wave carrying companions of other wavenumbers, each travelling at its own
speed). Which one a transient reaches depends on its start. So the answer for a point is
its set of attractors and the share of starts that reaches each. This demo runs a small
census with ``stickslip.attractors`` (the ``stickslip attractors`` command) on the damped
Figure-3 scene at N = 66: four random starts (a random superposition of the modes 1 ... 16
with random phases, 0.1 d, seeds 1 ... 4) and the structured mode-4 start, run as one batch
to 0.3 s; each start still changing then is continued from where it stopped, in legs of
x1.5, until it settles (up to 4 s).
"""

# %%
# The census
# ----------
import os
from pathlib import Path

import matplotlib.pyplot as plt

import stickslip

work = Path(os.environ.get("STICKSLIP_OUTPUT", "runs")) / "demos" / "census"
answer = stickslip.attractors("figure3_n132_damped", work, starts=4, structured=(4,),
                              meshes=(66,), end_time=0.3, force=True, quiet=True)
print(answer["text"])

# %%
# Each start's end state
# ----------------------
# Every start is described by its travelling components over the last two windows (the
# space-time spectrum of the contact circle: wavenumber, direction, share of the dominant's
# amplitude, celerity) and classified: a rigid wave (one component), a multi-wave state
# (several), steady sliding, or unsettled (its components still change between the two
# windows of 0.1 s). A start is "unsettled" only if it still changes at the cap; its settle
# time is the end of the first pair of windows from which its features stayed the same.
for row in answer["starts"]:
    which = f"seed {row['seed']}" if row["start"] == "random" else f"mode {row['start_mode']}"
    settled = (f"settled by {row['settle_time_s']:.2f} s" if row["settle_time_s"] else
               f"at {row['sim_time_s'] or 0:.2f} s")
    print(f"{which:>8}: {row['class']:>10}  {settled:>18}  {row['name'] or row['member'] or ''}")

# %%
# The members and their shares
# ----------------------------
# The share of the random starts that reaches each member, with its 95 % Wilson interval:
# with four starts the intervals are wide, which is the point of counting.
members = answer["members"]["66"]  # one row per member of the random starts
fig, ax = plt.subplots(figsize=(6, 3))
shares = [m["share"] for m in members]
low = [m["share"] - m["share_lo"] for m in members]
high = [m["share_hi"] - m["share"] for m in members]
ax.bar(range(len(members)), shares, yerr=[low, high], capsize=4)
ax.set_xticks(range(len(members)), [m["member"] for m in members], rotation=20, ha="right",
              fontsize=8)
ax.set(ylabel="share of random starts", ylim=(0, 1),
       title="members reached at N = 66 (damped Figure 3)")
fig.tight_layout()

# %%
# A census is complete only when the set stops changing under refinement: give
# ``meshes=(132, 264, 528)``: attractors are matched across meshes by their components, and
# the change of each celerity and share is reported. At coarse meshes attractors appear that
# finer meshes never reach, so report one with its start, N, dt, beta2 and damping.
