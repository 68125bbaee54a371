"""``stickslip export RUN -o FILE.csv``: a run's probe time histories as CSV, and with
``--plot`` their spectrogram and spectrum, the frequencies of the census and the CEA marked."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from stickslip.cli.checks import fail, output_file_problem
from stickslip.cli.commands import command_help
from stickslip.postprocess.analysis import load_run
from stickslip.postprocess.plotting import save_figure
from stickslip.postprocess.probes import signal_figure, write_probe_csv
from stickslip.postprocess.style import wave_title
from stickslip.solver.scene import load_scene
from stickslip.studies.attractors.starts import rung_key
from stickslip.studies.flutter_fe import complex_eigenvalue_analysis
from stickslip.studies.rundir.readers import samples_problem

#: The CEA's resolved unstable modes marked, the fastest growing first (``CEAResult.unstable``).
CEA_MARKS = 8


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export",
        help=command_help("export"),
        description=(
            "Write the every-step histories of the run's probes (output.probes_deg: u_r, "
            "u_theta, v_r, v_theta of the nearest contact node) as one CSV table, a column "
            "per quantity and probe. With --plot, draw the spectrogram and the spectrum of "
            "the first probe's u_r, with the run's measured wave frequency marked, the "
            "components of a census's attractors at the run's N (--census) and the unstable "
            "frequencies of steady sliding (--cea)."),
    )
    p.add_argument("run_dir", help="a run directory (`stickslip run`)")
    p.add_argument("-o", "--output", required=True, metavar="FILE.csv",
                   help="the CSV file to write")
    p.add_argument("--plot", default=None, metavar="FILE.png",
                   help="also draw the spectrogram and spectrum into FILE.png")
    p.add_argument("--census", default=None, metavar="DIR",
                   help="mark the components of this census's members at the run's N")
    p.add_argument("--cea", action="store_true",
                   help=f"mark the frequencies of the {CEA_MARKS} fastest-growing resolved "
                   "unstable modes of the run's scene (the CEA; computed, seconds at N = 132)")
    p.add_argument("--cea-fmax-hz", type=float, default=5000.0, metavar="F",
                   help="upper end of the CEA's band (default 5000 Hz)")
    p.set_defaults(func=_export)


def _export(args: argparse.Namespace) -> int:
    run_dir = Path(args.run_dir)
    problem = (samples_problem(run_dir, need=4) or output_file_problem(args.output, "-o")
               or (args.plot and output_file_problem(args.plot, "--plot")))
    if problem:
        return fail(problem)
    if not (math.isfinite(args.cea_fmax_hz) and args.cea_fmax_hz > 0):
        return fail(f"--cea-fmax-hz {args.cea_fmax_hz}: give a finite frequency > 0 (Hz)")
    census = Path(args.census) if args.census else None
    if census is not None and not (census / "attractors.json").is_file():
        return fail(f"--census {census}: no attractors.json there; give a census "
                     "directory (`stickslip attractors ... -o DIR`)")

    run = load_run(run_dir)
    if "probe_t" not in run.samples or run.samples["probe_t"].size < 8:
        return fail(f"{run_dir}: the run recorded no probe history (output.probes_deg is "
                     "empty, or fewer than 8 steps); rerun it with a probe angle, e.g. "
                     "--set output.probes_deg=[0.0]")
    rows = write_probe_csv(run.samples, args.output)
    print(f"wrote {args.output}: {rows} steps of {run.samples['probe_deg'].size} probe(s)")
    if args.plot:
        marks = _marks(run, census, args.cea_fmax_hz if args.cea else None)
        _plot(run, marks, args.plot)
        print(f"figure: {args.plot}")
    return 0


def _marks(run, census: Path | None, cea_fmax_hz: float | None) -> dict:  # noqa: ANN001
    """The frequencies (Hz) to mark: the run's measured wave, the census's components at the
    run's N, the CEA's resolved unstable modes."""
    marks: dict[str, list[float]] = {}
    summary = run.summary
    if summary.get("frequency_hz"):
        marks[f"this run: mode k = {summary.get('mode')}"] = [summary["frequency_hz"]]
    if census is not None:
        answer = json.loads((census / "attractors.json").read_text())
        mesh = run.scene.get("mesh", {})  # the census's key of the run's rung
        n = rung_key(mesh.get("n_inner", 0), mesh.get("degree", 1))
        freqs = [c["frequency_hz"] for m in answer.get("members", {}).get(n, [])
                 for c in m.get("components", []) if c.get("frequency_hz") is not None]
        marks[f"census components (N = {n})"] = freqs
    if cea_fmax_hz is not None:
        # dolfinx for --cea only, after the command line and the environment are checked
        from stickslip.solver.problem import build_problem

        problem = build_problem(load_scene(run.path / "scene.toml"))
        res = complex_eigenvalue_analysis(problem, None, cea_fmax_hz)
        fastest = [m for m in res.unstable() if not m.mesh_scale][:CEA_MARKS]
        marks[f"CEA: the {len(fastest)} fastest unstable"] = [m.frequency_hz for m in fastest]
    return marks


def _plot(run, marks: dict, path: str) -> None:  # noqa: ANN001
    import matplotlib

    matplotlib.use("Agg")

    save_figure(signal_figure(run.samples, f"{run.scene.get('name', run.path.name)}: "
                              f"{wave_title(run.summary)}", marks), Path(path))
