"""FE <-> semi-analytical verification: ``stickslip compare RUN_DIR``.

* ``compare_run``: the FE wave of a run directory (``postprocess.analysis.analyse_run``: k, signed
  celerity, frequency, psi1, psi2, amplitudes, zone order) side by side with every travelling
  wave of the reduced model at the same (nu, xi, f, delta, Omega) and k
  (``semianalytic.waves.find_waves``), the reduced model's flutter mode k and its free /
  sliding natural frequencies.
* ``fe_modes``: natural frequencies and flutter modes of the *FE* tube (same mesh as the run,
  outer circle clamped) with the inner circle (a) traction free (separation), (b) radially
  held, tangentially free (frictionless sliding), (c) held in both directions (stick) and
  (d) radially held with the sliding friction q = f p (the FE analogue of the reduced flutter
  analysis, paper section 3). This is how the ansatz X(r) of eq. [1] is tested against the
  full elasticity; ``reduced_modes`` gives the reduced model's numbers for the same four
  conditions.

Units in every table: m/s, Hz, m; celerity > 0 in the sense of rotation (paper eq. [3]).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from stickslip.postprocess.analysis import analyse_run, load_run
from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.flutter import dispersion_roots
from stickslip.semianalytic.waves import find_waves
from stickslip.solver.scene import scene_to_dict
from stickslip.studies.flutter_fe.cea import damped_exponents

#: Conditions on the inner circle for the modal analyses (see the module docstring).
CONDITIONS = ("free", "sliding", "stick", "flutter")


# ---------------------------------------------------------------------------------------------
# Reduced model (no dolfinx)


def scene_parameters(scene: dict) -> dict[str, float]:
    """nu, xi, f, delta, Omega, R, c0 = sqrt(E/rho) of a resolved scene (``scene.toml`` dict)."""
    mat, geo, load = scene["material"], scene["geometry"], scene["loading"]
    if "wave_speed" in mat:
        c0 = float(mat["wave_speed"])
    else:
        c0 = math.sqrt(float(mat["E"]) / float(mat["rho"]))
    return {"nu": float(mat["nu"]), "xi": float(geo["xi"]), "f": float(load["f"]),
            "delta": float(geo["delta"]), "omega": float(load["omega"]), "R": float(geo["R"]),
            "wave_speed": c0}


def _coeffs(p: dict[str, float]):
    return coefficients(p["nu"], p["xi"], gamma_from_physical(p["wave_speed"], p["R"],
                                                              p["omega"]))


def reduced_modes(p: dict[str, float], k: int) -> dict[str, dict[str, float]]:
    """Reduced-model (eq. [2]) frequencies of mode k for the four inner-circle conditions.

    Modes exp(i(k theta - w t)) of eq. [2] (non-dimensional time Omega t):
    free (P = Q = 0): w^2 = eigenvalues of [[b k^2 + g, -i D k], [i D k, a k^2 + h]];
    sliding (U = delta, Q = 0): w^2 = a k^2 + h; stick (U, V fixed): no dynamics left (the
    one-term ansatz has no interior freedom); flutter (U = delta, Q = f P):
    w^2 = a k^2 + h + i f D k (``semianalytic.flutter``). Physical: w Omega rad/s, phase
    speed w R Omega / k.
    """
    co = _coeffs(p)
    om, R = p["omega"], p["R"]
    H = np.array([[co.b * k * k + co.g, -1j * co.D * k], [1j * co.D * k, co.a * k * k + co.h]])
    lam = np.sort(np.linalg.eigvalsh(H))
    out: dict[str, dict[str, float]] = {}
    for name, w2 in (("free_tangential", lam[0]), ("free_radial", lam[1]),
                     ("sliding", co.a * k * k + co.h)):
        w = math.sqrt(w2) * om
        out[name] = {"omega_rad_s": w, "frequency_hz": w / (2 * math.pi),
                     "phase_speed_m_s": w * R / k}
    grow, _ = dispersion_roots(co, p["f"], k)
    out["flutter"] = {"omega_rad_s": abs(grow.real) * om,
                      "frequency_hz": abs(grow.real) * om / (2 * math.pi),
                      "phase_speed_m_s": grow.real * om * R / k,
                      "growth_rate_per_s": grow.imag * om}
    return out


def semianalytic_waves(p: dict[str, float], k: int) -> list[dict]:
    """Every reduced-model travelling wave at the run's parameters and wavenumber k.

    ``semianalytic.waves.find_waves`` (stick-slip and both stick-slip-separation closures),
    in physical units: celerity (m/s, signed), frequency (Hz), psi1, psi2 (time order, the
    paper's layout), amplitude max(U) - delta and (max V - min V) / 2 in metres; ``branch``
    names the root and how it was found, ``why_not`` says in words which inequality fails
    and by how much (``violated``: its equation tag).
    """
    co = _coeffs(p)
    out = []
    for w in find_waves(co, p["f"], k, p["delta"]):
        s = w.summary(R=p["R"], omega=p["omega"])
        out.append({
            "source": f"reduced {w.regime}" + (f" ({w.junction})" if w.regime != "stick-slip"
                                               else ""),
            "regime": w.regime, "k": w.k, "celerity_m_s": s["celerity_m_s"],
            "frequency_hz": s["frequency_hz"], "psi1": w.psi1, "psi2": w.psi2,
            "amplitude_r_m": w.amplitude * p["R"], "amplitude_theta_m": w.v_amplitude * p["R"],
            "direction": "rotation" if w.c > 0 else "opposite",
            "admissible": bool(w.admissible), "violated": w.violated,
            "branch": branch_description(w, s["celerity_m_s"]),
            "why_not": violation_in_words(w, p["R"]) if w.violated else None,
        })
    return out


#: How ``semianalytic.waves.find_waves`` finds each kind of root, and which junction
#: conditions close it (docs/semianalytic.md).
_SEARCH = {
    "friction-bound": "multistart: minima of the residual on a (c, psi) grid, each refined by "
                      "a hybrid Newton solve; closed by |Q| = fP at stick -> slip",
    "impact": "multistart: minima of the residual on a (c, psi1, psi2) grid, Newton; "
              "junctions: lift-off at P = 0, an impact at landing, |Q| = fP at stick -> slip",
    "smooth": "multistart: minima of the residual on a (c, psi1, psi2) grid, Newton; "
              "junctions: U, V, U', V' continuous at all three zone ends (the paper's count)",
}


def branch_description(w, celerity_m_s: float) -> str:
    """The root (celerity, zone fractions, residual) and how it was found, in one line."""
    root = f"c = {celerity_m_s:+.0f} m/s"
    root += f", psi2 = {w.psi2:.3f}" if w.regime == "stick-slip" else \
        f", psi1 = {w.psi1:.3f}, psi2 = {w.psi2:.3f}"
    return f"root {root} (residual {w.residual:.1g}); {_SEARCH.get(w.junction, w.junction)}"


def violation_in_words(w, R: float = 1.0) -> str:
    """Which inequality of eqs. [5]-[7] (or of the landing impact) the wave ``w`` breaks, and
    by how much, in words (``w.violated`` is its tag; the amounts from the wave's fields)."""
    ev = w.evaluate_s(2000)
    zone, P, Q = ev["zone"], ev["P"], ev["Q"]
    stick, slip, sep = zone == 1, zone == 2, zone == 0
    tag = w.violated or ""
    if tag.startswith("[7]"):
        pen = R * float(np.max(w.delta - ev["U"][sep]))
        return (f"in its separation zone the tube passes into the cylinder, by up to "
                f"{pen * 1e3:.3g} mm ({pen / (w.delta * R):.0%} of the mismatch d)")
    if tag == "[6] |Q| < fP in stick":
        ratio = float(np.max(np.abs(Q[stick]) / (w.f * P[stick])))
        return f"to stick it needs a friction force up to {ratio:.2g} x the Coulomb bound fP"
    if tag in ("[6] P >= 0 in stick", "[5] P >= 0 in slip"):
        where = stick if "stick" in tag else slip
        ratio = float(np.min(P[where]) / np.max(np.abs(P)))
        return (f"in {'stick' if 'stick' in tag else 'slip'} the cylinder would have to pull "
                f"the tube: the normal reaction P falls to {ratio:.2g} x its peak")
    if tag.startswith("[5] 1 + cV'"):
        rate = float(np.min(1.0 - abs(w.c) * ev["Vs"][slip]))
        return (f"in slip the slip velocity reverses (down to {rate:.2g} x R Omega) while "
                "friction still acts forward")
    if tag == "impact: normal impulse >= 0":
        return "at landing the impact impulse would pull the tube off the cylinder"
    if tag == "impact: |J| <= f I":
        i_n, i_t = w.info.get("impulse_normal", 0.0), w.info.get("impulse_tangential", 0.0)
        ratio = abs(i_t) / (w.f * i_n) if i_n > 0 else math.inf
        return f"at landing the tangential impulse is {ratio:.2g} x f times the normal one"
    return tag


# ---------------------------------------------------------------------------------------------
# FE side


def fe_wave(run_dir: Path) -> dict:
    """The FE wave of a run directory (``analyse_run``) as a table column."""
    run = load_run(run_dir)
    w = analyse_run(run)
    sc = run.scene
    return {
        "source": f"FE {run_dir.name}", "regime": w.regime, "k": w.mode,
        "celerity_m_s": w.celerity_m_s, "frequency_hz": w.frequency_hz,
        "psi1": w.psi1, "psi2": w.psi2, "zone_order": w.zone_order,
        "paper_order": w.paper_order, "fractions": w.fractions,
        "amplitude_r_m": w.amplitude_r_m, "amplitude_theta_m": w.amplitude_theta_m,
        "direction": w.direction, "limit_cycle": w.limit_cycle, "window_s": w.window_s,
        "n_inner": sc["mesh"]["n_inner"], "beta2": sc["time"]["beta2"],
        "seed": (f"mode {sc['initial']['mode']}" if sc["initial"]["perturbation"] == "mode"
                 else f"{sc['initial']['perturbation']} {sc['initial'].get('seed', 0)}"),
        "status": run.summary.get("status"),
    }


def compare_run(run_dir: Path | str, ks: list[int] | None = None) -> dict:
    """FE wave + every semi-analytical wave + reduced flutter/natural frequencies (dict).

    The reduced model is evaluated at the FE's wavenumber and at every k in ``ks``.
    """
    run_dir = Path(run_dir)
    run = load_run(run_dir)
    p = scene_parameters(run.scene)
    fe = fe_wave(run_dir)
    ks = sorted(set(ks or []) | {fe["k"]})
    waves: list[dict] = []
    reduced: dict[str, dict] = {}
    for k in ks:
        waves += semianalytic_waves(p, k)
        reduced[str(k)] = reduced_modes(p, k)
    out = {"run": str(run_dir), "parameters": p, "fe": fe, "semianalytic": waves,
           "reduced_modes": reduced}
    tube = run.summary.get("tube_3d")
    if isinstance(tube, dict):  # a 3D run: its wave is the mid-length ring's
        out["tube_3d"] = {k: tube.get(k) for k in ("length_m", "ends", "ring_z_m")}
    return out


ROWS = (
    ("k", "k", "{:d}"),
    ("celerity (m/s)", "celerity_m_s", "{:+.0f}"),
    ("frequency (Hz)", "frequency_hz", "{:.0f}"),
    ("psi1", "psi1", "{:.3f}"),
    ("psi2", "psi2", "{:.3f}"),
    ("max u_r - d (mm)", "amplitude_r_m", "{:.3f}", 1e3),
    ("u_theta half p-p (mm)", "amplitude_theta_m", "{:.3f}", 1e3),
    ("direction", "direction", "{}"),
    ("zone order", "zone_order", "{}"),
    ("admissible", "admissible", "{}"),
)


def _cell(col: dict, row: tuple) -> str:
    key, fmt = row[1], row[2]
    if key not in col or col[key] is None:
        return "–"
    val = col[key]
    if len(row) > 3:
        val = val * row[3]
    try:
        return fmt.format(val)
    except (ValueError, TypeError):
        return str(val)


def format_table(result: dict, markdown: bool = False) -> str:
    """The comparison as a text (or markdown) table: the FE wave, then one column R1, R2, ...
    per reduced-model wave; a legend naming each R's branch and why it is inadmissible; the
    reduced flutter mode; one concluding line."""
    fe, red = result["fe"], result["semianalytic"]
    cols = [fe] + red
    labels = [f"R{i} {_short(c)}" for i, c in enumerate(red, start=1)]
    heads = ["quantity", fe["source"]] + labels
    body = [[r[0]] + [_cell(c, r) for c in cols] for r in ROWS]
    for row in body:
        if row[0] == "admissible":
            row[2:] = ["yes" if c["admissible"] else "no" for c in red]
    p = result["parameters"]
    lines = [f"Omega = {p['omega']:g} rad/s, delta = {p['delta']:g}, f = {p['f']:g}, "
             f"nu = {p['nu']:g}, xi = {p['xi']:g}, R = {p['R']:g} m, "
             f"sqrt(E/rho) = {p['wave_speed']:g} m/s"]
    if markdown:
        lines.append("| " + " | ".join(heads) + " |")
        lines.append("|" + "---|" * len(heads))
        lines += ["| " + " | ".join(r) + " |" for r in body]
    else:
        widths = [max(len(str(r[i])) for r in [heads, *body]) for i in range(len(heads))]
        for r in [heads, *body]:
            lines.append("  ".join(str(x).ljust(w) for x, w in zip(r, widths, strict=True)))
    lines.append(f"{fe['source']}: transient, N = {fe.get('n_inner')}, beta2 = "
                 f"{fe.get('beta2')}, seed {fe.get('seed')}, limit cycle {fe.get('limit_cycle')}")
    for i, c in enumerate(red, start=1):
        verdict = "admissible" if c["admissible"] else \
            f"NOT admissible: {c.get('why_not') or c.get('violated')}"
        lines.append(f"R{i} = {c['source']}, {c.get('branch', '')}. {verdict}.")
    for k, modes in result["reduced_modes"].items():
        lines.append(
            f"reduced model, k = {k}: flutter phase speed "
            f"{modes['flutter']['phase_speed_m_s']:+.0f} m/s "
            f"({modes['flutter']['frequency_hz']:.0f} Hz, growth "
            f"{modes['flutter']['growth_rate_per_s']:.1f} 1/s); natural frequencies free "
            f"{modes['free_tangential']['frequency_hz']:.0f} / "
            f"{modes['free_radial']['frequency_hz']:.0f} Hz, sliding "
            f"{modes['sliding']['frequency_hz']:.0f} Hz")
    lines.append(conclusion(result))
    return "\n".join(lines)


def _short(col: dict) -> str:
    """Column label of a reduced wave: regime and closure in a few characters."""
    if col["regime"] == "stick-slip":
        return "stick-slip"
    return f"st-sl-sep ({col['source'].split('(')[-1].rstrip(')')})"


def conclusion(result: dict) -> str:
    """One line: what the comparison concludes."""
    fe = result["fe"]
    same_k = [c for c in result["semianalytic"] if c["k"] == fe["k"]]
    ok = [c for c in same_k if c["admissible"]]
    sense = {"opposite": "against the rotation", "rotation": "with the rotation"}
    head = (f"Conclusion: the FE wave is {fe['regime']} k = {fe['k']}, "
            f"{sense.get(fe['direction'], fe['direction'])} at {fe['celerity_m_s']:+.0f} m/s")
    if tube := result.get("tube_3d"):
        head += (f" (on the ring z = {tube['ring_z_m']:g} m of a finite tube, L = "
                 f"{tube['length_m']:g} m, {tube['ends']} ends; the reduced model is the "
                 "plane-strain tube's)")
    why = ("docs/verification.md, 'Why the FE wave travels at ≈ −2500 m/s': the reduced "
           "model's one-term radial ansatz X(r) cannot carry the tube's free radial flight")
    if not ok:
        return (f"{head}, while the reduced model has no admissible wave of k = {fe['k']} here "
                f"(all {len(same_k)} roots break a contact inequality, above); see {why}.")
    best = min(ok, key=lambda c: abs(c["celerity_m_s"] - fe["celerity_m_s"]))
    n = result["semianalytic"].index(best) + 1
    agree = "the same regime" if best["regime"] == fe["regime"] else \
        f"a {best['regime']} wave"
    return (f"{head}; the nearest admissible reduced wave R{n} is {agree} at "
            f"{best['celerity_m_s']:+.0f} m/s (FE / reduced celerity "
            f"{fe['celerity_m_s'] / best['celerity_m_s']:.2f}); see {why}.")


# ---------------------------------------------------------------------------------------------
# FE modal analysis (dolfinx; serial)


def fe_modes(scene, kmax: int = 16, n_eig: int = 80,
             conditions: tuple[str, ...] = CONDITIONS) -> dict[str, list[dict]]:
    """Natural frequencies / flutter modes of the FE tube for the four inner conditions.

    Serial; sparse shift-invert (ARPACK) about 0, the ``n_eig`` lowest |w^2|. Each mode gets
    its circumferential wavenumber (largest Fourier coefficient of the inner-circle
    displacement), its radial share and, for flutter, the growth rate and the signed phase
    speed (from the balance of e^{+ik theta} and e^{-ik theta} in the complex eigenvector,
    time factor e^{-i w t}). Flutter (condition d): the contact nodes keep u_r = d, their
    radial reaction is r_r = (K u)_r and the friction force r_theta = f r_r (sliding, q = f p,
    the cylinder dragging along +theta), i.e. M u'' + (K - f E K_r) u = 0 on the free dofs,
    with the scene's Kelvin-Voigt damping applied to the flutter exponents
    (``studies.flutter_fe.cea.damped_exponents``); the natural frequencies of (a)-(c) are
    the undamped ones.
    """
    from mpi4py import MPI

    # dolfinx on first use: the command line imports this module at start
    from stickslip.solver.problem import build_problem

    tube = _ModalTube(build_problem(scene, MPI.COMM_SELF))
    out: dict[str, list[dict]] = {}
    for cond in conditions:
        lam, vec, Tm = tube.eigenpairs(cond, scene.loading.f, n_eig)
        out[cond] = [_mode_entry(tube, cond, lam[j], Tm @ vec[:, j], kmax, scene.damping.tau,
                                 scene.geometry.R)
                     for j in np.argsort(lam.real)]
    return out


class _ModalTube:
    """The serial FE tube in the bases of the inner conditions: interior dofs (``Ti``) and
    the contact nodes' radial (``Tr``) and tangential (``Tt``) displacements; the lumped
    mass ``m``; every node's angle (the wavenumber is read from the whole field: a stick
    mode has no displacement on the inner circle)."""

    def __init__(self, prob: Any) -> None:
        import scipy.sparse as sp

        indptr, indices, data = prob.K.getValuesCSR()
        n = prob.K.getSize()[0]
        self.K = sp.csr_matrix((data, indices, indptr), shape=(n, n))
        self.m = prob.mass.copy()
        self.nodes = nd = prob.nodes
        mask = np.ones(n, dtype=bool)
        mask[prob.clamped] = False
        mask[nd.dofs_x] = False
        mask[nd.dofs_y] = False
        interior = np.flatnonzero(mask)
        self.n_interior, nc = interior.size, nd.dofs_x.size
        xy = prob.V.tabulate_dof_coordinates()[: n // 2, :2]
        self.theta = np.arctan2(xy[:, 1], xy[:, 0])
        self.cos, self.sin = np.cos(self.theta), np.sin(self.theta)
        ic = np.arange(nc)
        rows = np.concatenate([nd.dofs_x, nd.dofs_y])
        cols = np.concatenate([ic, ic])
        self.Tr = sp.csr_matrix((np.concatenate([nd.cos_t, nd.sin_t]), (rows, cols)),
                                shape=(n, nc))
        self.Tt = sp.csr_matrix((np.concatenate([-nd.sin_t, nd.cos_t]), (rows, cols)),
                                shape=(n, nc))
        self.Ti = sp.csr_matrix((np.ones(interior.size), (interior, np.arange(interior.size))),
                                shape=(n, interior.size))

    def eigenpairs(self, cond: str, f: float, n_eig: int) -> tuple[np.ndarray, np.ndarray, Any]:
        """(λ = w², eigenvectors in the condition's basis, the basis Tm) of M u'' + K u = 0
        restricted by ``cond``; flutter: K − f E K_r on the free dofs (``fe_modes``)."""
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla

        K, nc = self.K, self.Tr.shape[1]
        blocks = [self.Ti] + ([self.Tr] if cond == "free" else []) + \
            ([self.Tt] if cond != "stick" else [])
        Tm = sp.hstack(blocks).tocsr()
        Kr = (Tm.T @ K @ Tm).tocsc()
        Mr = sp.diags((Tm.T @ sp.diags(self.m) @ Tm).diagonal()).tocsc()  # lumped: diagonal
        nev = min(n_eig, Kr.shape[0] - 2)
        if cond == "flutter":
            ic = np.arange(nc)
            E = sp.csr_matrix((np.ones(nc), (self.n_interior + ic, ic)), shape=(Kr.shape[0], nc))
            Kr = (Kr - f * (E @ (self.Tr.T @ K @ Tm))).tocsc()
            lam, vec = spla.eigs(Kr, k=nev, M=Mr, sigma=0.0)
        else:
            lam, vec = spla.eigsh(Kr, k=nev, M=Mr, sigma=0.0)
        return np.asarray(lam, dtype=complex), vec, Tm


def _mode_entry(tube: _ModalTube, cond: str, lam: complex, full: np.ndarray, kmax: int,
                tau: float, R: float) -> dict:
    """One mode of ``fe_modes``: k, frequency, radial share at the contact nodes and, for
    flutter, the damped growth rate and the signed phase speed."""
    nd = tube.nodes
    w = np.sqrt(lam)
    if w.imag < 0:
        w = -w  # the growing root (time factor e^{-i w t})
    ux, uy = full[0::2], full[1::2]
    kk, sense, _ = _wavenumber(tube.theta, tube.cos * ux + tube.sin * uy,
                               -tube.sin * ux + tube.cos * uy, kmax)
    if cond == "stick":
        radial_share = float("nan")
    else:
        ur = nd.cos_t * full[nd.dofs_x] + nd.sin_t * full[nd.dofs_y]
        ut = -nd.sin_t * full[nd.dofs_x] + nd.cos_t * full[nd.dofs_y]
        er, et = float(np.sum(np.abs(ur) ** 2)), float(np.sum(np.abs(ut) ** 2))
        radial_share = er / max(er + et, 1e-300)
    entry = {"k": kk, "omega_rad_s": float(abs(w.real)),
             "frequency_hz": float(abs(w.real) / (2 * math.pi)),
             "radial_share": radial_share}
    if cond == "flutter":
        # the scene's Kelvin-Voigt damping tau (K + K_f): lambda^2 + tau mu lambda + mu
        # = 0 for mu = w^2 (studies.flutter_fe.cea); tau = 0: lambda = -i w
        lam_d = complex(damped_exponents(np.array([lam]), tau)[0])
        w_d = math.copysign(abs(lam_d.imag), w.real)
        entry["omega_rad_s"] = abs(w_d)
        entry["frequency_hz"] = abs(w_d) / (2 * math.pi)
        entry["growth_rate_per_s"] = float(lam_d.real)
        entry["damping_tau_s"] = tau
        # e^{i(+-k theta - w_r t)}: phase speed +-w_r / k (signed w_r)
        entry["phase_speed_m_s"] = float(sense * w_d * R / max(kk, 1))
    return entry


def _wavenumber(theta: np.ndarray, ur: np.ndarray, ut: np.ndarray,
                kmax: int) -> tuple[int, int, float]:
    """(k, sense, radial share) of a (complex) mode shape sampled at nodes of angles theta.

    sense = +1 if e^{+ik theta} dominates (a wave e^{i(k theta - w t)} travels at +w/k), else -1.
    """
    ks = np.arange(-kmax, kmax + 1)
    basis = np.exp(-1j * np.outer(theta, ks)) / theta.size  # nodes x wavenumbers
    cr, ct = ur @ basis, ut @ basis
    power = np.abs(cr) ** 2 + np.abs(ct) ** 2
    sym = power[kmax:] + power[kmax::-1]  # |k| = 0..kmax
    k = int(np.argmax(sym))
    sense = 1 if power[kmax + k] >= power[kmax - k] else -1
    er, et = float(np.sum(np.abs(ur) ** 2)), float(np.sum(np.abs(ut) ** 2))
    return k, sense, er / max(er + et, 1e-300)


def modal_table(scene, ks: list[int], kmax: int = 16) -> dict[str, dict]:
    """Lowest FE frequency of each wavenumber in ``ks`` and condition, with the reduced model's.

    For the free tube both the lowest tangential-dominated and radial-dominated modes are
    listed; for flutter, the fastest-growing mode of wavenumber k.
    """
    fe = fe_modes(scene, kmax=kmax)
    p = scene_parameters(scene_to_dict(scene))
    table: dict[str, dict] = {}
    for k in ks:
        red = reduced_modes(p, k)
        row: dict[str, float | None] = {}
        cand = [m for m in fe["free"] if m["k"] == k]
        tang = [m for m in cand if m["radial_share"] < 0.5]
        rad = [m for m in cand if m["radial_share"] >= 0.5]
        row["fe_free_tangential_hz"] = tang[0]["frequency_hz"] if tang else None
        row["fe_free_radial_hz"] = rad[0]["frequency_hz"] if rad else None
        sl = [m for m in fe["sliding"] if m["k"] == k]
        row["fe_sliding_hz"] = sl[0]["frequency_hz"] if sl else None
        st = [m for m in fe["stick"] if m["k"] == k]
        row["fe_stick_hz"] = st[0]["frequency_hz"] if st else None
        fl = sorted((m for m in fe["flutter"] if m["k"] == k),
                    key=lambda m: -m["growth_rate_per_s"])
        if fl:
            row["fe_flutter_hz"] = fl[0]["frequency_hz"]
            row["fe_flutter_phase_speed_m_s"] = fl[0]["phase_speed_m_s"]
            row["fe_flutter_growth_per_s"] = fl[0]["growth_rate_per_s"]
        row["reduced_free_tangential_hz"] = red["free_tangential"]["frequency_hz"]
        row["reduced_free_radial_hz"] = red["free_radial"]["frequency_hz"]
        row["reduced_sliding_hz"] = red["sliding"]["frequency_hz"]
        row["reduced_flutter_hz"] = red["flutter"]["frequency_hz"]
        row["reduced_flutter_phase_speed_m_s"] = red["flutter"]["phase_speed_m_s"]
        row["reduced_flutter_growth_per_s"] = red["flutter"]["growth_rate_per_s"]
        table[str(k)] = row
    return table


# ---------------------------------------------------------------------------------------------
# Free-flight law of the separated arc


def radial_branch(scene, kmax: int = 16) -> dict[int, float]:
    """Lowest radial-dominated natural frequency (Hz) of the FE tube, inner circle free, per k.

    "Radial-dominated": more than half of the inner-circle displacement energy is radial.
    """
    modes = fe_modes(scene, kmax=kmax + 2, n_eig=160, conditions=("free",))["free"]
    out: dict[int, float] = {}
    for m in modes:
        if 1 <= m["k"] <= kmax and m["radial_share"] >= 0.5 and m["k"] not in out:
            out[m["k"]] = m["frequency_hz"]
    return dict(sorted(out.items()))


def free_flight_celerity(branch: dict[int, float] | None, k: int, psi1: float, R: float,
                         reduced: dict[str, float] | None = None) -> float:
    """|celerity| (m/s) if the separated arc is half a wavelength of a free radial wave.

    In separation the tube is traction free: the arc [0, psi1 T] of a wave u(theta - ct) is
    then a piece of a free travelling wave of wavenumber kappa whose half wavelength is the
    arc, kappa = k / (2 psi1), and the wave moves at that free wave's phase speed
    R w_rad(kappa) / kappa. w_rad is interpolated in k on the FE radial branch, or (with
    ``reduced`` = scene parameters) taken from the reduced model's free radial root.
    """
    kappa = k / (2.0 * psi1)
    if reduced is not None:
        co = _coeffs(reduced)
        H = np.array([[co.b * kappa**2 + co.g, -1j * co.D * kappa],
                      [1j * co.D * kappa, co.a * kappa**2 + co.h]])
        w = math.sqrt(float(np.max(np.linalg.eigvalsh(H)))) * reduced["omega"]
    else:
        ks = np.array(list(branch))
        w = 2 * math.pi * float(np.interp(kappa, ks, np.array(list(branch.values()))))
    return w * R / kappa
