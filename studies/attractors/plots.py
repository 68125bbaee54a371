"""``stickslip attractors --plot``: shares per mesh, member values against N, profiles.

* ``basins.png``: each member's basin share per mesh with its 95 % Wilson interval, the
  attractors as solid bars, every other state hatched in a group of its own
  (``basins_figure``);
* ``members_vs_n.png``: celerity, frequency, ψ₁, ψ₂ and RMS amplitude of every member of
  the random starts with a wavenumber, mean ± standard deviation over its starts, against
  the ladder's rungs (equally spaced, in ladder order: by dofs);
* ``profile_<rung>_<member>.png`` (rung key ``132`` or ``132p2``): the paper's Figure-1
  panels (U, V, P, Q over one wavelength, ``postprocess.plotting.plot_uvpq``) of one run of
  each rigid-wave member, random or structured start.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np

from stickslip.postprocess.plotting import plot_uvpq
from stickslip.studies.attractors.starts import rung_key
from stickslip.studies.attractors.statistics import SETTLED, wilson


def plot_census(out_dir: str | Path, answer: dict | None = None) -> list[Path]:
    """Draw the census figures of ``out_dir`` (of ``answer``, as attractors.json holds it;
    default: its attractors.json) into it; returns their paths."""
    import matplotlib

    matplotlib.use("Agg")
    out_dir = Path(out_dir)
    if answer is None:
        answer = json.loads((out_dir / "attractors.json").read_text())
    paths = [_basins(out_dir, answer), _values(out_dir, answer)]
    return [p for p in paths if p is not None] + _profiles(out_dir, answer)


def _basins(out_dir: Path, answer: dict) -> Path | None:
    fig = basins_figure(answer)
    return None if fig is None else _save(fig, out_dir / "basins.png")


#: How a non-attractor's bar is drawn: hatched, pale, edged in its mesh's colour.
OTHER_HATCH, OTHER_FACE = "///", "0.92"


def basins_figure(answer: dict):  # noqa: ANN201 - matplotlib Figure, or None
    """The figure of ``basins.png``: per member its basin share at each mesh (a colour per
    mesh) with its 95 % Wilson interval. The attractors (``SETTLED``) are solid bars on the
    left; every other state (unsettled, settling, transient, steady sliding, diverged,
    failed) is a hatched pale bar in a separate group on the right; a member that is an
    attractor at one mesh and not at another stands with the attractors and is hatched
    where it is not one. Ticks: the members' readable labels (``label``). None where no
    member is there."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    meshes = list(answer["members"])
    labels: dict[str, str] = {}
    attractor: dict[str, bool] = {}
    for ms in answer["members"].values():
        for m in ms:
            key = m.get("member") or m["class"]
            labels.setdefault(key, m.get("label") or key)
            attractor[key] = attractor.get(key, False) or m["class"] in SETTLED
    firsts = sorted(k for k in labels if attractor[k])
    others = sorted(k for k in labels if not attractor[k])
    names = firsts + others
    if not names:
        return None
    gap = 0.6 if firsts and others else 0.0
    x = np.array([i + (gap if i >= len(firsts) else 0.0) for i in range(len(names))])
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(names) + 2.5), 5.0),
                           constrained_layout=True)
    width = 0.8 / len(meshes)
    for j, n in enumerate(meshes):
        by = {(m.get("member") or m["class"]): m for m in answer["members"][n]}
        starts = answer["members"][n][0]["starts"] if answer["members"][n] else 0
        none = wilson(0, starts)  # a member no start reached: 0 with its interval
        colour = f"C{j % 10}"
        for i, s in enumerate(names):
            m = by.get(s)
            share, lo, hi = ((m["share"], m["share_lo"], m["share_hi"]) if m else
                             (0.0, *none))
            solid = m["class"] in SETTLED if m else attractor[s]
            ax.bar(x[i] + (j - (len(meshes) - 1) / 2) * width, share, width,
                   yerr=[[share - lo], [hi - share]], capsize=3, ecolor="0.2",
                   color=colour if solid else OTHER_FACE, edgecolor=colour,
                   hatch=None if solid else OTHER_HATCH, linewidth=1.0)
    ax.set_xticks(x, [textwrap.fill(labels[s], 26) for s in names], rotation=30, ha="right",
                  fontsize=7)
    ax.set(ylabel="basin share of the random starts (95 % Wilson interval)", ylim=(0, 1.12),
           title=f"attractors of {answer['scene']['name']}")
    for group, where, text in ((firsts, x[:len(firsts)], "attractors"),
                               (others, x[len(firsts):], "not attractors")):
        if group:
            ax.text(where.mean(), 1.06, text, ha="center", va="center", fontsize=9,
                    fontweight="bold")
    if firsts and others:
        ax.axvline((x[len(firsts) - 1] + x[len(firsts)]) / 2, color="0.5", ls="--", lw=0.8)
    handles = [Patch(color=f"C{j % 10}", label=f"N = {n} "
                     f"({answer['members'][n][0]['starts'] if answer['members'][n] else 0}"
                     " starts)") for j, n in enumerate(meshes)]
    handles += [Patch(facecolor="0.5", edgecolor="0.5",
                      label="attractor: solid bar\n(in its mesh's colour)"),
                Patch(facecolor=OTHER_FACE, edgecolor="0.3", hatch=OTHER_HATCH,
                      label="not an attractor: hatched pale bar\n(unsettled, settling, "
                            "transient,\nsteady sliding, diverged, failed)")]
    fig.legend(handles=handles, fontsize=7, loc="outside right upper")
    return fig


def _values(out_dir: Path, answer: dict) -> Path | None:
    import matplotlib.pyplot as plt

    keys = (("celerity_m_s", "celerity (m/s)", 1.0), ("frequency_hz", "frequency (Hz)", 1.0),
            ("psi1", "ψ₁", 1.0), ("psi2", "ψ₂", 1.0),
            ("rms_amplitude_m", "RMS amplitude (mm)", 1e3))
    waves = sorted({m["member"] for ms in answer["members"].values() for m in ms
                    if m["k"] is not None})
    if not waves:
        return None
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * len(keys), 3.6),
                             constrained_layout=True)
    rungs = list(answer["members"])  # rung keys in ladder order (by dofs): the x axis
    for i, name in enumerate(waves):
        pts = [(rungs.index(n), m) for n, ms in answer["members"].items() for m in ms
               if m["member"] == name]
        ns = [n for n, _ in pts]
        style = "-" if pts[0][1]["class"] == "wave" else ":"
        for ax, (key, label, scale) in zip(axes, keys, strict=True):
            y = [scale * (m[key] if m[key] is not None else np.nan) for _, m in pts]
            e = [scale * (m[f"{key}_sd"] or 0.0) for _, m in pts]
            ax.errorbar(ns, y, yerr=e, marker="o", capsize=3, color=f"C{i % 10}", ls=style,
                        label=name)
            ax.set(xlabel="rung (N contact nodes; pP: element degree P)", ylabel=label)
    for ax in axes:
        ax.set_xticks(range(len(rungs)), rungs)
        ax.minorticks_off()
        ax.set_xlim(-0.5, len(rungs) - 0.5)
    axes[0].legend(fontsize=7)
    fig.suptitle("members of the random starts against the mesh (mean ± sd over the starts; "
                 "solid: rigid waves, dotted: multi-wave or unsettled)", fontsize=10)
    return _save(fig, out_dir / "members_vs_n.png")


def _profiles(out_dir: Path, answer: dict) -> list[Path]:
    paths, seen = [], set()
    for run in answer["starts"]:  # one run of each wave member per mesh, any start
        rung = rung_key(run["n_inner"], run.get("degree") or 1)
        key = (rung, run["member"])
        if run["class"] != "wave" or key in seen:
            continue
        seen.add(key)
        png = out_dir / f"profile_{rung}_{run['member'].replace('#', '_')}.png"
        try:
            paths.append(plot_uvpq(Path(run["run_dir"]), png, overlay=False))
        except (OSError, ValueError, KeyError) as err:
            print(f"profile of {run['member']} at N = {rung} not drawn: {err}")
    return paths


def _save(fig, path: Path) -> Path:  # noqa: ANN001
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
