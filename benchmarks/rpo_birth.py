"""Where a two-wave state is born: a rigid wave's sideband along a scene parameter
(``studies.rpo.birth``; docs/theory/rpo.md, "Where a two-wave state is born").

    ./dev python3 benchmarks/rpo_birth.py RUN_DIR --key loading.omega --k-wave 11 \\
        --k-side 10 --scan 60,62.5,65,67.5,70 [--duration 1] \\
        [--fan-from 65 --fan 68,70,72 --fan-duration 6] [--seed-side 1e-3]

The tables of docs/theory/rpo.md ("Where a two-wave state is born"), RUN_DIR P's census
start seed 1 at N = 264 (``stickslip attractors figure1_n132_damped --starts 8 --meshes 264
--set loading.omega=60 --set geometry.delta=8e-4 --set loading.f=0.6``):

    ... --k-wave 11 --k-side 10 --scan 60 --duration 6 --fan-from 60 \\
        --fan 62,64,66,67,68,70 --fan-duration 2                 # σ, linear
    ... --k-wave 11 --k-side 10 --scan 62.5,65 --fan-from 65 \\
        --fan 63.5,64,66,67 --fan-duration 8                     # the sideband held
    ... (the first) --set time.dt_fraction=0.45 --fan 62,64,65,66,67,68  # at Δt/2
    ... --k-wave 11 --k-side 10 --scan 56 --duration 6 --fan-from 56 \
        --fan 58.5,59,59.5,60 --fan-duration 2 --set time.dt_fraction=0.225   # at Δt/4
    ... --k-wave 11 --k-side 10 --scan 50 --duration 4 --fan-from 50 \
        --fan 52,55,58 --fan-duration 1.5 --set time.dt_fraction=0.1125       # at Δt/8
    ... --k-wave 11 --k-side 10 --scan 56 --duration 4 --fan-from 56 \
        --fan 59,59.5,60,62 --fan-duration 1.5 --set time.dt_fraction=0.1125

and Figure 3 damped's start seed 7 at N = 132 (16 starts): ``--k-wave 8 --k-side 9 --scan
45,40,35,30 --duration 2 --fan-from 30 --fan 30,31,31.5,32,33,34,35,35.5,36,38,40,42,43,45,50
--fan-duration 1.5 --seed-side 1e-2 --linear-below 0.01``; in Δt the same with ``--set
time.dt_fraction=0.45 --fan 30,30.5,31,31.5,32,33,34,35``, ``0.225 --fan
30,31,32,33,34,35,36,37,38,40,42,45,50`` and ``0.1125 --fan
30,31,32,33,34,36,38,40,42,45,50``; the torus itself: ``--k-wave 8 --k-side 9 --scan 50
--duration 6 --set time.dt_fraction=F`` (F = 0.9, 0.45, 0.225, 0.1125).

RUN_DIR: a run or census start standing near the rigid wave k_wave (its checkpoint). The
scan continues it along ``--scan`` (each value ``--duration`` s from the end of the one
before) and prints σ (the sideband's growth rate over the last half of each leg), its
frame frequency and its share |a_side|/|a_wave|. ``--fan`` then restarts the end state of
``--fan-from`` (a scan value) at each fan value for ``--fan-duration`` s and prints the
share over the run in tenths, and σ over its last 80 %: from a start whose sideband is
small (a long first scan leg), σ is the rigid wave's eigenvalue (real part) and the frame
frequency its imaginary part; from a finite sideband, a share that levels off is a two-wave
state, one that keeps growing leaves for another state. ``--seed-side EPS`` adds
EPS d cos(k_side θ) to each fan leg's start (a state without a sideband above round-off).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from stickslip.studies.rpo.birth import (
    checkpoint_state,
    mode_series,
    restart,
    scan_line,
    sideband_row,
    sideband_scan,
)

#: The fraction of a fan leg its growth rate is fitted over (the first fifth lets the start's
#: other modes decay).
FAN_FIT = 0.8


def floats(text: str) -> list[float]:
    return [float(x) for x in text.split(",") if x]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--key", default="loading.omega")
    ap.add_argument("--k-wave", type=int, required=True)
    ap.add_argument("--k-side", type=int, required=True)
    ap.add_argument("--scan", type=floats, required=True)
    ap.add_argument("--duration", type=float, default=1.0)
    ap.add_argument("--fan-from", type=float, default=None)
    ap.add_argument("--fan", type=floats, default=[])
    ap.add_argument("--fan-duration", type=float, default=6.0)
    ap.add_argument("--set", dest="overrides", action="append", default=[],
                    metavar="KEY=VALUE", help="override a key of the start's scene (e.g. "
                    "time.dt_fraction=0.45: the scan at half the step)")
    ap.add_argument("--linear-below", type=float, default=None, metavar="SHARE",
                    help="fit a fan leg's sigma only where its share is below SHARE")
    ap.add_argument("--seed-side", type=float, default=None, metavar="EPS",
                    help="add EPS d cos(k_side theta) to each fan leg's start")
    args = ap.parse_args()
    t0 = time.perf_counter()
    scene, state = checkpoint_state(args.run_dir)
    scene = scene.with_overrides(*args.overrides)
    fan_state = state
    for value in args.scan:
        rows, state = sideband_scan(scene, state, args.key, [value], args.k_wave,
                                    args.k_side, args.duration)
        print(f"{scan_line(rows[0], args.key)}  [{time.perf_counter() - t0:.0f} s]",
              flush=True)
        if args.fan_from is not None and value == args.fan_from:
            fan_state = state
    for value in args.fan:
        seed = None if args.seed_side is None else (args.k_side, args.seed_side)
        samples, dt, _ = restart(scene, fan_state, args.key, value, args.fan_duration, seed)
        t, side = mode_series(samples, args.k_side)
        _, wave = mode_series(samples, args.k_wave)
        share = np.abs(side) / np.abs(wave).mean()
        tenths = np.array_split(np.arange(t.size), 10)
        trace = " ".join(f"{share[i].mean():.3g}" for i in tenths)
        try:
            fit = sideband_row(samples, value, dt, args.k_wave, args.k_side, FAN_FIT,
                               args.linear_below)
        except ValueError as err:  # no sample in the linear range: the trace says why
            print(f"fan {args.key} = {value:g}: share by tenths {trace}; {err}")
            continue
        print(f"fan {args.key} = {value:g} from {args.fan_from:g} (dt {dt:.4g} s, "
              f"{args.fan_duration:g} s): share by tenths {trace}; sigma over the last "
              f"{FAN_FIT:.0%} {fit['sigma']:+.3f} 1/s (misfit {fit['misfit']:.2g}), frame "
              f"{fit['frame_hz']:+.2f} Hz  [{time.perf_counter() - t0:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
