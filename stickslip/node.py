"""``python3 -m stickslip.node DIR``: run a census bundle on a node without dolfinx or MPI.

The bundle is prepared where the FE stack is (``stickslip attractors SCENE ... --bundle
DIR``); this runner needs numpy, scipy and, for ``--backend gpu`` (the default), CuPy with a
CUDA device (``--backend cpu``: the numba kernel, the same numbers bit for bit). It writes
``DIR/results``; copied back, the same ``stickslip attractors ... --bundle DIR`` command
answers the census (docs/gpu.md). Exit status: 0 done, 2 bad input (one line naming the
fix), 130 interrupted (run it again: finished batches are kept).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from stickslip.solver.bundle import run_bundle


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m stickslip.node",
                                 description=__doc__.splitlines()[0].split(": ", 1)[1])
    ap.add_argument("directory", type=Path, help="the bundle directory (manifest.json)")
    ap.add_argument("--backend", choices=("gpu", "cpu"), default="gpu",
                    help="gpu: CuPy and the CUDA kernel (default); cpu: the numba kernel")
    args = ap.parse_args(argv)

    try:
        return run_bundle(args.directory, args.backend)
    except (ValueError, ImportError, OSError) as err:
        print(f"error: {err}", file=sys.stderr, flush=True)
        return 2
    except KeyboardInterrupt:
        print("interrupted: run the same command again (finished batches are kept)",
              file=sys.stderr, flush=True)
        return 130


if __name__ == "__main__":
    sys.exit(main())
