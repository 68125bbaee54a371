"""The finite tube's transient: does the plane-strain wave survive free ends, and which axial
structure does it take?

    ./dev python3 benchmarks/tube3d_transient.py [SCENE] [--lengths 0.25 0.5 1 2]
        [--ends free] [--n-axial N_z ...] [--control L/R] [--out DIR] [--set KEY=VALUE ...]

For the scene (default ``figure3_n132_damped``: Figure-3 physics, R = 1 m, xi = 1.25,
N = 132, Kelvin-Voigt 2 % at 1.6 kHz, beta_2 = 1/2, mode-4 bump of 0.1 d, 0.3 s) in
quadrilaterals, it runs the plane-strain scene and, for each L/R of ``--lengths``, the 3D
tube (``mesh.dim = 3``, N_z = round(L N / (2 pi R)) layers, the same start extruded along z)
at the plane-strain run's step (``time.dt``, unless ``--set time.dt=...`` gives one: the
same N, dt, beta_2, damping and start)
with ``stickslip.run``, and prints one row each: the wave of the mid-length ring (k,
celerity, frequency, zone fractions: the plane-strain analysis of ``samples.npz``), and its
axial structure from ``surface.npz`` (``postprocess.surface_map.axial_structure``): the
amplitude of its k-th harmonic at the end, the quarter and the middle of the tube relative
to its largest, and its phase at the end against the middle.
``--n-axial`` runs the first length at each of these layer counts instead (the convergence
in N_z). A control case runs the first length with roller ends: the plane-strain fields are then a
subspace of the 3D tube's (tests/test_tube3d_transient.py), so it must give the
plane-strain wave unless the round-off, amplified by the flutter, takes another attractor.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from stickslip import run
from stickslip.postprocess.surface_map import axial_structure
from stickslip.solver.scene import load_scene


def row(label: str, summary: dict, surface: dict | None, seconds: float) -> str:
    if "fractions" not in summary:  # a run that did not reach the wave analysis
        return f"| {label} | {summary['status']}: {summary.get('message', '')} |"
    fr = summary["fractions"]
    k = int(summary["mode"])
    shape, lag = "uniform", "0"
    if surface is not None and k:
        axial = axial_structure(surface, k)
        profile, levels = axial["profile"], len(axial["profile"]) - 1
        shape = (f"{profile[0]:.2f} / {profile[levels // 4]:.2f} / "
                 f"{profile[levels // 2]:.2f}")
        lag = f"{axial['end_phase_deg']:+.0f}"
    return (f"| {label} | {summary['dofs']} | {summary['regime']} | {k} | "
            f"{summary['celerity_m_s']:.1f} | {summary['frequency_hz']:.1f} | "
            f"{fr['separation']:.3f} / {fr['stick']:.3f} / {fr['slip']:.3f} | {shape} | "
            f"{lag} | {seconds:.0f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="figure3_n132_damped")
    parser.add_argument("--lengths", type=float, nargs="+", default=[0.25, 0.5, 1.0, 2.0])
    parser.add_argument("--ends", default="free")
    parser.add_argument("--out", default="/tmp/tube3d_transient")
    parser.add_argument("--n-axial", type=int, nargs="+", default=[],
                        help="the first length at each of these layer counts (convergence)")
    parser.add_argument("--control", type=float, default=None,
                        help="L/R of the roller control (default: the first length)")
    parser.add_argument("--set", dest="sets", action="append", default=[])
    args = parser.parse_args()
    base = ["mesh.cell=quadrilateral", *args.sets]
    radius = load_scene(args.scene, base).geometry.R
    cases = [("plane strain", base)]
    cases += [(f"L/R = {ratio:g}, {args.ends}",
               [*base, "mesh.dim=3", f"geometry.length={ratio * radius}",
                f"boundary.ends={args.ends}"])
              for ratio in args.lengths if not args.n_axial]
    cases += [(f"L/R = {args.lengths[0]:g}, {args.ends}, N_z = {layers}",
               [*base, "mesh.dim=3", f"geometry.length={args.lengths[0] * radius}",
                f"boundary.ends={args.ends}", f"mesh.n_axial={layers}"])
              for layers in args.n_axial]
    control = args.lengths[0] if args.control is None else args.control
    cases.append((f"L/R = {control:g}, roller (control)",
                  [*base, "mesh.dim=3", f"geometry.length={control * radius}",
                   "boundary.ends=roller"]))
    print("| tube | dofs | regime | k | celerity m/s | frequency Hz | sep / stick / slip "
          "| A_k end / quarter / middle | end phase deg | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    step: list[str] = []  # the plane-strain run's dt, for every tube after it
    for i, (label, overrides) in enumerate(cases):
        out = Path(args.out) / f"case{i}"
        t0 = time.perf_counter()
        summary = run(args.scene, out, overrides=[*overrides, *step], force=True, quiet=True)
        seconds = time.perf_counter() - t0
        given = any(kv.startswith("time.dt=") for kv in args.sets)  # the user's step
        step = step or ([] if given else [f"time.dt={summary['dt_s']!r}"])
        path = out / "surface.npz"
        surface = dict(np.load(path)) if path.exists() else None
        print(row(label, summary, surface, seconds), flush=True)


if __name__ == "__main__":
    main()
