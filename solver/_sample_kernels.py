"""numba kernels of a batch's records (``solver.ensemble_observers.BatchRecorder``: the
samples and the every-step probes).

Copies only: each moves values from the stepper's (n, B) and (m, B) arrays into the
record's scene-major rows, as the numpy indexing it replaces did, so the bits are the
same; the complex multiply by e^{-iθ} of a sample stays numpy's (its SIMD loop may fuse
multiply-adds). Two compiled calls instead of about twenty small numpy operations per
sample, one instead of three per step for the probes. In a file of their own so that
their disk cache and ``solver._fused_kernels``' do not invalidate each other.
"""

from __future__ import annotations

import numba

jit = numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")


@jit
def gather_sample(u, v, r_r, r_t, status, cx, perm, zu, zv, row, row_status):
    """Contact node j (angle order) of scene b: zu[b, j] = u_x + i u_y and zv[b, j] = v_x +
    i v_y at its dofs ``cx[j]``, ``cx[j] + 1``; row[b, 4, j] = r_r, row[b, 5, j] = r_t and
    row_status[b, j] = status at its contact index ``perm[j]``."""
    nb = zu.shape[0]
    for j in range(cx.size):
        ix = cx[j]
        p = perm[j]
        for b in range(nb):
            zu[b, j] = complex(u[ix, b], u[ix + 1, b])
            zv[b, j] = complex(v[ix, b], v[ix + 1, b])
            row[b, 4, j] = r_r[p, b]
            row[b, 5, j] = r_t[p, b]
            row_status[b, j] = status[p, b]


@jit
def scatter_polar(zu, zv, row):
    """row[b, 0:4, j] = (Re zu, Im zu, Re zv, Im zv)[b, j]: u_r, u_θ, v_r, v_θ."""
    nb, m = zu.shape
    for b in range(nb):
        for j in range(m):
            row[b, 0, j] = zu[b, j].real
            row[b, 1, j] = zu[b, j].imag
            row[b, 2, j] = zv[b, j].real
            row[b, 3, j] = zv[b, j].imag


@jit
def gather_probes(u, v, x_dofs, row):
    """Probe p of scene b: row[b, :, p] = (u_x, u_y, v_x, v_y) at its node's dofs
    ``x_dofs[p]``, ``x_dofs[p] + 1``."""
    nb = row.shape[0]
    for p in range(x_dofs.size):
        i = x_dofs[p]
        for b in range(nb):
            row[b, 0, p] = u[i, b]
            row[b, 1, p] = u[i + 1, b]
            row[b, 2, p] = v[i, b]
            row[b, 3, p] = v[i + 1, b]


@jit
def sample_one(i, u, u_next, v, ku, mass, r_r, r_t, status, node_x, perm, work, u0_ku0,
               damped, fields, status_rows, energies):
    """Row ``i`` of a batch of one's record in one pass (columns of (n, 1) arrays):
    fields[i, 0:4, j] = the CARTESIAN (x, y) of u_n and v_n at contact node j in angle order
    (``node_x[j]``: its x dof; ``BatchRecorder`` turns them to (r, θ) with numpy's complex
    multiply when they are read), fields[i, 4:6, j] = r_r, r_t and status_rows[i, j] = the
    status at its contact index ``perm[j]``; energies[i] = (½ Σ m v², ½ Σ u K u, the three
    works of ``work``, W_d = work[3] − ½ (u_{n+1} · K u_n − u_0 · K u_0) when ``damped``, else
    0), the sums in row order from 0.0 (``column_energies``, ``column_dots``: the same
    bits). ``u`` is u_n, ``u_next`` u_{n+1}, ``ku`` K u_n."""
    kin = 0.0
    strain = 0.0
    for k in range(u.shape[0]):
        vk = v[k, 0]
        kin += vk * mass[k] * vk
        strain += u[k, 0] * ku[k, 0]
    energies[i, 0] = kin * 0.5
    energies[i, 1] = strain * 0.5
    energies[i, 2] = work[0, 0]
    energies[i, 3] = work[1, 0]
    energies[i, 4] = work[2, 0]
    energies[i, 5] = 0.0
    if damped:
        dot = 0.0
        for k in range(u.shape[0]):
            dot += u_next[k, 0] * ku[k, 0]
        energies[i, 5] = work[3, 0] - 0.5 * (dot - u0_ku0[0])
    for j in range(node_x.size):
        ix = node_x[j]
        fields[i, 0, j] = u[ix, 0]
        fields[i, 1, j] = u[ix + 1, 0]
        fields[i, 2, j] = v[ix, 0]
        fields[i, 3, j] = v[ix + 1, 0]
        p = perm[j]
        fields[i, 4, j] = r_r[p, 0]
        fields[i, 5, j] = r_t[p, 0]
        status_rows[i, j] = status[p, 0]
