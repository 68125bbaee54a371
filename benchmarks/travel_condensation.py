"""Cost of one damped wave-frame condensation: ``OMP_NUM_THREADS=1 ./dev python3
benchmarks/travel_condensation.py [N ...]`` (default 264 528).

For ``scenes/figure1_n132_damped.toml`` at N contact nodes (the scene's Kelvin–Voigt τ), the
CPU time of S(ω) alone (a fixed-ω solve needs only this) and of S with dS/dω (free-ω Newton,
``studies.travel.frame``: one sparse LU of the interior, two multi-right-hand-side solves),
after the operators are assembled and split once.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> None:
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    for n in [int(a) for a in sys.argv[1:]] or [264, 528]:
        scene = load_scene("scenes/figure1_n132_damped.toml", [f"mesh.n_inner={n}"])
        st = D.setup(scene, scene.damping.tau)
        st.ops.stiffness(-2600.0, False)  # the blocks are split once
        c0 = time.process_time()
        st.ops.stiffness(-2610.0, False)
        c1 = time.process_time()
        st.ops.stiffness(-2620.0, True)
        c2 = time.process_time()
        print(f"N = {n} ({st.ops.problem.n_global_dofs} dofs): S(ω) {c1 - c0:.2f} s CPU; "
              f"S and dS/dω {c2 - c1:.2f} s CPU", flush=True)


if __name__ == "__main__":
    main()
