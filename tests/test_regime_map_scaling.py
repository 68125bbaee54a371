"""The Omega x delta regime map depends on delta/Omega only (docs/sweeps.md, damped map).

Linear elasticity with Kelvin-Voigt damping, unilateral contact and Coulomb friction are
positively homogeneous of degree 1: scaling the mismatch d and the rotation Omega by lambda
(with the seed amplitude ~ d) scales the whole solution by lambda at the same dt. This is what
makes every cell of sweeps/omega_delta_damped.toml with the same delta/Omega identical.
"""
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def _run(out: Path, omega: float, delta: float) -> dict:
    subprocess.run(
        [sys.executable, "-m", "stickslip.cli.main", "run", str(REPO / "scenes" / "figure3_n132_damped.toml"),
         "-o", str(out), "--force", "--set", "mesh.n_inner=36", "--set", "time.end_time=0.01",
         "--set", f"loading.omega={omega}", "--set", f"geometry.delta={delta}"],
        check=True, cwd=REPO, capture_output=True)
    with np.load(out / "samples.npz") as d:
        return {k: d[k] for k in ("u_r", "u_theta", "status")}


def test_damped_solution_scales_with_delta_and_omega(tmp_path: Path) -> None:
    a = _run(tmp_path / "a", 10.0, 5e-4)
    b = _run(tmp_path / "b", 40.0, 2e-3)   # lambda = 4: a power of two, so scaling is exact
    assert np.array_equal(a["status"], b["status"])  # same stick/slip/separation pattern
    for key in ("u_r", "u_theta"):
        # Homogeneity is exact; only round-off of sums differs (1e-9 of the amplitude is
        # ~1e6 times the float64 epsilon accumulated over ~400 steps).
        scale = np.abs(b[key]).max()
        assert np.abs(b[key] - 4.0 * a[key]).max() <= 1e-9 * scale, key
