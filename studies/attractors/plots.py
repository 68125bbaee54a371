"""``stickslip attractors --plot``: shares per mesh, member values against N, profiles.

* ``basins.png``: each member's basin share per mesh with its 95 % Wilson interval;
* ``members_vs_n.png``: celerity, frequency, ψ₁, ψ₂ and RMS amplitude of every member of
  the random starts with a wavenumber, mean ± standard deviation over its starts, against N;
* ``profile_<mesh>_<member>.png``: the paper's Figure-1 panels (U, V, P, Q over one
  wavelength, ``postprocess.plotting.plot_uvpq``) of one run of each rigid-wave member,
  random or structured start.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


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
    import matplotlib.pyplot as plt

    from stickslip.studies.attractors.statistics import wilson

    meshes = list(answer["members"])
    names = sorted({m["member"] for ms in answer["members"].values() for m in ms})
    if not names:
        return None
    fig, ax = plt.subplots(figsize=(max(6.0, 1.2 * len(names) + 2), 4.2),
                           constrained_layout=True)
    width = 0.8 / len(meshes)
    x = np.arange(len(names))
    for j, n in enumerate(meshes):
        by = {m["member"]: m for m in answer["members"][n]}
        starts = answer["members"][n][0]["starts"] if answer["members"][n] else 0
        none = wilson(0, starts)  # a member no start reached: 0 with its interval
        share = np.array([by[s]["share"] if s in by else 0.0 for s in names])
        lo = np.array([by[s]["share_lo"] if s in by else none[0] for s in names])
        hi = np.array([by[s]["share_hi"] if s in by else none[1] for s in names])
        ax.bar(x + (j - (len(meshes) - 1) / 2) * width, share, width,
               yerr=[share - lo, hi - share], capsize=3, label=f"N = {n} ({starts} starts)")
    ax.set_xticks(x, names, rotation=30, ha="right", fontsize=8)
    ax.set(ylabel="basin share (95 % Wilson interval)", ylim=(0, 1),
           title=f"attractors of {answer['scene']['name']}")
    ax.legend(fontsize=8)
    return _save(fig, out_dir / "basins.png")


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
    for i, name in enumerate(waves):
        pts = [(int(n), m) for n, ms in answer["members"].items() for m in ms
               if m["member"] == name]
        ns = [n for n, _ in pts]
        style = "-" if pts[0][1]["class"] == "wave" else ":"
        for ax, (key, label, scale) in zip(axes, keys, strict=True):
            y = [scale * (m[key] if m[key] is not None else np.nan) for _, m in pts]
            e = [scale * (m[f"{key}_sd"] or 0.0) for _, m in pts]
            ax.errorbar(ns, y, yerr=e, marker="o", capsize=3, color=f"C{i % 10}", ls=style,
                        label=name)
            ax.set(xlabel="N (contact nodes)", ylabel=label)
            ax.set_xscale("log", base=2)
    meshes = sorted(int(n) for n in answer["members"])
    for ax in axes:
        ax.set_xticks(meshes, [str(n) for n in meshes])
        ax.minorticks_off()
        ax.set_xlim(meshes[0] / 1.3, meshes[-1] * 1.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("members of the random starts against the mesh (mean ± sd over the starts; "
                 "solid: rigid waves, dotted: multi-wave or unsettled)", fontsize=10)
    return _save(fig, out_dir / "members_vs_n.png")


def _profiles(out_dir: Path, answer: dict) -> list[Path]:
    from stickslip.postprocess.plotting import plot_uvpq

    paths, seen = [], set()
    for run in answer["starts"]:  # one run of each wave member per mesh, any start
        key = (run["n_inner"], run["member"])
        if run["class"] != "wave" or key in seen:
            continue
        seen.add(key)
        png = out_dir / f"profile_{run['n_inner']}_{run['member'].replace('#', '_')}.png"
        try:
            paths.append(plot_uvpq(Path(run["run_dir"]), png, overlay=False))
        except (OSError, ValueError, KeyError) as err:
            print(f"profile of {run['member']} at N = {run['n_inner']} not drawn: {err}")
    return paths


def _save(fig, path: Path) -> Path:  # noqa: ANN001
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
