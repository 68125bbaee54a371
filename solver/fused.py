"""Fused explicit step: K u, the Newmark update, the contact projection and the contact work
in one compiled pass (numba), ``solver._fused_kernels``: ``single_step`` for one column and
``batched_step`` for a batch of scenes that share K and M, both stepped by
``solver.ensemble.BatchedExplicit`` (one scene is a batch of one:
``solver.scene_explicit``). This module loads the kernels and holds their plumbing.

The arithmetic is the one of the numpy reference (``solver.ensemble.ArrayColumns`` +
``solver.contact.ContactProjection`` + ``solver.contact.project_contact`` +
``solver.observers.EnergyAccumulator``), element by element, with beta_2 and kappa of the
paper's explicit scheme (solver/newmark.py docstring):

    a*_n   = -M^{-1} K u_n
    trial  = u_n + dt v~_n + kappa a*_n                    (contact nodes, polar frame)
    r_n    = project(trial; d, R Omega dt, f)              (paper section 2, [CAR 91])
    a_n    = a*_n + M^{-1} r_n
    v_n    = v~_n + beta_2 dt a_n,   w = v_n + dt/2 a_n
    u_{n+1} = u_n + dt w,            v~_{n+1} = w + (1/2 - beta_2) dt a_n

With Kelvin-Voigt damping C = tau K (``solver.ensemble.internal_force``) the
internal force is K w_n, w_n = u_n + tau v~_n, in place of K u_n (one product), the contact
step is unchanged, and the kernel also sums the damping work's per-step part
1/2 (K w_n . u_{n+1} - K w_n . u_{n-1}) (``solver.observers.DampingWork``; u_{n-1} is the
spare half of the double buffer before u_{n+1} overwrites it), closed at the samples with
K u_n (``BatchedExplicit.damping_work_totals``).

Only the summation order of K u (CSR order here, PETSc's order in MatMult) and of the work
sums (sequential here, BLAS in ``np.vdot``) differ, so the two kernels agree to round-off
(tests/test_fused.py). The single-scene and the batched kernel share the per-node functions
below and sum in the same order, so a scene gives *bitwise* the same numbers alone or in a
batch, whatever the batch size.

MPI: the kernel works on the local arrays (owned + ghost dofs, local column numbering); the
ghost values of u_n (w_n damped) are refreshed by PETSc (``Vec.ghostUpdate``) before each
step (``solver.scene_explicit.GhostRows``).

numba compiles on the first call (~1-3 s per kernel) and caches the machine code on disk
(``cache=True``): in the package's ``__pycache__`` when it is writable, else in
``$NUMBA_CACHE_DIR``, which ``_cache_dir`` sets to a user cache directory (Docker images with
a read-only package directory). ``COMPILE_SECONDS`` records the cost of the first call.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

COMPILE_SECONDS: dict[str, float] = {}
"""Wall time of the first (compiling or cache-loading) call of each kernel, seconds."""


def _before_numba() -> None:
    """What numba's import reads from the environment, set up before it: a thread count it
    would reject in words that name no variable is refused (ValueError, one line with the
    fix), and its cache goes where it can be written (``_cache_dir``)."""
    threads = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    if threads.lstrip("+-").isdigit() and int(threads) < 1:
        raise ValueError(f"NUMBA_NUM_THREADS = {threads}: numba needs at least 1 thread; "
                         "unset it or set NUMBA_NUM_THREADS=1")
    _cache_dir()


def _cache_dir() -> None:
    """Point numba's cache to a writable directory when the package directory is not."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    here = Path(__file__).resolve().parent
    if os.access(here, os.W_OK):
        return
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    for root in (base, tempfile.gettempdir()):
        path = Path(root) / "stickslip-numba"
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(path, os.W_OK):
            os.environ["NUMBA_CACHE_DIR"] = str(path)
            return


def numba_available() -> bool:
    """True when numba imports (Debian's python3-numba is in the apt list)."""
    try:
        _before_numba()
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


# ------------------------------------------------------------------------------ kernels

def _kernels():
    """The kernels module, imported (and numba with it) on first use."""
    _before_numba()
    # numba (0.3 s) with the compiled step only: the numpy kernel runs without it
    from stickslip.solver import _fused_kernels

    return _fused_kernels


def sample_kernels():
    """The batch records' copies module (``solver._sample_kernels``), imported on first use
    with numba's cache where ``_kernels`` has it."""
    _before_numba()
    # numba (0.3 s) with the compiled step only: the numpy kernel runs without it
    from stickslip.solver import _sample_kernels

    return _sample_kernels


def friction_bound(law) -> tuple[int, float, float]:
    """(code, rate_slip, rate_base) of ``law``'s friction bound for the kernels
    (``solver.contact.ContactLaw.kernel_bound``; the 1-2-1 filtered bound is not in them)."""
    return law.kernel_bound()


def kernel(name: str):
    """The compiled kernel ``name`` ("single_step", "batched_step", "batched_step_long")."""
    return getattr(_kernels(), name)


@contextmanager
def slp_vectorize() -> Iterator[None]:
    """Compile inside this block with LLVM's SLP vectoriser on (numba's default is off).

    ``batched_step`` keeps 4 scenes' partial sums in scalar locals (``half_product4``);
    only the SLP vectoriser packs them into 4-wide registers (the loop vectoriser cannot:
    the lanes are not a loop). numba reads ``config.SLP_VECTORIZE`` when it builds the
    pass pipeline of a compilation, so the flag is set around the kernel's first call and
    restored after it; a cache load is unaffected. SLP packs identical scalar operations
    and does not reorder floating-point ones (no fast-math), so the bits cannot change:
    tests/test_ensemble.py checks the batch bitwise against ``single_step``, which is
    compiled without it. (numba turned SLP off by default after LLVM miscompilations,
    numba PR #8852; that bitwise test is the guard here.)
    """
    from numba.core import config

    old = getattr(config, "SLP_VECTORIZE", None)
    if old is None:  # a numba without the flag: compile as it does (slower, same bits)
        yield
        return
    config.SLP_VECTORIZE = 1
    try:
        yield
    finally:
        config.SLP_VECTORIZE = old


def timed_first_call(name: str, fn, *args):
    """``fn(*args)``; the first call of kernel ``name`` is timed (compile or cache load)."""
    if name in COMPILE_SECONDS:
        return fn(*args)
    t0 = time.perf_counter()
    out = fn(*args)
    COMPILE_SECONDS[name] = time.perf_counter() - t0
    return out


# ------------------------------------------------------------------------------ local CSR


def local_csr(problem) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, data, ghosts) of K's owned rows in LOCAL column numbering.

    Local numbering: owned dofs 0 .. n_owned - 1, then the off-process columns of the owned
    rows ("ghosts", sorted by global index), so the columns index an array of owned + ghost
    values. The ghosts come from K itself, not from the dofmap: with dolfinx's default ghost
    mode, rows on the partition boundary also couple to dofs of cells the rank does not hold.
    ``ghosts`` are their global indices (for ``PETSc.Vec.createGhostWithArray``).
    """
    indptr, cols, data = problem.K.getValuesCSR()
    r0, r1 = problem.K.getOwnershipRange()
    n_owned = problem.n_owned
    if r1 - r0 != n_owned:
        raise RuntimeError(f"K owns {r1 - r0} rows, the space {n_owned} dofs")
    cols = np.asarray(cols, dtype=np.int64)
    local = cols - r0
    outside = (local < 0) | (local >= n_owned)
    ghosts = np.unique(cols[outside])
    local[outside] = n_owned + np.searchsorted(ghosts, cols[outside])
    indptr = np.asarray(indptr, dtype=np.int64)
    lengths = np.diff(indptr)
    paired = n_owned % 2 == 0 and np.array_equal(lengths[0::2], lengths[1::2])
    if paired:
        ln = lengths[0::2]
        offs = np.arange(ln.sum()) - np.repeat(np.cumsum(ln) - ln, ln)
        paired = np.array_equal(local[np.repeat(indptr[0:-1:2], ln) + offs],
                                local[np.repeat(indptr[1::2], ln) + offs])
    if not paired:
        raise RuntimeError("the fused kernel needs the (x, y) rows of a node to share their "
                           "column pattern (a blocked bs = 2 space); use time.kernel = numpy")
    # unsigned indices: numba then skips its negative-index wrap-around test (2x faster K u)
    return (np.ascontiguousarray(indptr, dtype=np.uint32),
            np.ascontiguousarray(local, dtype=np.uint32),
            np.ascontiguousarray(data, dtype=np.float64), ghosts)
