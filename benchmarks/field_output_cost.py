"""What field output (``output.fields``) costs: time per step against a run without it, and
the size on disk per written frame, against the estimate of ``studies.resources``.

Run: ``./dev python3 benchmarks/field_output_cost.py [N ...]`` (default N = 132 528), one
core. For each N the Figure-3 scene (``figure3_n132`` with ``mesh.n_inner = N``) is built
twice in one process, without and with fields (VTX, every ``--interval`` seconds, the whole
run in the window); the two advance side by side in chunks of ``CHUNK`` s of sim time, so
both see the same machine load; the loop time of each is its median chunk times the
number of chunks (robust to the other jobs of a shared machine), and their ratio is the cost.
The first chunk (compiling the kernels) is not timed. Prints one row per N: the timed steps
and frames, the two loop times, the ratio, the seconds per frame,
the measured and the estimated bytes per frame.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from stickslip.solver.run import Simulation  # noqa: E402
from stickslip.solver.scene import load_scene  # noqa: E402
from stickslip.studies.resources import estimate  # noqa: E402

CHUNK = 1e-3  # s of sim time per turn


def _size(path: Path) -> int:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


def measure(n_inner: int, end_time: float, interval: float) -> dict:
    common = [f"mesh.n_inner={n_inner}", f"time.end_time={end_time}", "output.progress=false",
              "time.kernel=numba"]
    plain = load_scene("figure3_n132", common)
    fields = load_scene("figure3_n132", [*common, "output.fields=true",
                                         f"output.field_interval={interval}",
                                         f"output.field_window={end_time}"])
    with tempfile.TemporaryDirectory() as tmp:
        sims = [Simulation(plain, MPI.COMM_SELF), Simulation(fields, MPI.COMM_SELF,
                                                             output_dir=Path(tmp))]
        for sim in sims:  # compile the kernels, write the first frame: not timed
            sim.proceed(end_time=CHUNK)
        warm_frames, warm_steps = sims[1].observers[0].frames, sims[0].steps
        chunks: list[list[float]] = [[], []]
        t = CHUNK
        while t < end_time - 1e-12:
            t = min(end_time, t + CHUNK)
            for i, sim in enumerate(sims):
                t0 = time.perf_counter()
                sim.proceed(end_time=t)
                chunks[i].append(time.perf_counter() - t0)
        # the median chunk, times the chunks: robust to the other jobs of a shared machine
        wall = [float(np.median(c)) * len(c) for c in chunks]
        sims[1].columns.writer.close()
        frames = sims[1].observers[0].frames
        timed_frames = frames - warm_frames
        size = _size(Path(tmp))
    est = estimate(fields)
    return {"N": n_inner, "dofs": int(sims[0].problem.n_global_dofs),
            "steps": sims[0].steps - warm_steps,
            "frames": timed_frames, "loop_s": wall[0], "loop_fields_s": wall[1],
            "ratio": wall[1] / wall[0], "s_per_frame": (wall[1] - wall[0]) / timed_frames,
            "bytes_per_frame": size / frames,
            "estimated_bytes_per_frame": est.field_bytes / max(1, est.field_frames)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("N", nargs="*", type=int, default=[132, 528])
    parser.add_argument("--end-time", type=float, default=0.01)
    parser.add_argument("--interval", type=float, default=1e-4,
                        help="output.field_interval [s] (default 1e-4, the sample interval)")
    args = parser.parse_args()
    print(f"{'N':>5} {'dofs':>7} {'steps':>6} {'frames':>6} {'loop s':>8} {'+fields s':>9} "
          f"{'ratio':>6} {'ms/frame':>8} {'kB/frame':>8} {'est kB':>7}")
    for n in args.N:
        r = measure(n, args.end_time, args.interval)
        print(f"{r['N']:>5} {r['dofs']:>7} {r['steps']:>6} {r['frames']:>6} "
              f"{r['loop_s']:>8.3f} {r['loop_fields_s']:>9.3f} {r['ratio']:>6.2f} "
              f"{1e3 * r['s_per_frame']:>8.2f} {r['bytes_per_frame'] / 1e3:>8.1f} "
              f"{r['estimated_bytes_per_frame'] / 1e3:>7.1f}")


if __name__ == "__main__":
    main()
