"""numba kernels of ``solver.fused`` (imported lazily: numba costs ~0.4 s to import).

Module-level functions so that ``cache=True`` can store their machine code on disk.
See ``solver.fused`` for the equations and the summation-order contract.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from stickslip.solver.contact.law import (  # the law's codes, frozen at compile
    SEPARATION,
    SLIP,
    STICK,
)

U1, U2, U3 = np.uint64(1), np.uint64(2), np.uint64(3)  # unsigned offsets: no wrap-around test
# Why three loop orders (same arithmetic, same bits): one scene runs the single-scene
# kernel, register passes win for short batches, B-long vector loops for long ones
# (``batched_kernel_name``, measured below).
#: A batch of one runs ``single_step`` on its column: at B = 1 ``batched_step`` pays its
#: block scratch and a per-node column product for nothing, 1.8x slower at N = 528 damped
#: (244 against 450 us a step) and 2.0x at N = 132 (16 against 33 us). After the 4-scene
#: passes, 2 scenes go together (``half_product2``): B = 2 and 3 then cost 1.3x less per
#: scene-step than column by column (N = 528: 264 against 332 us at B = 2; B = 4 and 8
#: unchanged) (``benchmarks/small_batches.py``).
#: nodes per block of ``batched_step``: its scratch ``acc`` is (2 NODE_BLOCK, B) at least,
#: (4 NODE_BLOCK, B) with damping (K w_n of the block from row KW_ROW on)
NODE_BLOCK = 32
KW_ROW = 2 * NODE_BLOCK
#: from this B on the batch runs ``batched_step_long`` (B-long vector loops) instead of
#: ``batched_step`` (4-scene register passes): at N = 528 the passes are 1.7x faster at
#: B = 8 and 1.2x slower at B = 16 (benchmarks/batched_step_ab.py; docs/performance.md)
LONG_B = 16
#: ... unless K is small: the passes read K's CSR once per 4 scenes, which costs little
#: while it stays in a core's L2 cache (1 MiB here; half of it for K). Then they run up to
#: B < SMALL_K_LONG_B: at N = 132 (K 0.27 MB) they are 1.04-1.3x faster at B = 32 and
#: 1.2x slower at B = 48 (``benchmarks/batched_step_ab.py --both``)
SMALL_K_BYTES = 1 << 19
SMALL_K_LONG_B = 48


def batched_kernel_name(B: int, k_bytes: int) -> str:
    """``single_step`` for a batch of one, else ``batched_step`` (4-scene register passes)
    or ``batched_step_long`` (B-long vector loops) for a batch of B scenes whose K's CSR
    (values + column indices) is ``k_bytes``: the fastest on the measurements above. Same
    bits each way."""
    if B == 1:
        return "single_step"
    long_from = SMALL_K_LONG_B if k_bytes <= SMALL_K_BYTES else LONG_B
    return "batched_step" if B < long_from else "batched_step_long"

jit = numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy")
inline = numba.njit(inline="always", cache=True, fastmath=False, error_model="numpy")


@inline
def project(tr, tt, now_t, stiff, d, slide, f):
    """Nodal law (solver.contact.project_contact), same operations: (r_r, r_t, status)."""
    rr = d - tr
    if rr < 0.0:  # np.maximum(rr, 0): NaN stays NaN (blow-ups must show)
        rr = 0.0
    rr = rr * stiff
    inc = rr > 0.0
    if f == 0.0:
        return rr, 0.0, SLIP if inc else SEPARATION
    rt = now_t + slide
    rt = rt - tt
    rt = rt * stiff
    cone = rr * f
    if abs(rt) > cone:
        return rr, math.copysign(cone, rt), SLIP if inc else SEPARATION
    return rr, rt, STICK if inc else SEPARATION


@inline
def project_regularised(tr, tt, now_t, stiff, d, slide, f, reg, sigma, ut_last, j, b,
                        rate_slip, rate_base, dt, first):
    """``project`` with a regularised bound f sigma_eff (``reg`` > 0: any
    ``solver.contact.law.Regularisation``, by its two rates), the operations of
    ``solver.contact.nodal.project_contact_regularized``: the normal force, then
    sigma_eff[j, b] relaxed exactly towards p over dt at rate = |V dt| rate_slip + rate_base,
    V dt the last step's slip (``EffectivePressure.update``; a slip-independent rate,
    rate_slip = 0, is rate_base itself; sigma_eff = p and the last u_theta = u_theta,n at
    the first step), then the tangential projection inside f sigma_eff (zero off
    contact)."""
    rr = d - tr
    if rr < 0.0:
        rr = 0.0
    rr = rr * stiff
    inc = rr > 0.0
    if first:
        sigma[j, b] = rr
        ut_last[j, b] = now_t
    if rate_slip != 0.0:  # e.g. (|V| + V*) / L, V dt = u_theta,n - u_theta,{n-1} - R Omega dt
        rate = now_t - ut_last[j, b]
        rate = rate - slide
        rate = abs(rate) * rate_slip
        rate = rate + rate_base
    else:  # e.g. 1 / t*
        rate = rate_base
    decay = math.exp(rate * -dt)
    sg = sigma[j, b] - rr
    sg = sg * decay
    sg = sg + rr
    sigma[j, b] = sg
    ut_last[j, b] = now_t
    cone = sg * f
    cone = cone * (1.0 if inc else 0.0)
    rt = now_t + slide
    rt = rt - tt
    rt = rt * stiff
    if abs(rt) > cone:
        return rr, math.copysign(cone, rt), SLIP if inc else SEPARATION
    return rr, rt, STICK if inc else SEPARATION


@inline
def contact_reaction(ux, uy, vx, vy, ax, ay, c_re, c_im, h_re, h_im, dt, kappa, stiff,
                     d, slide, f, reg, sigma, ut_last, j, b, rate_slip, rate_base, first):
    """Forward-increment contact at one node of one scene, from u_n = (ux, uy), v~_n and
    a*_n: the trial position u_n + dt v~_n + κ a*_n turned to polar components by
    (c_re, c_im) = e^{-iθ}, the nodal law ``project`` (``project_regularised`` with a
    Prakash-Clifton state, reg > 0), and the reaction turned back by
    (h_re, h_im) = e^{iθ}. Returns (r_r, r_t, status, r_x, r_y). Shared by ``single_step``,
    ``batched_step`` and ``batched_step_long`` so that they run the same operations."""
    now_r = ux * c_re - uy * c_im
    now_t = ux * c_im + uy * c_re
    tx = vx * dt + ax * kappa
    ty = vy * dt + ay * kappa
    tr = (tx * c_re - ty * c_im) + now_r
    tt = (tx * c_im + ty * c_re) + now_t
    if reg == 0:
        rr, rt, st = project(tr, tt, now_t, stiff, d, slide, f)
    else:
        rr, rt, st = project_regularised(tr, tt, now_t, stiff, d, slide, f, reg, sigma,
                                         ut_last, j, b, rate_slip, rate_base, dt, first)
    rx = rr * h_re - rt * h_im
    ry = rr * h_im + rt * h_re
    return rr, rt, st, rx, ry


@inline
def pair_product(indptr, indices, data, u, i):
    """Rows i, i + 1 of K u (same column pattern: the x and y rows of one node).

    Each row is summed as (even terms) + (odd terms) of its CSR order: four independent
    chains per pass instead of one, and one column-index load for both rows. The batched
    kernel sums in exactly this order, so a scene alone and in a batch agree bitwise.
    """
    a0 = indptr[i]
    a1 = indptr[i + 1]
    ln = a1 - a0
    s0e = 0.0
    s0o = 0.0
    s1e = 0.0
    s1o = 0.0
    t = 0
    while t + 1 < ln:
        c0 = u[indices[a0 + t]]
        c1 = u[indices[a0 + t + 1]]
        s0e += data[a0 + t] * c0
        s0o += data[a0 + t + 1] * c1
        s1e += data[a1 + t] * c0
        s1o += data[a1 + t + 1] * c1
        t += 2
    if t < ln:
        c0 = u[indices[a0 + t]]
        s0e += data[a0 + t] * c0
        s1e += data[a1 + t] * c0
    return s0e + s0o, s1e + s1o


@jit
def pair_product_col(indices, data, u, a0, a1, b):
    """``pair_product`` on column b of an (n, B) u (same order; unsigned a0, a1, b)."""
    s0e = 0.0
    s0o = 0.0
    s1e = 0.0
    s1o = 0.0
    ln = a1 - a0
    p = a0
    r = a1
    end = a0 + (ln - ln % U2)
    while p < end:
        c0 = u[indices[p], b]
        c1 = u[indices[p + U1], b]
        s0e += data[p] * c0
        s0o += data[p + U1] * c1
        s1e += data[r] * c0
        s1o += data[r + U1] * c1
        p += U2
        r += U2
    if ln % U2 != 0:
        c0 = u[indices[p], b]
        s0e += data[p] * c0
        s1e += data[r] * c0
    return s0e + s0o, s1e + s1o


@jit
def half_product4(indices, data, u, p, r, end, b0):
    """Every second term of rows i (from ``p``) and i + 1 (from ``r``) of K u, for columns
    b0 .. b0 + 3 of an (n, B) u: the even (``p = a0``) or odd (``p = a0 + 1``) partial sums
    of ``pair_product``, each a sequential sum from 0.0 in CSR order.

    The 8 sums are scalar locals that LLVM's SLP vectoriser packs into two 4-wide
    registers (``solver.fused.slp_vectorize``); each (column index, K value) load serves
    4 scenes. Offsets are unsigned (uint64) so that numba emits no negative-index
    wrap-around test. Returns (row i: b0 .. b0 + 3, row i + 1: b0 .. b0 + 3).
    """
    b1 = b0 + U1
    b2 = b0 + U2
    b3 = b0 + U3
    x0 = 0.0
    x1 = 0.0
    x2 = 0.0
    x3 = 0.0
    y0 = 0.0
    y1 = 0.0
    y2 = 0.0
    y3 = 0.0
    while p < end:
        c = indices[p]
        dp = data[p]
        dq = data[r]
        w0 = u[c, b0]
        w1 = u[c, b1]
        w2 = u[c, b2]
        w3 = u[c, b3]
        x0 += dp * w0
        x1 += dp * w1
        x2 += dp * w2
        x3 += dp * w3
        y0 += dq * w0
        y1 += dq * w1
        y2 += dq * w2
        y3 += dq * w3
        p += U2
        r += U2
    return x0, x1, x2, x3, y0, y1, y2, y3


@jit
def half_product2(indices, data, u, p, r, end, b0):
    """``half_product4`` for the 2 columns b0, b0 + 1 (the rest of a batch after its
    4-scene passes): the same sequential sums, each (column index, K value) load serving 2
    scenes. Returns (row i: b0, b0 + 1, row i + 1: b0, b0 + 1). Written out, not a width
    parameter of ``half_product4``: numba keeps the sums in registers only as named
    scalars, and two calls of a 2-wide pass would load K twice per 4 scenes."""
    b1 = b0 + U1
    x0 = 0.0
    x1 = 0.0
    y0 = 0.0
    y1 = 0.0
    while p < end:
        c = indices[p]
        dp = data[p]
        dq = data[r]
        w0 = u[c, b0]
        w1 = u[c, b1]
        x0 += dp * w0
        x1 += dp * w1
        y0 += dq * w0
        y1 += dq * w1
        p += U2
        r += U2
    return x0, x1, y0, y1


@jit
def single_step(indptr, indices, data, n_rows, u, u_next, v, vp, a, ku, nim,
                c_v, c_w, c_p, b2_half, dt, kappa, inv_kappa,
                cx, ph_re, ph_im, pc_re, pc_im, cmass, cinv,
                d, slide, f, r_r, r_t, r_x, r_y, status, zprev, work, u_tau, u_tau_next, tau,
                reg, sigma, ut_last, rate_slip, rate_base, started):
    """One explicit step of one scene (``solver.fused`` docstring). With Kelvin-Voigt
    damping (``tau > 0``, ``solver.ensemble.internal_force``) the internal force is K w_n,
    w_n = u_n + tau v~_n, read from ``u_tau`` (the previous step, or the caller at the
    start, formed it; a caller with ghosts has updated them), ``u_tau_next`` receives
    w_{n+1} = u_{n+1} + tau v~_{n+1} (the caller alternates the two, as u, and as
    ``batched_step`` does), ``ku`` receives K w_n, and work[3] accumulates the damping
    work's per-step part 1/2 (K w_n . u_{n+1} - K w_n . u_{n-1})
    (``solver.observers.DampingWork``), read from ``u_next`` before it is overwritten (it
    holds u_{n-1}). Undamped (``tau = 0``) the
    product reads ``u`` and the arithmetic is the plain step's. A regularised friction
    bound (``reg`` > 0) keeps its per-node state in ``sigma``, ``ut_last`` (m, 1);
    ``started[0]`` = 0 before the first step (``project_regularised``).

    The contact outputs r_r, r_t, r_x, r_y and ``status`` are (m,) arrays of any stride
    (the projection's interleaved pairs, or column 0 of a batch of one: the same kernel
    steps both, ``solver.ensemble.NumbaColumns``); ``zprev`` holds u_{n-1} at the contact
    nodes as (x, y) pairs."""
    damped = tau > 0.0
    src = u_tau if damped else u
    # K u_n (K w_n damped) and a*_n = -M^{-1} K u_n (owned rows; columns may be ghosts)
    for i in range(0, n_rows, 2):
        s0, s1 = pair_product(indptr, indices, data, src, i)
        ku[i] = s0
        ku[i + 1] = s1
        a[i] = s0 * nim[i]
        a[i + 1] = s1 * nim[i + 1]
    # forward-increment contact at the contact nodes (polar frame via e^{-i theta})
    for j in range(cx.size):
        ix = cx[j]
        iy = ix + 1
        rr, rt, st, rx, ry = contact_reaction(
            u[ix], u[iy], vp[ix], vp[iy], a[ix], a[iy], pc_re[j], pc_im[j], ph_re[j],
            ph_im[j], dt, kappa, cmass[j] * inv_kappa, d, slide, f, reg, sigma, ut_last, j,
            0, rate_slip, rate_base, started[0] == 0)
        r_r[j] = rr
        r_t[j] = rt
        status[j] = st
        r_x[j] = rx
        r_y[j] = ry
        a[ix] = a[ix] + rx * cinv[j]
        a[iy] = a[iy] + ry * cinv[j]
    started[0] = 1
    # Newmark: v_n, w, u_{n+1}, v~_{n+1}
    if damped:  # the same update, plus K w_n . u_{n+1} and K w_n . u_{n-1} in row order
        s_new = 0.0
        s_old = 0.0
        for i in range(n_rows):
            ai = a[i]
            vi = ai * c_v + vp[i]
            v[i] = vi
            w = ai * c_w + vi
            un = w * dt + u[i]
            kwi = ku[i]
            s_new += kwi * un
            s_old += kwi * u_next[i]
            u_next[i] = un
            vp[i] = w if b2_half else w + ai * c_p
            u_tau_next[i] = vp[i] * tau + un  # w_{n+1} (ArrayColumns: v~ tau, then + u)
        work[3] += 0.5 * (s_new - s_old)
    else:
        for i in range(n_rows):
            ai = a[i]
            vi = ai * c_v + vp[i]
            v[i] = vi
            w = ai * c_w + vi
            u_next[i] = w * dt + u[i]
            vp[i] = w if b2_half else w + ai * c_p
    # contact work with the centred increment u_{n+1} - u_{n-1} (EnergyAccumulator)
    sc = 0.0
    st_ = 0.0
    srt = 0.0
    for j in range(cx.size):
        ix = cx[j]
        dzx = u_next[ix] - zprev[2 * j]
        dzy = u_next[ix + 1] - zprev[2 * j + 1]
        zprev[2 * j] = u[ix]
        zprev[2 * j + 1] = u[ix + 1]
        sc += r_x[j] * dzx + r_y[j] * dzy
        rt = r_t[j]
        st_ += rt * (dzx * pc_im[j] + dzy * pc_re[j])
        srt += rt
    work[0] += 0.5 * sc
    if f > 0.0:
        wc = srt * slide
        work[1] += wc
        work[2] += wc - 0.5 * st_


@inline
def batch_energies(u, v, ku, mass, energy, row, nb):
    """Row ``row``'s terms of the sampled energies of B scenes: energy[0] += m v², energy[1] +=
    u (K u) (kinetic and strain energy x 2; the observers' sums, in row order)."""
    mr = mass[row]
    for b in range(nb):
        vi = v[row, b]
        energy[0, b] += vi * mr * vi
        energy[1, b] += u[row, b] * ku[row, b]


@inline
def batched_contact_work(u, u_next, cx, pc_re, pc_im, r_x, r_y, r_t, zprev, work, slide, f):
    """Contact work of every scene of a batch with the centred increment u_{n+1} − u_{n−1}
    (as ``single_step``: per scene, over the contact nodes in order). Scene-outer, so that
    the three sums stay in registers (a B-long loop per contact node would pay its vector
    loop's set-up per node)."""
    for b in range(u.shape[1]):
        sc = 0.0
        st_ = 0.0
        srt = 0.0
        for j in range(cx.size):
            ix = cx[j]
            dzx = u_next[ix, b] - zprev[j, 0, b]
            dzy = u_next[ix + 1, b] - zprev[j, 1, b]
            zprev[j, 0, b] = u[ix, b]
            zprev[j, 1, b] = u[ix + 1, b]
            sc += r_x[j, b] * dzx + r_y[j, b] * dzy
            rt = r_t[j, b]
            st_ += rt * (dzx * pc_im[j] + dzy * pc_re[j])
            srt += rt
        work[0, b] += 0.5 * sc
        if f[b] > 0.0:
            wc = srt * slide[b]
            work[1, b] += wc
            work[2, b] += wc - 0.5 * st_


@jit
def batched_step(indptr, indices, data, u, u_next, v, vp, a, ku, nim,
                 c_v, c_w, c_p, b2_half, dt, kappa, inv_kappa,
                 cx, ph_re, ph_im, pc_re, pc_im, cmass, cinv,
                 d, slide, f, r_r, r_t, r_x, r_y, status, zprev, work, acc, cslot,
                 diag, keep, mass, energy, u_tau, u_tau_next, tau, dsum,
                 reg, sigma, ut_last, rate_slip, rate_base, started):
    """The same step on (n, B) arrays: column b is scene b (per-scene d, slide, f).

    One pass over the nodes, in blocks of ``NODE_BLOCK`` nodes: the (x, y) rows of K u for
    all B scenes (one read of the row for the whole batch; 4 scenes per register pass,
    ``half_product4``, then 2, ``half_product2``, the last one alone, ``pair_product_col``) and
    a*_n = -M^{-1} K u_n into the scratch ``acc`` (2 NODE_BLOCK, B), the contact projection
    at the block's contact nodes (``cslot`` >= 0), then the Newmark update of the block's
    rows as one flat loop of 2 NODE_BLOCK B elements (a loop that long vectorises; one per
    node, B long, would pay the vector loop's set-up per node). Valid because a node's
    update reads only u_n (never u_{n+1}) and its own v~_n, a_n.

    Only u_{n+1} and v~_{n+1} are state. v_n, a_n and K u_n are outputs read by the
    observers alone, so they are stored only when ``diag`` (a sampled step) or at the
    nodes with ``keep[node] != 0`` (probes). Same operations in the same order either way,
    and the same as ``single_step`` per scene: the state's bits do not depend on ``diag``,
    B or the block size. On a ``diag`` step the sampled energies are summed too, while the
    block is in cache: ``energy`` (2, B) = Σ_i m_i v_i² and Σ_i u_i (K u)_i over the rows in
    ascending order (``batch_energies``; the observers halve them).

    Kelvin-Voigt damping (``tau > 0``, shared by the batch): as ``single_step``, K reads
    w_n = u_n + tau v~_n, from ``u_tau`` (n, B), which the previous step wrote (a block's
    update overwrites v~ that later blocks' products read, so w_n cannot be formed in the
    pass); each block writes w_{n+1} into ``u_tau_next`` (the caller alternates the two, as
    u) with ``single_step``'s operations. K w_n of the block's rows is kept in ``acc`` from
    row ``KW_ROW`` on (the damping work needs it), and ``dsum`` (2, B) sums K w_n . u_{n+1}
    and K w_n . u_{n-1} per scene in row order, as ``single_step``:
    work[3] += 1/2 (dsum[0] - dsum[1]). On a damped
    ``diag`` step ``energy[1]`` is u . K w, not the strain energy: the caller refreshes K u_n
    (``stiffness_product_cols``) and sums it (``column_dots``).
    """
    n_rows, nb = u.shape
    nb4 = nb - nb % 4
    nb2 = nb - nb % 2
    damped = tau > 0.0
    first = started[0] == 0  # a regularised bound's first step: sigma_eff = p
    src = u_tau if damped else u
    if diag:
        for b in range(nb):
            energy[0, b] = 0.0
            energy[1, b] = 0.0
    n_nodes = n_rows // 2
    u_f = u.reshape(-1)  # flat views (C order: row-major, B per row) for the Newmark loop
    un_f = u_next.reshape(-1)
    vp_f = vp.reshape(-1)
    v_f = v.reshape(-1)
    a_f = a.reshape(-1)
    acc_f = acc.reshape(-1)
    if damped:
        dsum[:] = 0.0
    for g0 in range(0, n_nodes, NODE_BLOCK):
        g1 = min(g0 + NODE_BLOCK, n_nodes)
        for node in range(g0, g1):
            i = 2 * node
            k = i - 2 * g0  # the node's x row in acc
            a0 = numba.uint64(indptr[i])
            a1 = numba.uint64(indptr[i + 1])
            n0 = nim[i]
            n1 = nim[i + 1]
            write = diag or keep[node] != 0
            kw = KW_ROW + k  # damped: K w_n of the node's rows in acc, for the damping work
            for b0 in range(0, nb4, 4):  # 4 scenes at a time, their sums in registers
                bu = numba.uint64(b0)
                # pair_product's order: even terms, odd terms, then their sum
                e = half_product4(indices, data, src, a0, a1, a1, bu)  # row i: a0 .. a1 - 1
                o = half_product4(indices, data, src, a0 + U1, a1 + U1, a1, bu)
                for m in range(4):
                    s0 = e[m] + o[m]
                    s1 = e[4 + m] + o[4 + m]
                    if write:
                        ku[i, b0 + m] = s0
                        ku[i + 1, b0 + m] = s1
                    if damped:
                        acc[kw, b0 + m] = s0
                        acc[kw + 1, b0 + m] = s1
                    acc[k, b0 + m] = s0 * n0
                    acc[k + 1, b0 + m] = s1 * n1
            # each pass stores its sums in place: an inlined helper for the three stores
            # made the 4-scene pass 2x slower at N = 528 (benchmarks/small_batches.py)
            for b0 in range(nb4, nb2, 2):  # then 2 scenes at a time
                bu = numba.uint64(b0)
                e2 = half_product2(indices, data, src, a0, a1, a1, bu)
                o2 = half_product2(indices, data, src, a0 + U1, a1 + U1, a1, bu)
                for m in range(2):
                    s0 = e2[m] + o2[m]
                    s1 = e2[2 + m] + o2[2 + m]
                    if write:
                        ku[i, b0 + m] = s0
                        ku[i + 1, b0 + m] = s1
                    if damped:
                        acc[kw, b0 + m] = s0
                        acc[kw + 1, b0 + m] = s1
                    acc[k, b0 + m] = s0 * n0
                    acc[k + 1, b0 + m] = s1 * n1
            for b in range(nb2, nb):  # the last one alone
                s0, s1 = pair_product_col(indices, data, src, a0, a1, numba.uint64(b))
                if write:
                    ku[i, b] = s0
                    ku[i + 1, b] = s1
                if damped:
                    acc[kw, b] = s0
                    acc[kw + 1, b] = s1
                acc[k, b] = s0 * n0
                acc[k + 1, b] = s1 * n1
            j = cslot[node]
            if j >= 0:  # a_n = a*_n + M^{-1} r_n at a contact node
                inv_m = cinv[j]
                stiff = cmass[j] * inv_kappa
                for b in range(nb):
                    rr, rt, st, rx, ry = contact_reaction(
                        u[i, b], u[i + 1, b], vp[i, b], vp[i + 1, b], acc[k, b],
                        acc[k + 1, b], pc_re[j], pc_im[j], ph_re[j], ph_im[j], dt, kappa,
                        stiff, d[b], slide[b], f[b], reg, sigma, ut_last, j, b, rate_slip,
                        rate_base, first)
                    r_r[j, b] = rr
                    r_t[j, b] = rt
                    status[j, b] = st
                    r_x[j, b] = rx
                    r_y[j, b] = ry
                    acc[k, b] = acc[k, b] + rx * inv_m
                    acc[k + 1, b] = acc[k + 1, b] + ry * inv_m
            if write and not diag:  # a probe node: a_n and v_n (before v~ is overwritten)
                for r in range(2):
                    for b in range(nb):
                        ai = acc[k + r, b]
                        a[i + r, b] = ai
                        v[i + r, b] = ai * c_v + vp[i + r, b]
        # Newmark on the block's rows: v_n, w, u_{n+1}, v~_{n+1} (elementwise, one flat loop;
        # unsigned q: a signed index's wrap-around test would stop it vectorising, 3.7x)
        q0 = numba.uint64(2 * g0 * nb)
        if damped:  # K w_n . u_{n-1} of the block's rows, before u_{n+1} overwrites it
            damping_sums(acc, KW_ROW, u_next, 2 * g0, 2 * g1, dsum, 1)
        if diag:
            for t in range(2 * (g1 - g0) * nb):
                q = q0 + numba.uint64(t)
                ai = acc_f[t]
                vi = ai * c_v + vp_f[q]
                a_f[q] = ai
                v_f[q] = vi
                w = ai * c_w + vi
                un_f[q] = w * dt + u_f[q]
                vp_f[q] = w if b2_half else w + ai * c_p
            for row in range(2 * g0, 2 * g1):
                batch_energies(u, v, ku, mass, energy, row, nb)
        else:
            for t in range(2 * (g1 - g0) * nb):
                q = q0 + numba.uint64(t)
                ai = acc_f[t]
                w = ai * c_w + (ai * c_v + vp_f[q])
                un_f[q] = w * dt + u_f[q]
                vp_f[q] = w if b2_half else w + ai * c_p
        if damped:  # K w_n . u_{n+1}, and w_{n+1}
            damping_sums_next(acc, KW_ROW, u_next, vp, u_tau_next, tau, 2 * g0, 2 * g1,
                              dsum)
    batched_contact_work(u, u_next, cx, pc_re, pc_im, r_x, r_y, r_t, zprev, work, slide, f)
    started[0] = 1
    if damped:
        for b in range(nb):
            work[3, b] += 0.5 * (dsum[0, b] - dsum[1, b])


@inline
def damping_sums(kw, k0, u, r0, r1, dsum, slot):
    """dsum[slot, b] += Σ_row (K w_n)[row, b] u[row, b] over rows r0 .. r1 - 1 in order,
    K w_n of row r in ``kw`` row k0 + r - r0: per scene the running sum of
    ``single_step``'s damped loop (K w_n . u_{n+1} in slot 0, K w_n . u_{n-1} in slot 1;
    each sum is its own chain, so taking them in two passes keeps the bits)."""
    nb = u.shape[1]
    for row in range(r0, r1):
        k = k0 + row - r0
        for b in range(nb):
            dsum[slot, b] += kw[k, b] * u[row, b]


@inline
def damping_sums_next(kw, k0, u_next, vp, w_next, tau, r0, r1, dsum):
    """``damping_sums`` of K w_n . u_{n+1} (slot 0), and there
    w_{n+1} = u_{n+1} + tau v~_{n+1} (``single_step``'s operations) for the next step."""
    nb = u_next.shape[1]
    for row in range(r0, r1):
        k = k0 + row - r0
        for b in range(nb):
            un = u_next[row, b]
            dsum[0, b] += kw[k, b] * un
            w_next[row, b] = vp[row, b] * tau + un


# Why two batched steps: the loop order that vectorises (4-scene register passes for short
# B, B-long vector loops for long B) is fixed when numba compiles; both call the same
# per-node functions in the same order, so tests/test_ensemble.py pins both bitwise to
# ``single_step``.
@jit
def batched_step_long(indptr, indices, data, u, u_next, v, vp, a, ku, nim,
                      c_v, c_w, c_p, b2_half, dt, kappa, inv_kappa,
                      cx, ph_re, ph_im, pc_re, pc_im, cmass, cinv,
                      d, slide, f, r_r, r_t, r_x, r_y, status, zprev, work, acc, cslot,
                      diag, keep, mass, energy, u_tau, u_tau_next, tau, dsum,
                      reg, sigma, ut_last, rate_slip, rate_base, started):
    """``batched_step`` for long batches (B >= LONG_B; ``acc`` (4, B) at least): same
    arguments, same operations in the same order per scene, hence the same bits.

    K u is formed term-outer: for each term of the node's two rows one B-long vector loop
    adds it to partial sums kept in ``acc``. With B long that loop's set-up is paid once per
    B scenes and its body vectorises; with B short (8) the set-up dominates and the
    register passes of ``batched_step`` are faster (docs/performance.md, "Batches").

    One pass over the nodes: the (x, y) rows of K u for all B scenes (one read of the row
    for the whole batch), the contact projection if the node is a contact node
    (``cslot`` >= 0), then the Newmark update of the node. Valid because a node's update
    reads only u_n (never u_{n+1}) and its own v~_n, a_n.

    Only u_{n+1} and v~_{n+1} are state. v_n, a_n and K u_n are outputs read by the
    observers alone, so they are stored only when ``diag`` (a sampled step) or at the
    nodes with ``keep[node] != 0`` (probes); otherwise they stay in the (4, B) scratch
    ``acc``: 3 of the 6 (n, B) arrays the step would write are not touched, and the
    batch's working set (u_n, u_{n+1}, v~, K) is half as large. Same operations in the same
    order either way: the state's bits do not depend on ``diag``. Kelvin-Voigt damping as
    in ``batched_step`` (w_n from ``u_tau``, w_{n+1} into ``u_tau_next``, K w_n of the node's
    rows in ``ku`` when stored, else in ``acc[4]``, ``acc[5]``, the sums in ``dsum``).
    """
    n_rows, nb = u.shape
    damped = tau > 0.0
    first = started[0] == 0  # a regularised bound's first step: sigma_eff = p
    src = u_tau if damped else u
    if damped:
        dsum[:] = 0.0
    # scratch rows of the node's two dofs: even-term partial sums, then a_n (e0, e1);
    # odd-term partial sums (o0, o1). 2-D indexing only: a row view (u[col]) would cost a
    # reference-count update per use
    e0, e1, o0, o1 = acc[0], acc[1], acc[2], acc[3]
    if diag:
        for b in range(nb):
            energy[0, b] = 0.0
            energy[1, b] = 0.0
    for i in range(0, n_rows, 2):
        a0 = indptr[i]
        a1 = indptr[i + 1]
        ln = a1 - a0
        for b in range(nb):
            e0[b] = 0.0
            e1[b] = 0.0
            o0[b] = 0.0
            o1[b] = 0.0
        for t in range(ln):  # same order as pair_product: even terms, odd terms, then sum
            col = indices[a0 + t]
            d0 = data[a0 + t]
            d1 = data[a1 + t]
            if t % 2 == 0:
                for b in range(nb):
                    ub = src[col, b]
                    e0[b] += d0 * ub
                    e1[b] += d1 * ub
            else:
                for b in range(nb):
                    ub = src[col, b]
                    o0[b] += d0 * ub
                    o1[b] += d1 * ub
        n0 = nim[i]
        n1 = nim[i + 1]
        write = diag or keep[i // 2] != 0
        if write:
            for b in range(nb):
                s0 = e0[b] + o0[b]
                s1 = e1[b] + o1[b]
                ku[i, b] = s0
                ku[i + 1, b] = s1
                e0[b] = s0 * n0
                e1[b] = s1 * n1
        elif damped:  # K w_n of the two rows in acc[4], acc[5], for the damping work
            for b in range(nb):
                s0 = e0[b] + o0[b]
                s1 = e1[b] + o1[b]
                acc[4, b] = s0
                acc[5, b] = s1
                e0[b] = s0 * n0
                e1[b] = s1 * n1
        else:
            for b in range(nb):
                e0[b] = (e0[b] + o0[b]) * n0
                e1[b] = (e1[b] + o1[b]) * n1
        kw_src, kw_row = (ku, i) if write else (acc, 4)  # where K w_n of the rows is
        j = cslot[i // 2]
        if j >= 0:
            inv_m = cinv[j]
            stiff = cmass[j] * inv_kappa
            for b in range(nb):
                rr, rt, st, rx, ry = contact_reaction(
                    u[i, b], u[i + 1, b], vp[i, b], vp[i + 1, b], e0[b], e1[b], pc_re[j],
                    pc_im[j], ph_re[j], ph_im[j], dt, kappa, stiff, d[b], slide[b], f[b],
                    reg, sigma, ut_last, j, b, rate_slip, rate_base, first)
                r_r[j, b] = rr
                r_t[j, b] = rt
                status[j, b] = st
                r_x[j, b] = rx
                r_y[j, b] = ry
                e0[b] = e0[b] + rx * inv_m
                e1[b] = e1[b] + ry * inv_m
        if damped:  # K w_n . u_{n-1}, before u_{n+1} overwrites it
            damping_sums(kw_src, kw_row, u_next, i, i + 2, dsum, 1)
        for r in range(2):  # a_n of row i + r is acc[r] (e0, e1)
            row = i + r
            if write:
                for b in range(nb):
                    ai = acc[r, b]
                    vi = ai * c_v + vp[row, b]
                    a[row, b] = ai
                    v[row, b] = vi
                    w = ai * c_w + vi
                    u_next[row, b] = w * dt + u[row, b]
                    vp[row, b] = w if b2_half else w + ai * c_p
                if diag:
                    batch_energies(u, v, ku, mass, energy, row, nb)
            else:
                for b in range(nb):
                    ai = acc[r, b]
                    w = ai * c_w + (ai * c_v + vp[row, b])
                    u_next[row, b] = w * dt + u[row, b]
                    vp[row, b] = w if b2_half else w + ai * c_p
        if damped:  # K w_n . u_{n+1}, and w_{n+1}
            damping_sums_next(kw_src, kw_row, u_next, vp, u_tau_next, tau, i, i + 2, dsum)
    batched_contact_work(u, u_next, cx, pc_re, pc_im, r_x, r_y, r_t, zprev, work, slide, f)
    started[0] = 1
    if damped:
        for b in range(nb):
            work[3, b] += 0.5 * (dsum[0, b] - dsum[1, b])


@jit
def stiffness_product(indptr, indices, data, n_rows, u, out):
    """out = K u on the owned rows (``pair_product``'s order: the bits of the step's K u)."""
    for i in range(0, n_rows, 2):
        s0, s1 = pair_product(indptr, indices, data, u, i)
        out[i] = s0
        out[i + 1] = s1


@jit
def stiffness_product_cols(indptr, indices, data, u, out):
    """out = K u for every column of an (n, B) u, each in ``pair_product``'s order (the
    bits of ``stiffness_product`` on that column alone): 4 columns per register pass
    (``half_product4``) and the last B mod 4 one by one, as ``batched_step``."""
    n_rows, nb = u.shape
    nb4 = nb - nb % 4
    for i in range(0, n_rows, 2):
        a0 = numba.uint64(indptr[i])
        a1 = numba.uint64(indptr[i + 1])
        for b0 in range(0, nb4, 4):
            bu = numba.uint64(b0)
            e = half_product4(indices, data, u, a0, a1, a1, bu)
            o = half_product4(indices, data, u, a0 + U1, a1 + U1, a1, bu)
            for m in range(4):
                out[i, b0 + m] = e[m] + o[m]
                out[i + 1, b0 + m] = e[4 + m] + o[4 + m]
        for b in range(nb4, nb):
            s0, s1 = pair_product_col(indices, data, u, a0, a1, numba.uint64(b))
            out[i, b] = s0
            out[i + 1, b] = s1


@jit
def column_energies(u, v, ku, mass, energy):
    """``batched_step``'s sampled energies of (n, B) arrays, summed after the step: energy
    (2, B) = Σ_i m_i v_i² and Σ_i u_i (K u)_i, rows in ascending order (``batch_energies``:
    the same bits). A batch of one steps with ``single_step``, which sums none."""
    n_rows, nb = u.shape
    for b in range(nb):
        energy[0, b] = 0.0
        energy[1, b] = 0.0
    for row in range(n_rows):
        batch_energies(u, v, ku, mass, energy, row, nb)


@jit
def column_dots(x, y, out):
    """out[b] = Σ_i x[i, b] y[i, b] in row order from 0.0, per column of (n, B) arrays."""
    n_rows, nb = x.shape
    for b in range(nb):
        out[b] = 0.0
    for i in range(n_rows):
        for b in range(nb):
            out[b] += x[i, b] * y[i, b]


@jit
def advance(n_max, t_stop, clock, indptr, indices, data, n_rows, u_a, u_b, v, vp, a, ku, nim,
            c_v, c_w, c_p, b2_half, dt, kappa, inv_kappa,
            cx, ph_re, ph_im, pc_re, pc_im, cmass, cinv,
            d, slide, f, r_r, r_t, r_x, r_y, status, zprev, work, w_a, w_b, tau,
            reg, sigma, ut_last, rate_slip, rate_base, started,
            probe_dof, probe_t, probe_rows, probe_count):
    """Up to ``n_max`` steps of ``single_step`` (same arguments, ``indptr`` to ``started``) in
    one call (one rank), stopping before a step once ``clock[0] >= t_stop``; after each step
    the probes record time level n as ``solver.ensemble_observers.BatchRecorder.
    record_probes`` does (t_n, and probe_rows[i, :, q] = (u_x, u_y, v_x, v_y) of level n
    at ``probe_dof[q]`` (x dof; y = x + 1) while rows are left). ``u_a`` holds u_n
    (damped: ``w_a`` w_n) on entry; the buffers alternate. Returns the number of steps
    taken."""
    cap = probe_t.size
    n_probes = probe_dof.size
    for s in range(n_max):
        if clock[0] >= t_stop:
            return s
        single_step(indptr, indices, data, n_rows, u_a, u_b, v, vp, a, ku, nim,
                    c_v, c_w, c_p, b2_half, dt, kappa, inv_kappa,
                    cx, ph_re, ph_im, pc_re, pc_im, cmass, cinv,
                    d, slide, f, r_r, r_t, r_x, r_y, status, zprev, work, w_a, w_b, tau,
                    reg, sigma, ut_last, rate_slip, rate_base, started)
        clock[0] += dt
        i = probe_count[0]
        if i < cap:
            probe_t[i] = clock[0] - dt
            for q in range(n_probes):
                ix = probe_dof[q]
                probe_rows[i, 0, q] = u_a[ix]
                probe_rows[i, 1, q] = u_a[ix + 1]
                probe_rows[i, 2, q] = v[ix]
                probe_rows[i, 3, q] = v[ix + 1]
            probe_count[0] = i + 1
        u_a, u_b = u_b, u_a
        w_a, w_b = w_b, w_a
    return n_max
