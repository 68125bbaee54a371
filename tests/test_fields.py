"""Field output (solver.writers, solver.field_output): what is written, when, and its numbers.

The scene is the smoke tube (36 x 2 P1 triangles) started exactly at the discrete steady
sliding state (no bump), which the explicit scheme keeps to round-off: every written frame then
holds the steady state, whose contact pressure is known (``solver.steady``) and whose stress
has the closed form of the continuum (``semianalytic.steady``: u_r = d X(r),
u_θ = R v_e(r/R)). The files are read back with Debian's ADIOS2 Python module
(python3-adios2 + python3-adios2-mpi) where it is installed.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("dolfinx")

from mpi4py import MPI  # noqa: E402

from stickslip.semianalytic.steady import closed_form_steady  # noqa: E402
from stickslip.solver.field_output import (  # noqa: E402
    WindowCadence,
    expected_period,
    field_cadence,
    frame_count,
)
from stickslip.solver.scene import load_scene  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"
STEADY = ["initial.perturbation=none", "output.fields=true", "output.progress=false",
          "time.max_steps=30"]


def _adios2():
    """Debian's adios2 module with its MPI bindings (the serial ones are another package)."""
    os.environ.setdefault("ADIOS2_ALWAYS_USE_MPI", "1")
    return pytest.importorskip("adios2", reason="python3-adios2 (Debian) is not installed")


def _shared_dir(tmp_path: Path) -> Path:
    """One directory for all ranks (rank 0's tmp_path)."""
    return Path(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))


def _run_steady(tmp_path: Path, extra: list[str]):
    from stickslip.solver.run import Simulation

    scene = load_scene(SMOKE, [*STEADY, *extra])
    out = _shared_dir(tmp_path)
    sim = Simulation(scene, MPI.COMM_WORLD, output_dir=out)
    sim.proceed()
    if sim.columns.writer is not None:
        sim.columns.writer.close()
    return sim, out


def _closed_form_stress(scene, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """σ_rr, σ_θθ, σ_rθ [Pa] of the continuum steady sliding state at radius r [m]:
    u_r = d X, u_θ = d f X (1 + 1/(ξ²(1 − 2ν))) with X = (ξ² R/r − r/R)/(ξ² − 1)."""
    g, m = scene.geometry, scene.material
    R, xi, nu, d, f = g.R, g.xi, m.nu, g.d, scene.loading.f
    lam = m.E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = m.E / (2 * (1 + nu))
    X = (xi**2 * R / r - r / R) / (xi**2 - 1)
    dX = (-xi**2 * R / r**2 - 1 / R) / (xi**2 - 1)
    c_t = d * f * (1 + 1 / (xi**2 * (1 - 2 * nu)))
    e_rr, e_tt = d * dX, d * X / r
    s_rr = (lam + 2 * mu) * e_rr + lam * e_tt
    s_tt = lam * e_rr + (lam + 2 * mu) * e_tt
    s_rt = mu * (c_t * dX - c_t * X / r)
    return s_rr, s_tt, s_rt


def test_window_rule_and_cadence():
    """The default window is field_periods periods of the reduced model's mode-k flutter; the
    written levels are multiples of the cadence inside it, counted by frame_count."""
    from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
    from stickslip.semianalytic.flutter import dispersion_roots

    scene = load_scene(SMOKE)
    m, g, ld = scene.material, scene.geometry, scene.loading
    co = coefficients(m.nu, g.xi, gamma_from_physical(m.wave_speed, g.R, ld.omega))
    w = dispersion_roots(co, ld.f, scene.initial.mode)[0]
    # T = 2π/(|Re ω| Ω) from the dispersion relation directly (round-off only: 1e-12)
    assert expected_period(scene) == pytest.approx(2 * math.pi / (abs(w.real) * ld.omega),
                                                   rel=1e-12)
    dt, steps = 1e-5, 1000
    every = round(scene.output.field_interval / dt)
    window = scene.output.field_periods * expected_period(scene)
    c = field_cadence(scene, dt, steps)
    written = [n for n in range(steps) if c.at(n)]
    assert written and all(n % every == 0 for n in written)
    assert written[0] * dt >= steps * dt - window - 1e-12  # nothing before the window
    assert (written[0] - every) * dt < steps * dt - window  # the first one inside it
    assert frame_count(scene, dt, steps) == len(written)
    # next_level finds each written level from anywhere before it
    assert [c.next_level(n) for n in (0, written[0], written[0] + 1)] == \
        [written[0], written[0], written[1]]
    # a window longer than the run: every multiple of the cadence from level 0
    long = scene.with_overrides("output.field_window=10")
    assert frame_count(long, dt, steps) == len(range(0, steps, every))
    assert WindowCadence(5, 10).next_level(11) == 15


@pytest.mark.parallel
def test_steady_fields_in_memory(tmp_path):
    """The last frame of a steady run: p and q = f p at every contact node are the steady
    state's, all nodes slip, v = 0, and the cell stress is the closed form's (P1 error)."""
    sim, _ = _run_steady(tmp_path, ["output.field_window=1"])
    w, sc = sim.columns.writer, sim.scene
    nodes = sim.problem.nodes.nodes
    p = w.pressure.x.array[nodes]
    # the scheme keeps the discrete steady state to round-off (1e-9 relative)
    assert p == pytest.approx(sim.columns.steady.pressure, rel=1e-9)
    assert w.shear.x.array[nodes] == pytest.approx(sc.loading.f * p, rel=1e-9)
    assert np.all(w.status.x.array[nodes] == 2)  # SLIP
    away = np.setdiff1d(np.arange(sim.problem.n_owned // 2), nodes)
    assert np.all(w.status.x.array[away] == -1) and np.all(w.pressure.x.array[away] == 0)
    scale = sc.material.wave_speed * sc.geometry.delta  # |v| scale of a wave, m/s
    assert np.max(np.abs(w.v.x.array)) < 1e-9 * scale
    # stress: cell averages vs the continuum at the cell centroid radius. The P1 stress is
    # first order: measured per-cell errors of 11.4 / 5.9 / 3.0 % of max |σ| at
    # (36 x 2, 72 x 4, 144 x 8) cells, halving with h, and the mean over the cells within
    # 1.4 % here: the bounds are 15 % and 2 % on this 36 x 2 mesh.
    cells = w.stress[0].function_space
    x = cells.tabulate_dof_coordinates()[: w.n_cells]
    ref = _closed_form_stress(sc, np.hypot(x[:, 0], x[:, 1]))
    top = max(np.max(np.abs(c)) for c in ref)
    for fn, exact in zip(w.stress[:3], ref, strict=True):
        error = fn.x.array[: w.n_cells] - exact
        assert np.max(np.abs(error)) < 0.15 * top
        assert abs(np.mean(error)) < 0.02 * top
    s_rr, s_tt, s_rt = (fn.x.array[: w.n_cells] for fn in w.stress[:3])
    s_zz = sc.material.nu * (s_rr + s_tt)
    vm = np.sqrt(0.5 * ((s_rr - s_tt) ** 2 + (s_tt - s_zz) ** 2 + (s_zz - s_rr) ** 2)
                 + 3 * s_rt**2)
    # von Mises is invariant under the rotation to polar axes and constant per P1 cell, so
    # it equals the formula of the averaged components up to O(h²) of the frame's turn
    # across a cell (10° here: 1 %)
    assert np.max(np.abs(w.stress[3].x.array[: w.n_cells] - vm)) < 0.01 * np.max(vm)
    # the pressure against the continuum's p_e E (paper section 2): the 36-node circle is
    # 0.5 % off (2.211 vs 2.222 MPa, 2.2215 at 144 nodes); bound 1 %
    g, m = sc.geometry, sc.material
    p_e = closed_form_steady(1.0, delta=g.delta, f=sc.loading.f, nu=m.nu, xi=g.xi)[2]
    assert float(np.mean(p)) == pytest.approx(p_e * m.E, rel=0.01)


def _read_bp(path: Path, names: tuple[str, ...]) -> list[dict]:
    """Every step of a .bp folder: {"step": t, name: array, "geometry", "connectivity"}, the
    blocks (one per writing rank, local connectivity) joined into one mesh. A mesh written
    only once (fields.bp) is carried to the later steps."""
    adios2 = _adios2()
    frames, mesh = [], {}
    with adios2.Stream(str(path), "r") as s:
        for _ in s.steps():
            available = s.available_variables()
            if "connectivity" in available:
                n_blocks = np.ravel(s.read("NumberOfNodes")).size
                geo = [np.asarray(s.read("geometry", block_id=b)) for b in range(n_blocks)]
                offsets = np.cumsum([0, *(g.shape[0] for g in geo[:-1])])
                conn = [np.asarray(s.read("connectivity", block_id=b))[:, 1:] + off
                        for b, off in zip(range(n_blocks), offsets, strict=True)]
                mesh = {"geometry": np.concatenate(geo), "connectivity": np.concatenate(conn),
                        "blocks": n_blocks}
            frame = {"step": float(np.ravel(s.read("step"))[0]), **mesh}
            for key in names:
                parts = [np.asarray(s.read(key, block_id=b)) for b in range(mesh["blocks"])]
                frame[key] = np.concatenate([p.reshape(p.shape[0], -1) for p in parts])
            frames.append(frame)
    return frames


@pytest.mark.parallel
def test_vtx_files_read_back(tmp_path):
    """fields.bp and stress.bp hold the written levels t_n = n dt of the cadence, and their
    numbers: p = steady pressure at r = R (0 elsewhere), von Mises from the file's own
    displacement (numpy, P1 gradients: an independent computation), under MPI too."""
    sim, out = _run_steady(tmp_path, ["output.field_window=1", "output.field_interval=2e-4"])
    every = sim.observers[0].cadence.every
    steps = sim.steps
    expected = [n * sim.dt for n in range(0, steps, every)]
    fields = _read_bp(out / "fields.bp", ("displacement", "contact_pressure", "contact_shear",
                                          "contact_status", "velocity"))
    stress = _read_bp(out / "stress.bp", ("von_mises", "sigma_rr", "sigma_tt"))
    # levels n = 0, every, 2 every, ... written at t_n = n dt (1e-12 rel: the same float ops)
    assert [f["step"] for f in fields] == pytest.approx(expected, rel=1e-12)
    assert [f["step"] for f in stress] == pytest.approx(expected, rel=1e-12)
    sc = sim.scene
    p_sum = MPI.COMM_WORLD.allreduce(float(np.sum(sim.columns.steady.pressure)))
    p_mean = p_sum / MPI.COMM_WORLD.allreduce(sim.columns.steady.pressure.size)
    x0 = fields[0]["geometry"]
    r = np.hypot(x0[:, 0], x0[:, 1])
    on = np.abs(r - sc.geometry.R) < 1e-9
    for f, s in zip(fields, stress, strict=True):
        p = np.ravel(f["contact_pressure"])
        # uniform steady pressure at r = R: the discrete state varies by < 1e-6 around the
        # circle (a rotation-invariant mesh) and is kept to round-off
        assert p[on] == pytest.approx(p_mean, rel=1e-6)
        assert np.all(p[~on] == 0.0)
        assert np.ravel(f["contact_shear"])[on] == pytest.approx(sc.loading.f * p_mean,
                                                                 rel=1e-6)
        assert np.all(np.ravel(f["contact_status"])[on] == 2)
        # von Mises of the file's displacement, per cell, in numpy (plane strain)
        xy, conn = f["geometry"][:, :2], f["connectivity"]
        u = f["displacement"][:, :2]
        vm_file = _von_mises_p1(xy, conn, u, sc.material)
        cen_f = xy[conn].mean(axis=1)
        sxy = s["geometry"][:, :2]
        cen_s = sxy[s["connectivity"]].mean(axis=1)
        order_f, order_s = np.lexsort(np.round(cen_f.T, 9)), np.lexsort(np.round(cen_s.T, 9))
        assert np.allclose(cen_f[order_f], cen_s[order_s], atol=1e-12)
        vm = np.ravel(s["von_mises"])
        # invariant and constant per P1 cell; O(h²) of the frame's turn across a cell: 1 %
        assert np.max(np.abs(vm[order_s] - vm_file[order_f])) < 0.01 * np.max(vm_file)
        tr = np.ravel(s["sigma_rr"]) + np.ravel(s["sigma_tt"])
        tr_file = _trace_p1(xy, conn, u, sc.material)
        # σ_rr + σ_θθ = tr σ: invariant, and the cell average of a constant (1e-9 rel)
        assert tr[order_s] == pytest.approx(tr_file[order_f], rel=1e-9, abs=1e-9 * p_mean)


def _p1_strain(xy: np.ndarray, conn: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Per cell (ε_xx, ε_yy, ε_xy) of the P1 field u on triangles ``conn``."""
    p0, p1, p2 = xy[conn[:, 0]], xy[conn[:, 1]], xy[conn[:, 2]]
    J = np.stack([p1 - p0, p2 - p0], axis=2)  # columns: edge vectors
    du = np.stack([u[conn[:, 1]] - u[conn[:, 0]], u[conn[:, 2]] - u[conn[:, 0]]], axis=2)
    grad = du @ np.linalg.inv(J)  # ∂u_i/∂x_j
    return np.stack([grad[:, 0, 0], grad[:, 1, 1], 0.5 * (grad[:, 0, 1] + grad[:, 1, 0])], 1)


def _stress_p1(xy, conn, u, material):
    e = _p1_strain(xy, conn, u)
    nu, E = material.nu, material.E
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    tr = e[:, 0] + e[:, 1]
    return lam * tr + 2 * mu * e[:, 0], lam * tr + 2 * mu * e[:, 1], 2 * mu * e[:, 2]


def _trace_p1(xy, conn, u, material) -> np.ndarray:
    sxx, syy, _ = _stress_p1(xy, conn, u, material)
    return sxx + syy


def _von_mises_p1(xy, conn, u, material) -> np.ndarray:
    sxx, syy, sxy = _stress_p1(xy, conn, u, material)
    szz = material.nu * (sxx + syy)
    return np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                   + 3 * sxy**2)


def test_xdmf_format_still_written(tmp_path):
    """output.field_format = "xdmf": one fields.xdmf with the nodal and the cell fields."""
    import xml.etree.ElementTree as ET

    _, out = _run_steady(tmp_path, ["output.field_window=1", "output.field_format=xdmf",
                                    "output.field_interval=1e-3"])
    xdmf = out / "fields.xdmf"
    assert xdmf.is_file() and (out / "fields.h5").is_file()
    names = {a.get("Name") for a in ET.parse(xdmf).getroot().iter("Attribute")}
    assert names == {"displacement", "velocity", "contact_pressure", "contact_shear",
                     "contact_status", "sigma_rr", "sigma_tt", "sigma_rt", "von_mises"}


def test_estimate_and_disk_guard_count_the_fields(tmp_path, monkeypatch):
    """The size estimate adds the frames of the window; the disk guard refuses a run whose
    fields do not fit, naming the field keys in its fix."""
    import stickslip.studies.resources as resources

    plain = load_scene(SMOKE)
    with_fields = plain.with_overrides("output.fields=true", "output.field_window=0.01")
    a, b = resources.estimate(plain), resources.estimate(with_fields)
    assert a.field_frames == 0 and a.field_bytes == 0.0
    # 10 ms of window at the 1 ms cadence: 10 frames, 11 where a multiple of the cadence
    # falls on the window's first level
    assert b.field_frames in (10, 11)
    assert b.output_bytes == pytest.approx(a.output_bytes + b.field_bytes, rel=1e-12)
    assert "fields:" in b.line()
    monkeypatch.setattr(resources, "_free_disk", lambda _: b.output_bytes - 1.0)
    with pytest.raises(resources.ResourceError, match="output.field_interval"):
        resources.check_resources(with_fields, tmp_path)
    resources.check_resources(plain, tmp_path)  # the samples alone fit


@pytest.mark.parallel
def test_final_field_carries_stress_and_tractions(tmp_path):
    """final_field.npz (what --plot's stress map reads) holds the last level's p, q at the
    points (the steady pressure on r = R, 0 elsewhere) and the cell stress, over all ranks."""
    sim, _ = _run_steady(tmp_path, ["output.fields=false"])
    field = sim.final_field()
    if MPI.COMM_WORLD.rank != 0:
        assert field is None
        return
    n_cells = field["cell_types"].size
    assert all(field[k].shape == (n_cells,) for k in ("sigma_rr", "sigma_tt", "sigma_rt",
                                                     "von_mises"))
    r = np.hypot(field["points"][:, 0], field["points"][:, 1])
    on = np.abs(r - sim.scene.geometry.R) < 1e-9
    # uniform to 1e-6 (rotation-invariant mesh)
    p_mean = float(np.mean(sim.columns.steady.pressure))
    assert field["contact_pressure"][on] == pytest.approx(p_mean, rel=1e-6)
    assert np.all(field["contact_pressure"][~on] == 0.0)
    assert field["contact_shear"][on] == pytest.approx(sim.scene.loading.f * p_mean, rel=1e-6)
    # the steady σ_rr is compressive everywhere (-p at the circle, 0 < p): no cell above 0
    assert np.all(field["sigma_rr"] < 0.0)
    assert float(field["fields_time"]) == pytest.approx(float(field["time"]) - sim.dt,
                                                        rel=1e-12)
