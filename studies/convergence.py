"""The convergence study of the FE limit cycle: cases, one run, its measures.

A case is Figure-3 or Figure-1 physics ("fig3": Omega = 50 rad/s, delta = 4e-4, f = 0.7;
"fig1": Omega = 40, delta = 1e-3, f = 0.7) at N contact nodes, beta2, dt = frac x dt_crit,
undamped or with Kelvin-Voigt eta = 2 % at 1.6 kHz, from the mode-4 seed or a random seed,
with the nodal or the 1-2-1 filtered friction bound (``case["filter"]``, docs/friction_filter.md).
``run_case`` runs it in this process and ``measure`` extracts, over the last ``WINDOW`` s
(a case may set ``end_time`` and ``window``: the CI test runs a shorter, still stationary,
stretch):

* frequency: FFT peak (parabolic refinement) of the every-step probe history at theta = 0
  (u_r - d when the tube separates, else u_theta): a property of the time signal, whichever
  wavenumber carries it;
* zone fractions (node-samples), psi1, psi2, k, celerity (``postprocess.analysis.analyse``);
* amplitude: RMS of u_r - d over all contact nodes and the samples of the last whole number of
  periods 1/f (a mean, so it can converge; a maximum over a window need not).

The driver and report are ``benchmarks/convergence.py`` (docs/convergence.md).
"""

from __future__ import annotations

import math
import time

import numpy as np

from stickslip.postprocess.analysis import analyse, probe_frequency, zone_fractions
from stickslip.solver.errors import Diverged
from stickslip.solver.run import Simulation
from stickslip.solver.scene import SCENES_DIR, Scene, load_scene

END_TIME = 0.3  # s; the limit cycle is reached by ~0.1 s (paper section 4)
WINDOW = 0.12  # s analysed at the end of the run
ETA_DAMPED = 0.02  # loss factor of the damped series ...
F_REF_HZ = 1600.0  # ... at the frequency of the Figure-3 wave: tau = eta / (2 pi f) = 1.99 us
PHYSICS = {
    "fig3": ["loading.omega=50.0", "geometry.delta=0.0004", "loading.f=0.7"],
    "fig1": ["loading.omega=40.0", "geometry.delta=0.001", "loading.f=0.7"],
}
NS = (66, 132, 264, 528, 1056)

def case_key(phys: str, damped: bool, n: int, seed: str, beta2: float = 0.5,
             frac: float = 0.9, filt: str = "nodal") -> str:
    """Unique name of a case of the study (``filt``: ``[friction] filter``; the nodal law
    keeps the keys it had before the option existed)."""
    tail = "" if filt == "nodal" else "-f" + filt.replace("-", "")
    return f"{phys}-{'eta2' if damped else 'undamped'}-N{n}-{seed}-b{beta2:g}-fr{frac:g}{tail}"


def scene_for(case: dict) -> Scene:
    """The scene of one case: Figure-3 scene file with the case's physics and numerics."""
    ov = [*PHYSICS[case["phys"]], f"mesh.n_inner={case['n']}", "mesh.n_radial=0",
          f"time.beta2={case['beta2']}", f"time.dt_fraction={case['frac']}", "time.dt=0",
          f"time.end_time={case.get('end_time', END_TIME)}", "output.progress=false",
          "output.sample_interval=1e-4",
          "output.probes_deg=[0.0]", "time.max_wall_time=1800"]
    if case.get("filter", "nodal") != "nodal":
        ov += [f'friction.filter="{case["filter"]}"']
    if case["damped"]:
        ov += [f"damping.loss_factor={ETA_DAMPED}", f"damping.reference_frequency_hz={F_REF_HZ}"]
    if case["seed"] == "mode4":
        ov += ['initial.perturbation="mode"', "initial.mode=4", "initial.amplitude=0.1"]
    else:
        ov += ['initial.perturbation="random"', f"initial.seed={case['seed'][6:]}",
               "initial.amplitude=0.1", "initial.n_modes=16"]
    name = case["key"].replace("+", "p")
    return load_scene(SCENES_DIR / "figure3_n132.toml", [f'name="{name}"', *ov])


def measure(t, theta, u_r, u_t, status, probe_t, probe, d, radius, window) -> dict:
    """Limit-cycle quantities over the last ``window`` seconds (module docstring)."""
    sel = probe_t >= probe_t[-1] - window
    sep = zone_fractions(status[t >= t[-1] - window])["separation"] > 0.02
    sig = probe[sel, 0] - d if sep else probe[sel, 1]
    freq = probe_frequency(probe_t[sel], sig)
    wave = analyse(t, theta, u_r, u_t, status, d=d, radius=radius, window=window,
                   frequency_hint_hz=freq if freq > 0 else None)
    n_per = max(1, int(math.floor(window * freq))) if freq > 0 else 0
    tw = n_per / freq if n_per else window
    s = t >= t[-1] - tw + 1e-12
    rms = float(np.sqrt(np.mean((u_r[s] - d) ** 2)))
    rms_t = float(np.sqrt(np.mean((u_t[s] - u_t[s].mean(axis=1, keepdims=True)) ** 2)))
    fr = zone_fractions(status[t >= t[-1] - window])
    return dict(frequency_hz=freq, k=wave.mode, celerity_m_s=wave.celerity_m_s,
                wave_frequency_hz=wave.frequency_hz, sep=fr["separation"], stick=fr["stick"],
                slip=fr["slip"], psi1=wave.psi1, psi2=wave.psi2, amp_rms_m=rms,
                amp_t_rms_m=rms_t, regime=wave.regime, limit_cycle=bool(wave.limit_cycle),
                zone_order=wave.zone_order)


def run_case(case: dict) -> dict:
    """Run one case (serial) and measure its limit cycle; a JSON-able dict."""
    from mpi4py import MPI

    scene = scene_for(case)
    window = case.get("window", WINDOW)
    t0, c0 = time.perf_counter(), time.process_time()
    sim = Simulation(scene, MPI.COMM_SELF)
    setup = time.perf_counter() - t0
    if sim.proceed() == "diverged":  # a blow-up has no wave to measure
        raise Diverged(f"{scene.name}: {sim.message}")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    a = sim.recorder.arrays()
    pr = sim.probes.arrays()
    g = scene.geometry
    out = dict(case)
    out.update(status=sim.stop_reason, steps=sim.integrator.step_count, dt_s=sim.dt,
               dt_crit_s=sim.dt_crit, tau_s=scene.damping.tau, dofs=int(sim.problem.n_global_dofs),
               omega_max=sim.omega_max, wall_s=wall, cpu_s=cpu, setup_s=setup,
               end_time=case.get("end_time", END_TIME), window_s=window,
               sim_time_s=sim.integrator.time)
    pdata = pr["probe_data"][0]  # (step, [u_r, u_theta, v_r, v_theta])
    args = (a["t"], a["theta"], a["u_r"], a["u_theta"], a["status"], pr["probe_t"], pdata,
            g.d, g.R)
    out.update(measure(*args, window))
    # stationarity: the two halves of the window
    for half, shift in (("h1", window / 2), ("h2", 0.0)):
        end = a["t"][-1] - shift
        sa, sp = a["t"] <= end + 1e-12, pr["probe_t"] <= end + 1e-12
        m = measure(a["t"][sa], a["theta"], a["u_r"][sa], a["u_theta"][sa], a["status"][sa],
                    pr["probe_t"][sp], pdata[sp], g.d, g.R, window / 2)
        out[half] = {k: m[k] for k in ("frequency_hz", "k", "sep", "stick", "slip", "psi1",
                                       "psi2", "amp_rms_m")}
    e = a["energies"]
    # power balance over the window (J/m/s): normal contact work (impacts, <= 0), friction,
    # damping, fed by the cylinder; normal work = contact work - tangential work, tangential
    # work = cylinder work - friction dissipation
    w = a["t"] >= a["t"][-1] - window
    i0, i1 = int(np.argmax(w)), a["t"].size - 1
    span = a["t"][i1] - a["t"][i0]
    de = (e[i1] - e[i0]) / span
    out["power"] = dict(normal=float(de[2] - (de[3] - de[4])), friction=float(de[4]),
                        damping=float(de[5]), cylinder=float(de[3]),
                        mean_energy=float(np.mean(e[w, 0] + e[w, 1])))
    out["energy_residual_rel"] = float(
        abs(e[-1, 0] + e[-1, 1] - e[0, 0] - e[0, 1] - (e[-1, 2] - e[0, 2]) + (e[-1, 5] - e[0, 5]))
        / max(1e-300, float(np.max(e[:, 0] + e[:, 1]))))
    return out


def richardson(ns, qs, noise):
    """Observed order and extrapolated value from the three finest of (N, q) at ratio 2.

    p = log2((q1 - q2) / (q2 - q3)); q_inf = q3 + (q3 - q2) / (2^p - 1). The error bar is
    |q_inf - q3| plus the time-averaging noise of the finest run. If the differences change
    sign (no asymptotic range) no order is claimed: the bar is the spread of the last two.
    """
    if len(qs) < 3:
        return None
    q1, q2, q3 = qs[-3:]
    d1, d2 = q1 - q2, q2 - q3
    if d1 == 0 or d2 == 0 or d1 * d2 < 0 or abs(d2) >= abs(d1):
        return dict(order=None, value=q3, err=abs(d2) + noise, n=ns[-1])
    p = math.log2(d1 / d2)
    q_inf = q3 - d2 / (2 ** p - 1)
    return dict(order=p, value=q_inf, err=abs(q_inf - q3) + noise, n=ns[-1])
