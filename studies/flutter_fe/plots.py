"""CEA figures: the diagram against f, the spectrum and a 3D tube's unstable modes on its
contact surface (matplotlib, Agg)."""


from __future__ import annotations

import numpy as np

from stickslip.studies.flutter_fe.cea import CEAMode, CEAResult, ContactGrid, distinct_modes
from stickslip.studies.flutter_fe.tables import lock_in_points

# --------------------------------------------------------------------------------- plots


def plot_cea_diagram(
    results: list[CEAResult], path: str, *, k_detail: int = 4, kmax: int = 12,
    reduced: dict[float, list[dict]] | None = None, title: str = "",
) -> str:
    """The classic CEA diagram against the friction coefficient f, three panels:

    (a) frequency of every mode of wavenumber ``k_detail`` (▲ travels with the rotation,
    ▼ against it, ● standing); (b) their real parts ``Re λ = ±σ``: each conjugate pair is a
    growing (+σ) and a decaying (−σ) wave, degenerate (±k, σ = 0) at f = 0; (c) growth rate
    of the most unstable mode of each k = 1..kmax (reduced model of eq. [2] dashed, if given).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fs = np.array([r.f for r in results])
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2), constrained_layout=True)
    ax1, ax2, ax3 = axes
    marks = {"rotation": ("^", "tab:red"), "opposite": ("v", "tab:blue"),
             "standing": ("o", "0.4"), "divergence": ("s", "k")}
    # (a), (b): branches of k_detail, connected in frequency order
    branches = [distinct_modes(m for m in r.modes if m.wavenumber == k_detail) for r in results]
    nb = min((len(b) for b in branches), default=0)
    for j in range(nb):
        fr = [b[j].frequency_hz for b in branches]
        gr = [b[j].growth_rate for b in branches]
        ax1.plot(fs, fr, "-", color="0.75", lw=0.8, zorder=1)
        ax2.plot(fs, gr, "-", color="0.75", lw=0.8, zorder=1)
        ax2.plot(fs, [-g for g in gr], "--", color="0.75", lw=0.8, zorder=1)
    for r, b in zip(results, branches, strict=True):
        for m in b:
            mk, col = marks[m.direction]
            ax1.scatter(r.f, m.frequency_hz, marker=mk, c=col, s=22, zorder=2)
            ax2.scatter(r.f, m.growth_rate, marker=mk, c=col, s=22, zorder=2)
            ax2.scatter(r.f, -m.growth_rate, marker=mk, facecolors="none", edgecolors=col,
                        s=22, zorder=2)
    for mk, col, lab in (("^", "tab:red", "travels with the rotation"),
                         ("v", "tab:blue", "travels against the rotation"),
                         ("o", "0.4", "standing (f = 0: ±k degenerate)")):
        ax1.scatter([], [], marker=mk, c=col, label=lab)
    ax1.legend(loc="lower right", fontsize=8)
    ax1.set_title(f"(a) frequencies of the |k| = {k_detail} modes")
    ax1.set_ylabel("frequency Im λ / 2π (Hz)")
    ax2.set_title(f"(b) Re λ of the |k| = {k_detail} modes (open: decaying partner)")
    ax2.set_ylabel("Re λ (1/s), > 0: flutter")
    ax2.axhline(0.0, color="k", lw=0.6)
    # (c) most unstable growth per k
    cmap = plt.get_cmap("turbo")
    for k in range(1, kmax + 1):
        g = [r.by_wavenumber().get(k) for r in results]
        ax3.plot(fs, [m.growth_rate if m else np.nan for m in g], "-", color=cmap(k / kmax),
                 lw=1.4, label=f"k = {k}" if k in (1, k_detail, kmax) else None)
    top = [r.unstable()[0].growth_rate if r.unstable() else 0.0 for r in results]
    ax3.plot(fs, top, "k-", lw=2.2, label="most unstable, all k in band")
    if reduced:
        rf = sorted(reduced)
        ax3.plot(rf, [next(x["growth_rate_per_s"] for x in reduced[f] if x["k"] == k_detail)
                      for f in rf], "k--", lw=1.2, label=f"reduced model eq. [2], k = {k_detail}")
    _mark_lock_in(axes, results, k_detail, kmax)
    ax3.set_title("(c) growth rate of the most unstable mode of each k")
    ax3.set_ylabel("growth rate (1/s)")
    ax3.legend(fontsize=8, loc="upper left")
    for ax in axes:
        ax.set_xlabel("friction coefficient f")
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _mark_lock_in(axes, results: list[CEAResult], k_detail: int, kmax: int) -> None:  # noqa: ANN001
    """Where each k's pair couples and starts to grow (``tables.lock_in_points``): a star on
    panel (c) for every k, a dotted line on (a) and (b) for ``k_detail``."""
    ax1, ax2, ax3 = axes
    label = "lock-in (first f where k grows)"
    for point in lock_in_points(results):
        if point["k"] > kmax:
            continue
        ax3.plot(point["f_unstable"], point["growth_rate_per_s"], "k*", ms=9, label=label)
        label = None
        if point["k"] == k_detail:
            for ax in (ax1, ax2):
                ax.axvline(point["f_unstable"], color="k", ls=":", lw=1.0)
            ax1.annotate(f"lock-in of k = {k_detail}: f ≤ {point['f_unstable']:g}",
                         (point["f_unstable"], point["frequency_hz"]), fontsize=8,
                         xytext=(4, 8), textcoords="offset points")


def plot_spectrum(result: CEAResult, path: str, *, reduced: list[dict] | None = None) -> str:
    """Growth rate against frequency at one f, coloured by |k| (reduced model overlaid)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fr = np.array([m.frequency_hz for m in result.modes])
    gr = np.array([m.growth_rate for m in result.modes])
    kk = np.array([m.wavenumber for m in result.modes])
    fig, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
    sc = ax.scatter(fr, gr, c=kk, cmap="turbo", s=12)
    fig.colorbar(sc, ax=ax, label="|k|")
    if reduced:
        ax.plot([r["frequency_hz"] for r in reduced], [r["growth_rate_per_s"] for r in reduced],
                "k+-", ms=8, lw=0.8, label="reduced model (eq. [2]), k = 1, 2, ...")
        ax.legend(loc="upper left")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("growth rate (1/s)")
    ax.set_title(f"CEA of steady sliding: {result.scene}, f = {result.f:g}, "
                 f"{result.mass} mass, {result.n_free} free dofs")
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path




def plot_contact_modes(modes: list[CEAMode], grids: list[ContactGrid], path: str,
                       title: str = "") -> str:
    """One panel per mode: ``Re ψ_θ(θ, z)`` on the contact surface r = R unrolled (θ in
    degrees across, z/L up), each grid normalised by ``contact_grid`` (``max |ψ_θ| = 1``,
    real at its peak), on a diverging colour scale symmetric about 0; titled with the mode's
    k, m, frequency and growth rate. The motion is ``Re(ψ e^{λt})``: this is its t = 0
    snapshot, the wave travelling at ``−ω/k`` rad/s."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    count = len(modes)
    cols = min(count, 2)
    rows = max(1, -(-count // cols))
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 2.6 * rows + 0.4),
                             constrained_layout=True, squeeze=False)
    image = None
    for ax, mode, grid in zip(axes.flat, modes, grids, strict=False):
        deg = np.degrees(grid.theta)
        step = 360.0 / deg.size
        edges_t = np.append(deg, 360.0) - step / 2  # cells centred on the nodes
        z = grid.z_rel
        dz = z[1] - z[0] if z.size > 1 else 1.0
        edges_z = np.append(z, z[-1] + dz) - dz / 2
        image = ax.pcolormesh(edges_t, edges_z, grid.values.real, cmap="RdBu_r",
                              vmin=-1.0, vmax=1.0, shading="flat")
        scale = ", mesh-scale" if mode.mesh_scale else ""
        ax.set_title(f"k = {mode.k:+d}, m = {mode.axial_order}: {mode.frequency_hz:.1f} Hz, "
                     f"{mode.growth_rate:.1f} 1/s{scale}", fontsize=9)
        ax.set_xlabel("θ (deg)")
        ax.set_ylabel("z / L")
        ax.set_xlim(-step / 2, 360.0 - step / 2)
    for ax in list(axes.flat)[count:]:
        ax.set_visible(False)
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.8, label="Re u_θ (max |u_θ| = 1)")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
