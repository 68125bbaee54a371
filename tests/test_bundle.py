"""The bundle route of a census (``stickslip attractors ... --bundle DIR``, then
``python3 -m stickslip.node DIR`` on a node without dolfinx, then the same command) answers
as the command's own census.

A census of the damped Figure-1 scene on the N = 36 mesh (2 random starts and the mode-4
start, first leg 0.02 s, settle-or-extend to 0.03 s). The node runs the numba kernel, the
kernel of the command's batched sweep, on the same u_0 (built by the same
``Simulation.batch``), through the same ``run_loop``: every start's samples and checkpoint are
bitwise those of the command's census, and so is every row of attractors.json but its wall
time and run directory; the unsettled starts are continued from the node's checkpoints as
from the command's own. The emulated CUDA kernel (CuPy replaced by the CUDA source compiled
for the CPU, benchmarks/gpu_emulate.py) gives the same rows, its unsettled starts continued
here on the CPU from the GPU's checkpoints: its dynamics are bitwise the numba ones
(tests/test_gpu.py), its work sums are kept per node.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "scenes" / "figure1_n132_damped.toml"
ARGS = ["attractors", str(SCENE), "--starts", "2", "--structured", "4", "--meshes", "36",
        "--end-time", "0.02", "--no-certify"]
#: what may differ between two censuses of the same starts: the clock and the folder
UNCOMPARED = ("wall_time_s", "run_dir")
#: The node imports none of the FE stack: a finder that refuses them, then the runner.
BLOCKER = """
import runpy, sys
class Refuse:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("dolfinx", "mpi4py", "petsc4py", "ufl", "basix"):
            raise ImportError(f"{name} is blocked: the node has no FE stack")
sys.meta_path.insert(0, Refuse())
sys.argv = ["stickslip.node", *sys.argv[1:]]
runpy.run_module("stickslip.node", run_name="__main__")
"""


def _node(bundle: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", BLOCKER, str(bundle), *extra], cwd=REPO,
                          capture_output=True, text=True, timeout=300)


def _rows(census: Path) -> dict[str, dict]:
    answer = json.loads((census / "attractors.json").read_text())
    return {r["id"]: {k: v for k, v in r.items() if k not in UNCOMPARED}
            for r in answer["starts"]}


def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files if k != "meta"}


@pytest.mark.dolfinx
def test_bundle_census_equals_the_command_census(tmp_path, capsys):
    pytest.importorskip("numba")
    from stickslip.cli.main import main

    bundle, census, reference = tmp_path / "bundle", tmp_path / "census", tmp_path / "ref"
    answer = [*ARGS, "--max-time", "0.03", "--bundle", str(bundle), "-o", str(census)]
    assert main(answer) == 0  # prepares
    assert "python3 -m stickslip.node" in capsys.readouterr().out
    assert main(answer) == 2  # the node has not run yet: one line naming the fix
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "python3 -m stickslip.node" in err[0], err
    done = _node(bundle, "--backend", "cpu")
    assert done.returncode == 0, done.stderr
    assert "3 completed" in done.stdout
    again = _node(bundle, "--backend", "cpu")  # a rerun: nothing runs twice
    assert again.returncode == 0 and "done already" in again.stdout, again.stderr
    assert main(answer) == 0
    assert "settle: continuing 3" in capsys.readouterr().out  # from the node's checkpoints
    assert main([*ARGS, "--max-time", "0.03", "-o", str(reference)]) == 0
    rows = _rows(census)
    assert len(rows) == 3 and rows == _rows(reference)
    for run in (reference / "starts" / "runs").iterdir():
        mine = census / "starts" / "runs" / run.name
        for name in ("samples.npz", "checkpoint.npz"):  # bitwise: the same kernel
            ours, theirs = _arrays(mine / name), _arrays(run / name)
            assert ours.keys() == theirs.keys()
            assert all(np.array_equal(ours[k], theirs[k]) for k in ours), (run.name, name)


@pytest.mark.dolfinx
@pytest.mark.skipif(shutil.which("g++") is None, reason="the CUDA emulation compiles C++")
def test_bundle_on_the_emulated_gpu_gives_the_command_census(tmp_path, monkeypatch, capsys):
    pytest.importorskip("numba")
    from benchmarks import gpu_emulate
    from stickslip.cli.main import main
    from stickslip.node import main as node
    from stickslip.solver.observers import Progress

    bundle, census, reference = tmp_path / "bundle", tmp_path / "census", tmp_path / "ref"
    answer = [*ARGS, "--max-time", "0.03", "--bundle", str(bundle), "-o", str(census)]
    assert main(answer) == 0
    with monkeypatch.context() as m:
        m.setitem(sys.modules, "cupy", gpu_emulate.cupy_module())
        # every sample "due" for a progress line (a node's batch ran silent until its end)
        m.setattr(Progress, "due", lambda self: self.enabled)
        assert node([str(bundle)]) == 0  # --backend gpu, the default
    out = capsys.readouterr().out
    assert "gpu): 3 completed" in out and "(100.0%)" in out
    # the GPU's checkpoints go on here, on the CPU (no CuPy): the same dynamics' bits
    assert main(answer) == 0
    assert "settle: continuing 3" in capsys.readouterr().out
    log = (census / "settle-rank0.log").read_text()  # the continuations' own lines
    assert "3 checkpoint(s) of the gpu backend continue on the cpu" in log
    assert main([*ARGS, "--max-time", "0.03", "-o", str(reference)]) == 0
    assert _rows(census) == _rows(reference)
    for run in (reference / "starts" / "runs").iterdir():
        ours, theirs = (_arrays(d / "samples.npz") for d in (census / "starts" / "runs"
                                                             / run.name, run))
        for key in ("u_r", "u_theta", "v_r", "v_theta", "status", "r_r", "r_theta"):
            assert np.array_equal(ours[key], theirs[key]), (run.name, key)
        # the energies' sums run in CuPy's order on the first leg: round-off apart (1e-14
        # of their scale measured on an H200; 1e-12 leaves room for other devices)
        scale = np.abs(theirs["energies"]).max()
        np.testing.assert_allclose(ours["energies"], theirs["energies"], rtol=0,
                                   atol=1e-12 * scale)


def _one_line_exit_2(rc: int, err: str, words: str) -> None:
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0], \
        lines


def test_node_refuses_a_directory_without_a_bundle(tmp_path):
    done = _node(tmp_path)
    _one_line_exit_2(done.returncode, done.stderr, "manifest.json not found")


def test_node_backend_gpu_without_cupy_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    from stickslip.node import main as node
    from stickslip.solver.bundle import KIND, MANIFEST

    (tmp_path / MANIFEST).write_text(json.dumps({"kind": KIND, "format": 1, "batches": []}))
    monkeypatch.setitem(sys.modules, "cupy", None)  # ``import cupy`` fails
    _one_line_exit_2(node([str(tmp_path)]), capsys.readouterr().err, "needs CuPy")
    assert node([str(tmp_path), "--backend", "cpu"]) == 0  # nothing to run


@pytest.mark.dolfinx
def test_bundle_of_another_census_is_refused(tmp_path, capsys):
    from stickslip.cli.main import main

    bundle = tmp_path / "bundle"
    assert main([*ARGS, "--bundle", str(bundle), "-o", str(tmp_path / "c")]) == 0
    capsys.readouterr()
    other = [a if a != "2" else "3" for a in ARGS]  # 3 random starts, not 2
    rc = main([*other, "--bundle", str(bundle), "-o", str(tmp_path / "c")])
    _one_line_exit_2(rc, capsys.readouterr().err, "another scene point")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("a user's file\n")
    rc = main([*ARGS, "--bundle", str(tmp_path / "full"), "-o", str(tmp_path / "c")])
    _one_line_exit_2(rc, capsys.readouterr().err, "not empty")
