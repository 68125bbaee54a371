"""The run-like directory of ``stickslip travel`` and the branch table of ``--continue``.

``summary.json`` carries the keys of ``stickslip run`` (status, regime, mode, signed
celerity, frequency, fractions, ψ₁, ψ₂, amplitude) plus the Newton residual and the
inequality margins; ``profiles.npz`` the U, V, U̇, V̇, P, Q, status over one period (paper
Figure 1). A failed solve writes ``summary.json`` with ``status: failed``, the last residual
and the violated inequality, and **no** wave file.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from stickslip.postprocess.style import MM, MPA, shade_zones, status_handles
from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import Scene, write_scene
from stickslip.studies.rundir.ownership import claim
from stickslip.studies.rundir.summary_file import json_text, write_summary

__all__ = ["prepare_dir", "write_wave", "write_failure", "write_branch", "plot_profiles",
           "plot_branch"]


def prepare_dir(path: Path, force: bool):
    """Claim ``path`` (``studies.rundir.ownership``, kind travel): a new or empty directory,
    or with ``force`` a travel directory, replaced by a sibling that is swapped in by
    ``Claim.commit`` once the results are written (``Claim.discard`` keeps the earlier one);
    anything else raises ``OwnershipError`` (a ``FileExistsError``) with one line. Write into
    ``claim.work``; the claim holds the directory's lock until released."""
    return claim(path, "travel", force=force)


def shown(path: Path) -> Path:
    """``path`` as the user will find it: a replacement folder ``.NAME.new.PID`` is NAME."""
    parts = [re.sub(r"^\.(.+)\.new\.\d+$", r"\1", part) for part in path.parts]
    return Path(*parts)


def write_wave(path: Path, scene: Scene, summary: dict, profiles: dict) -> None:
    """scene.toml, summary.json and profiles.npz (atomic writes)."""
    write_scene(scene, path / "scene.toml")
    tmp = path / ".profiles.tmp.npz"
    np.savez_compressed(tmp, **profiles)
    os.replace(tmp, path / "profiles.npz")
    write_summary(path, summary)


def write_failure(path: Path, scene: Scene, summary: dict) -> None:
    """scene.toml and summary.json (status failed); no wave file."""
    write_scene(scene, path / "scene.toml")
    write_summary(path, summary)


def write_branch(path: Path, rows: list[dict]) -> None:
    """branch.json and branch.csv of a continuation."""
    atomic_write_text(path / "branch.json", json_text(rows))
    keys = ["value", "status", "celerity_m_s", "amplitude_m", "psi1", "psi2", "psi1_subnode",
            "psi2_subnode", "regime", "residual", "violated"]
    lines = [",".join(keys)]
    for r in rows:
        lines.append(",".join(str(r.get(k, "")) for k in keys))
    atomic_write_text(path / "branch.csv", "\n".join(lines) + "\n")


def plot_profiles(path: Path, profiles: dict, summary: dict) -> Path:
    """U, V, P, Q over one period with the zones shaded (paper Figure 1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    phi = profiles["phi"]
    fig, axes = plt.subplots(4, 1, figsize=(7, 8), sharex=True)
    for ax, key, scale, lab in zip(axes, ("U", "V", "P", "Q"), (MM, MM, MPA, MPA),
                                   ("u_r − d (mm)", "u_θ (mm)", "p (MPa)", "q (MPa)"),
                                   strict=True):
        shade_zones(ax, phi, np.asarray(profiles["status"]))
        ax.plot(phi, scale * np.asarray(profiles[key]), "k.-", ms=3)
        ax.set_ylabel(lab)
        ax.ticklabel_format(axis="y", useOffset=False)
    axes[0].legend(handles=status_handles(alpha=0.35), fontsize=7, loc="upper right", ncol=3)
    axes[-1].set_xlabel("φ = θ − ωt (rad)")
    fig.suptitle(f"travel: {summary['regime']}, k = {summary['k']}, "
                 f"{summary['celerity_m_s']:.1f} m/s, ψ1 = {summary['psi1_subnode']:.3f}, "
                 f"ψ2 = {summary['psi2_subnode']:.3f}")
    out = path / "travel_profiles.png"
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


#: axis labels of continuation keys: symbol, scene key and unit
KEY_LABELS = {
    "loading.omega": "Ω, loading.omega (rad/s)",
    "loading.f": "f, loading.f (–)",
    "geometry.delta": "δ = d/R, geometry.delta (–)",
    "geometry.xi": "ξ = R*/R, geometry.xi (–)",
    "geometry.R": "R, geometry.R (m)",
    "material.nu": "ν, material.nu (–)",
    "material.E": "E, material.E (Pa)",
    "material.wave_speed": "c_s, material.wave_speed (m/s)",
    "damping.loss_factor": "η, damping.loss_factor (–)",
    "damping.reference_frequency_hz": "f_ref, damping.reference_frequency_hz (Hz)",
    "mesh.n_inner": "N, mesh.n_inner (contact nodes)",
}


def key_label(key: str) -> str:
    """The axis label of a continuation key: ``KEY_LABELS``, else the key itself."""
    return KEY_LABELS.get(key, key)


def plot_branch(path: Path, rows: list[dict], key: str) -> Path:
    """Celerity, amplitude, ψ₁, ψ₂ against the continuation parameter (Figures 4–6)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "converged"]
    x = [r["value"] for r in ok]
    fig, axes = plt.subplots(3, 1, figsize=(6, 7), sharex=True)
    axes[0].plot(x, [r["celerity_m_s"] for r in ok], "o-")
    axes[0].set_ylabel("celerity (m/s)")
    axes[1].plot(x, [r["amplitude_m"] for r in ok], "o-")
    axes[1].set_ylabel("amplitude (m)")
    axes[2].plot(x, [r["psi1_subnode"] for r in ok], "o-", label="ψ1")
    axes[2].plot(x, [r["psi2_subnode"] for r in ok], "s-", label="ψ2")
    axes[2].legend()
    axes[2].set_ylabel("ψ (fraction of a period)")
    axes[2].set_xlabel(key_label(key))
    bad = [r for r in rows if r["status"] != "converged" and r.get("value") is not None]
    if bad:
        for ax in axes:
            ax.axvline(bad[0]["value"], color="r", ls="--")
        axes[0].set_title(f"branch lost at {key} = {bad[0]['value']:g}: {bad[0].get('violated')}")
    out = path / "branch.png"
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
