"""Unstable CEA mode shapes for ParaView and for tables: ``stickslip flutter-fe --modes DIR``.

A mode is the real motion ``u(t) = Re(ψ e^{λt})`` (``studies.flutter_fe.cea``). The files:

* ``mode_NN.bp`` (VTX, ``dolfinx.io.VTXWriter``): the displacement ``Re(ψ e^{iφ})`` at 16
  phases ``φ`` of one period, time stamps ``φ / ω`` (s), so ParaView's play button animates the
  wave; without growth (the growth factor is left out, or one frame would dwarf the others).
* ``modes.csv``: the table (frequency, growth, damping ratio, k, direction, speed, purity,
  mesh-scale flag, file, axial order m: 0 in plane strain) in the order of ``NN``
  (``flutter-fe``: its table's order).
* ``contact.csv``: ``ψ_θ`` on the contact circle (``ψ_r = 0`` there: the sliding
  linearisation holds the contact nodes on the cylinder), per mode and node, by angle; on a
  finite 3D tube per mode, ring (``z_rel`` = z/L) and angle (``cea.contact_grid``).

``ψ`` is normalised so that ``max |ψ_θ|`` on the contact surface is 1 (arbitrary units: an
eigenvector has no amplitude), with ``ψ_θ`` real and positive at that node.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from stickslip.solver.atomic import atomic_write_text
from stickslip.studies.flutter_fe.cea import contact_grid

if TYPE_CHECKING:
    from stickslip.solver.problem import TubeProblem
    from stickslip.studies.flutter_fe.cea import CEAOperators, CEAResult

PHASES = 16  # frames of one period in each VTX file

__all__ = ["PHASES", "modes_dir_problem", "write_mode_shapes"]


def modes_dir_problem(path: str | Path) -> str | None:
    """Why ``--modes DIR`` cannot be written (one line), or None. DIR must be new or empty:
    mode files of an earlier analysis left beside new ones would be mistaken for its modes."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        return f"--modes {p} exists and is not a folder; give a new folder name"
    if p.is_dir() and any(p.iterdir()):
        return f"--modes {p} is not empty; give a new or empty folder (nothing is overwritten)"
    return None


def _displacement(ops: CEAOperators, problem: TubeProblem, free_vec: np.ndarray
                  ) -> np.ndarray:
    """Owned (x, y) dof values of ψ from its owned free-dof values (rotated frame)."""
    nd = problem.every_contact_node
    rot = np.zeros(problem.n_owned, dtype=complex)
    rot[ops.free] = free_vec
    u = rot.copy()
    ur, ut = rot[nd.dofs_x], rot[nd.dofs_y]
    u[nd.dofs_x] = nd.cos_t * ur - nd.sin_t * ut  # u = T ũ
    u[nd.dofs_y] = nd.sin_t * ur + nd.cos_t * ut
    return u


def _normalise(u: np.ndarray, psi_theta_all: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scale so that max |ψ_θ| = 1 with ψ_θ real > 0 there (``psi_theta_all``: every node)."""
    j = int(np.argmax(np.abs(psi_theta_all)))
    scale = 1.0 / psi_theta_all[j] if psi_theta_all[j] != 0 else 1.0
    return u * scale, psi_theta_all * scale


def _gather_contact(comm: Any, ops: CEAOperators, free_vec: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Angles and ψ_θ of every contact node (all ranks), sorted by angle."""
    psi = free_vec[ops.pos_theta]
    theta = np.concatenate(comm.allgather(np.asarray(ops.theta, dtype=float)))
    psi_all = np.concatenate(comm.allgather(psi))
    order = np.argsort(theta, kind="stable")
    return theta[order], psi_all[order]


def _contact_values(comm: Any, ops: CEAOperators, free_vec: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(θ, z/L, ψ_θ) of every contact node (all ranks): by angle on the plane-strain circle
    (z/L = 0), ring by ring and by angle on a 3D tube's surface (``contact_grid``)."""
    if ops.levels == 1:
        theta, psi = _gather_contact(comm, ops, free_vec)
        return theta, np.zeros(theta.size), psi
    grid = contact_grid(ops, free_vec, normalise=False)  # ``_normalise`` scales it with ψ
    rings, n = grid.values.shape
    return (np.tile(grid.theta, rings), np.repeat(grid.z_rel, n),
            grid.values.reshape(-1))


def _write_vtx(problem: TubeProblem, path: Path, u: np.ndarray, frequency_hz: float) -> None:
    """One period of ``Re(ψ e^{iφ})`` (PHASES frames; one frame without oscillation)."""
    import dolfinx.io

    fn = problem.to_function(u.real, name="u")
    omega = 2.0 * math.pi * frequency_hz
    frames = PHASES if omega > 0 else 1
    with dolfinx.io.VTXWriter(problem.comm, str(path), [fn], engine="BP4") as writer:
        for j in range(frames):
            phi = 2.0 * math.pi * j / frames
            fn.x.array[: problem.n_owned] = (u * np.exp(1j * phi)).real
            fn.x.scatter_forward()
            writer.write(phi / omega if omega > 0 else 0.0)


def write_mode_shapes(problem: TubeProblem, ops: CEAOperators, res: CEAResult,
                      out_dir: str | Path, indices: list[int] | None = None) -> dict[str, Any]:
    """Write the modes ``indices`` of ``res.modes``, in that order (default: every unstable
    mode kept with ``shapes=True``, most unstable first), as the module docstring describes.

    Collective (every rank calls it); rank 0 writes the CSV files. Returns
    ``{"dir", "count", "files"}``.
    """
    comm = problem.comm
    out = Path(out_dir)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    if indices is None:
        order = sorted(res.shapes, key=lambda i: -res.modes[i].growth_rate)
    else:
        order = [i for i in indices if i in res.shapes]
    table = ["index,frequency_hz,growth_rate_per_s,zeta,k,direction,phase_speed_m_s,purity,"
             "mesh_scale,file,axial_order"]
    tube = ops.levels > 1  # a finite 3D tube: the contact surface in rings
    contact = ["index," + ("z_rel," if tube else "")
               + "theta_deg,re_psi_theta,im_psi_theta,abs_psi_theta"]
    files = []
    for n, i in enumerate(order, start=1):
        m = res.modes[i]
        theta, z_rel, psi_theta = _contact_values(comm, ops, res.shapes[i])
        u, psi_theta = _normalise(_displacement(ops, problem, res.shapes[i]), psi_theta)
        name = f"mode_{n:02d}.bp"
        _write_vtx(problem, out / name, u, m.frequency_hz)
        files.append(name)
        table.append(f"{n},{m.frequency_hz:.6g},{m.growth_rate:.6g},{m.zeta:.6g},{m.k},"
                     f"{m.direction},{m.phase_speed_m_s:.6g},{m.purity:.4f},"
                     f"{str(m.mesh_scale).lower()},{name},{m.axial_order}")
        contact += [f"{n}," + (f"{z:.6f}," if tube else "")
                    + f"{math.degrees(t):.6f},{p.real:.8g},{p.imag:.8g},{abs(p):.8g}"
                    for z, t, p in zip(z_rel, theta, psi_theta, strict=True)]
    if comm.rank == 0:
        atomic_write_text(out / "modes.csv", "\n".join(table) + "\n")
        atomic_write_text(out / "contact.csv", "\n".join(contact) + "\n")
    return {"dir": str(out), "count": len(order), "files": files}
