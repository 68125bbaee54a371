"""``stickslip compare RUN_DIR``: the FE wave against the reduced model's waves."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from stickslip.cli.checks import fail, output_file_problem
from stickslip.cli.commands import command_help
from stickslip.cli.semianalytic import KMAX_LIMIT
from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import load_scene
from stickslip.studies.rundir.readers import samples_problem
from stickslip.studies.verification import compare_run, format_table, modal_table


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare",
        help=command_help("compare"),
        description=(
            "Measure the FE wave of RUN_DIR (mode k, signed celerity, frequency, psi1, psi2, "
            "amplitudes, zone order) and put it side by side with every travelling wave of "
            "the reduced model (eqs. [2]-[7]) at the same parameters and k, plus the reduced "
            "flutter phase speed. Writes the table as JSON (default RUN_DIR/compare.json)."
        ),
    )
    p.add_argument("run_dir", help="a run directory written by `stickslip run`")
    p.add_argument("--json", dest="json_out", help="output JSON (default RUN_DIR/compare.json)")
    p.add_argument("--k", type=int, action="append", default=[],
                   help="also compare with reduced waves of this wavenumber (repeatable)")
    p.add_argument("--markdown", action="store_true", help="print a markdown table")
    p.add_argument("--modal", action="store_true",
                   help="also compute FE natural frequencies / flutter modes (N <= 264)")
    p.set_defaults(func=_compare)


def _compare(args: argparse.Namespace) -> int:
    run_dir = Path(args.run_dir)
    out = Path(args.json_out) if args.json_out else run_dir / "compare.json"
    problem = samples_problem(run_dir, need=4) or output_file_problem(out, "--json")
    if problem:
        return fail(problem)
    ks = list(args.k)

    if bad := [k for k in ks if not 1 <= k <= KMAX_LIMIT]:
        print(f"error: --k {bad[0]}: give a wavenumber 1 <= k <= {KMAX_LIMIT} (the reduced "
              "model's waves per turn)", file=sys.stderr)
        return 2
    result = compare_run(run_dir, ks)
    if args.modal:
        scene = load_scene(run_dir / "scene.toml")
        result["fe_modes"] = modal_table(scene, sorted({result["fe"]["k"], *ks}))
    print(format_table(result, markdown=args.markdown))
    if args.modal:
        for k, row in result["fe_modes"].items():
            print(f"k = {k}: " + ", ".join(f"{key} {val:.1f}" for key, val in row.items()
                                           if val is not None))

    atomic_write_text(out, json.dumps(result, indent=2, default=_json_default))
    print(f"table: {out}")
    return 0


def _json_default(obj):
    if isinstance(obj, np.integer | np.bool_):
        return obj.item()
    if isinstance(obj, np.floating):
        return float(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


