"""The census of several scenes on a GPU node without dolfinx, through the product's bundle
route (``stickslip attractors ... --bundle DIR``, docs/gpu.md), with the rows that
benchmarks/certify_census.py reads.

``prepare DIR SCENE...`` (where dolfinx is): one bundle per scene, ``DIR/<scene stem>``, and
``DIR/census_args.json`` (the census arguments, for ``answer``);
``run DIR [--backend cpu]`` (the node): ``python3 -m stickslip.node`` on every bundle (its
lines give each batch's scene-steps/s);
``answer DIR --into CENSUS_DIR`` (where dolfinx is): each scene's census answered from its
bundle into ``CENSUS_DIR/<scene stem>`` (settle-or-extend off: ``--max-time`` = ``--end-time``)
and every start's row, with its scene, in ``CENSUS_DIR/rows.jsonl``.

Example (docs/attractors.md, "The damped paper scenes on a GPU")::

    ./dev python3 benchmarks/gpu_census.py prepare build/gpu_census \\
        scenes/figure1_n132_damped.toml scenes/figure3_n132_damped.toml \\
        --meshes 132,264,528 --starts 64 --structured 1:12 --end-time 2.0
    python3 benchmarks/gpu_census.py run build/gpu_census                    # GPU node
    ./dev python3 benchmarks/gpu_census.py answer build/gpu_census --into runs/census
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def _census_args(args: dict, scene: str, bundle: Path) -> list[str]:
    return ["attractors", scene, "--meshes", args["meshes"], "--starts", str(args["starts"]),
            "--structured", args["structured"], "--end-time", repr(args["end_time"]),
            "--max-time", repr(args["end_time"]), "--no-certify", "--bundle", str(bundle)]


def main(argv: list[str] | None = None) -> int:
    from stickslip.cli.main import main as stickslip

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="stage", required=True)
    p = sub.add_parser("prepare", help="one bundle per scene (needs dolfinx)")
    p.add_argument("directory", type=Path)
    p.add_argument("scenes", nargs="+")
    p.add_argument("--meshes", default="132,264,528")
    p.add_argument("--starts", type=int, default=64)
    p.add_argument("--structured", default="1:12")
    p.add_argument("--end-time", type=float, default=2.0)
    p = sub.add_parser("run", help="every bundle on the node")
    p.add_argument("directory", type=Path)
    p.add_argument("--backend", choices=("gpu", "cpu"), default="gpu")
    p = sub.add_parser("answer", help="every scene's census and rows.jsonl (needs dolfinx)")
    p.add_argument("directory", type=Path)
    p.add_argument("--into", type=Path, required=True)
    args = ap.parse_args(argv)
    meta_path = args.directory / "census_args.json"
    if args.stage == "prepare":
        args.directory.mkdir(parents=True, exist_ok=True)
        meta = {"meshes": args.meshes, "starts": args.starts, "structured": args.structured,
                "end_time": args.end_time, "scenes": args.scenes}
        meta_path.write_text(json.dumps(meta, indent=1) + "\n")
        return max(stickslip(_census_args(meta, s, args.directory / Path(s).stem))
                   for s in args.scenes)
    meta = json.loads(meta_path.read_text())
    if args.stage == "run":
        return max(subprocess.run([sys.executable, "-m", "stickslip.node",
                                   str(args.directory / Path(s).stem), "--backend",
                                   args.backend], cwd=REPO).returncode for s in meta["scenes"])
    rc, rows = 0, []
    for s in meta["scenes"]:
        out = args.into / Path(s).stem
        rc = max(rc, stickslip([*_census_args(meta, s, args.directory / Path(s).stem), "-o",
                                str(out)]))
        answer = json.loads((out / "attractors.json").read_text())
        rows += [{"scene": answer["scene"]["name"], **r} for r in answer["starts"]]
    (args.into / "rows.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return rc


if __name__ == "__main__":
    sys.exit(main())
