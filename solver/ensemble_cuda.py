"""The CUDA source of the batched explicit step (``solver.ensemble``, backend "cuda"): one
thread per (node, scene), the arithmetic of ``solver._fused_kernels`` in the same order.
The status codes come from the contact law (``solver.contact.law``), as #defines.

Kernels: ``fused_step`` (undamped), and with Kelvin-Voigt damping ``kelvin_voigt_argument``
(w_n = u_n + tau v~_n over every (row, scene), a launch of its own: a step overwrites v~
that other threads' products read) then ``fused_step_damped`` (K reads w_n; each thread adds
its node's share of 1/2 (K w_n . u_{n+1} - K w_n . u_{n-1}) to ``dwork``, per (node, scene):
no atomics). Both steps run ``explicit_step_node``, so the undamped bits are unchanged."""

from stickslip.solver.contact.law import SEPARATION, SLIP, STICK

_CODES = f"""
#define SEPARATION {SEPARATION}
#define STICK {STICK}
#define SLIP {SLIP}
"""

#: the parameters of ``fused_step``, also the first ones of ``fused_step_damped``
_STEP_PARAMS = r"""
    const unsigned int* indptr, const unsigned int* indices, const double* data,
    const double* u, double* un, double* v, double* vp, double* a, double* ku,
    const double* nim, const int* cslot, const double* ph_re, const double* ph_im,
    const double* pc_re, const double* pc_im, const double* cmass, const double* cinv,
    const double* d, const double* slide, const double* f,
    double* r_r, double* r_t, double* r_x, double* r_y, signed char* status,
    double* zprev, double* work,
    const double c_v, const double c_w, const double c_p, const int b2_half,
    const double dt, const double kappa, const double inv_kappa,
    const int n_nodes, const int B, const int m, const int diag, const signed char* keep"""
_STEP_ARGS = ("indptr, indices, data, u, un, v, vp, a, ku, nim, cslot, ph_re, ph_im, pc_re, "
              "pc_im, cmass, cinv, d, slide, f, r_r, r_t, r_x, r_y, status, zprev, work, c_v, "
              "c_w, c_p, b2_half, dt, kappa, inv_kappa, n_nodes, B, m, diag, keep")

CUDA_SOURCE = _CODES + r"""
#if !defined(__CUDACC__) && !defined(__CUDACC_RTC__)
#define __device__
#endif
// One explicit step for one (node, scene): the (x, y) rows of K src (even/odd partial sums,
// as solver/_fused_kernels.py; src = u_n, or w_n = u_n + tau v~_n with damping), the contact
// projection when the node is on the contact circle, the Newmark update and the contact
// work (and the damping work's share when dwork is given). Arrays are (rows, B) row-major:
// consecutive threads are consecutive scenes, so every load is coalesced.
// Rows i, i + 1 of K src for scene b: (even terms) + (odd terms) of the CSR order, as
// pair_product in solver/_fused_kernels.py.
static __device__ void pair_rows(const unsigned int* indptr, const unsigned int* indices,
    const double* data, const double* src, const int i, const int b, const int B,
    double* k0, double* k1)
{
    const unsigned int a0 = indptr[i], a1 = indptr[i + 1];
    const unsigned int ln = a1 - a0;
    double s0e = 0.0, s0o = 0.0, s1e = 0.0, s1o = 0.0;
    unsigned int t = 0;
    for (; t + 1 < ln; t += 2) {
        const double c0 = src[(size_t)indices[a0 + t] * B + b];
        const double c1 = src[(size_t)indices[a0 + t + 1] * B + b];
        s0e += data[a0 + t] * c0;
        s0o += data[a0 + t + 1] * c1;
        s1e += data[a1 + t] * c0;
        s1o += data[a1 + t + 1] * c1;
    }
    if (t < ln) {
        const double c0 = src[(size_t)indices[a0 + t] * B + b];
        s0e += data[a0 + t] * c0;
        s1e += data[a1 + t] * c0;
    }
    *k0 = s0e + s0o;
    *k1 = s1e + s1o;
}

static __device__ void explicit_step_node(""" + _STEP_PARAMS + r""",
    const double* src, double* dwork)
{
    long long tid = (long long)blockIdx.x * blockDim.x + threadIdx.x;
    if (tid >= (long long)n_nodes * B) return;
    const int p = (int)(tid / B);
    const int b = (int)(tid % B);
    const int i = 2 * p;
    const size_t ix = (size_t)i * B + b, iy = (size_t)(i + 1) * B + b;
    double k0, k1;
    pair_rows(indptr, indices, data, src, i, b, B, &k0, &k1);
    // v_n, a_n, K u_n are read only by the observers: written on sample steps (diag) and at
    // the probe nodes (keep); u_{n+1}, v~_{n+1} (the state) always
    const bool write = diag || keep[p];
    if (write) {
        ku[ix] = k0;
        ku[iy] = k1;
    }
    double ax = k0 * nim[i], ay = k1 * nim[i + 1];
    const int j = cslot[p];
    const double ux = u[ix], uy = u[iy];
    double rx = 0.0, ry = 0.0, rt = 0.0;
    if (j >= 0) {
        const double pr = pc_re[j], pi = pc_im[j];
        const double now_r = ux * pr - uy * pi;
        const double now_t = ux * pi + uy * pr;
        const double tx = vp[ix] * dt + ax * kappa;
        const double ty = vp[iy] * dt + ay * kappa;
        const double tr = (tx * pr - ty * pi) + now_r;
        const double tt = (tx * pi + ty * pr) + now_t;
        const double stiff = cmass[j] * inv_kappa;
        double rr = d[b] - tr;
        if (rr < 0.0) rr = 0.0;
        rr = rr * stiff;
        const bool inc = rr > 0.0;
        signed char st;
        const double fb = f[b];
        if (fb == 0.0) {
            rt = 0.0;
            st = inc ? SLIP : SEPARATION;
        } else {
            rt = now_t + slide[b];
            rt = rt - tt;
            rt = rt * stiff;
            const double cone = rr * fb;
            if (fabs(rt) > cone) { rt = copysign(cone, rt); st = inc ? SLIP : SEPARATION; }
            else { st = inc ? STICK : SEPARATION; }
        }
        const size_t jb = (size_t)j * B + b;
        r_r[jb] = rr;
        r_t[jb] = rt;
        status[jb] = st;
        rx = rr * ph_re[j] - rt * ph_im[j];
        ry = rr * ph_im[j] + rt * ph_re[j];
        r_x[jb] = rx;
        r_y[jb] = ry;
        ax = ax + rx * cinv[j];
        ay = ay + ry * cinv[j];
    }
    const double vx = ax * c_v + vp[ix], vy = ay * c_v + vp[iy];
    if (write) {
        a[ix] = ax;
        a[iy] = ay;
        v[ix] = vx;
        v[iy] = vy;
    }
    const double wx = ax * c_w + vx, wy = ay * c_w + vy;
    const double unx = wx * dt + ux, uny = wy * dt + uy;
    if (dwork) {  // damped: un holds u_{n-1} until it is overwritten
        dwork[(size_t)p * B + b] += 0.5 * ((k0 * unx + k1 * uny) - (k0 * un[ix] + k1 * un[iy]));
    }
    un[ix] = unx;
    un[iy] = uny;
    vp[ix] = b2_half ? wx : wx + ax * c_p;
    vp[iy] = b2_half ? wy : wy + ay * c_p;
    if (j >= 0) {
        const size_t zx = ((size_t)j * 2) * B + b, zy = ((size_t)j * 2 + 1) * B + b;
        const double dzx = unx - zprev[zx], dzy = uny - zprev[zy];
        zprev[zx] = ux;
        zprev[zy] = uy;
        const size_t jb = (size_t)j * B + b, mb = (size_t)m * B;
        work[jb] += 0.5 * (rx * dzx + ry * dzy);
        if (f[b] > 0.0) {
            const double wc = rt * slide[b];
            work[mb + jb] += wc;
            work[2 * mb + jb] += wc - 0.5 * (rt * (dzx * pc_im[j] + dzy * pc_re[j]));
        }
    }
}

extern "C" __global__ void fused_step(""" + _STEP_PARAMS + r""")
{
    explicit_step_node(""" + _STEP_ARGS + r""", u, 0);
}

extern "C" __global__ void fused_step_damped(""" + _STEP_PARAMS + r""",
    const double* w, double* dwork)
{
    explicit_step_node(""" + _STEP_ARGS + r""", w, dwork);
}

// w = u + tau v~ over the count = rows x B entries (the numba kernels' operations)
extern "C" __global__ void kelvin_voigt_argument(const double* u, const double* vp, double* w,
                                                 const double tau, const int count)
{
    long long tid = (long long)blockIdx.x * blockDim.x + threadIdx.x;
    if (tid >= (long long)count) return;
    w[tid] = vp[tid] * tau + u[tid];
}

// out = K u for every (node, scene), in the step's order (the samples' K u_n when damped)
extern "C" __global__ void stiffness_product(const unsigned int* indptr,
    const unsigned int* indices, const double* data, const double* u, double* out,
    const int n_nodes, const int B)
{
    long long tid = (long long)blockIdx.x * blockDim.x + threadIdx.x;
    if (tid >= (long long)n_nodes * B) return;
    const int b = (int)(tid % B);
    const int i = 2 * (int)(tid / B);
    double k0, k1;
    pair_rows(indptr, indices, data, u, i, b, B, &k0, &k1);
    out[(size_t)i * B + b] = k0;
    out[(size_t)(i + 1) * B + b] = k1;
}
"""
