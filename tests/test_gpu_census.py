"""The census of a GPU node without dolfinx (benchmarks/gpu_census.py) is the census of
``stickslip attractors``: the same starts, batches, time loop and classification, so the
same rows, bit for bit.

A census of the damped Figure-1 scene on the N = 36 mesh (2 random starts and the mode-4
start, 0.02 s): ``prepare`` here, ``run`` with the numba batch (the node's CPU path) and with
the CUDA source compiled for the CPU (the GPU path, emulated), ``answer``; against
``stickslip attractors`` with the same arguments. Equality is exact: the CUDA kernel is
bitwise the numba kernel (tests/test_gpu.py), the starts are rebuilt from the dof coordinates
with dolfinx's operations (``prepare`` checks the rebuild: difference 0), and the analysis is
the same code on the same arrays.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "scenes" / "figure1_n132_damped.toml"
ARGS = {"starts": 2, "structured": "4", "meshes": "36", "end_time": 0.02}
COMPARED = ("class", "k", "direction", "regime", "celerity_m_s", "frequency_hz", "psi1",
            "psi2", "amplitude_m", "rms_amplitude_m", "frame_spread", "spread_trend",
            "limit_cycle", "member")


def _gpu_census():
    sys.path.insert(0, str(REPO / "benchmarks"))
    import gpu_census

    return gpu_census


def _rows(path: Path) -> dict[str, dict]:
    answer = json.loads(path.read_text())
    return {r["id"]: {k: r[k] for k in COMPARED} for r in answer["starts"]}


@pytest.mark.dolfinx
def test_offloaded_census_rows_equal_the_cli_census(tmp_path, capsys):
    pytest.importorskip("numba")
    from cli.main import main

    gc = _gpu_census()
    prep = tmp_path / "prep"
    gc.main(["prepare", str(prep), str(SCENE), "--meshes", ARGS["meshes"], "--starts",
             str(ARGS["starts"]), "--structured", ARGS["structured"], "--end-time",
             str(ARGS["end_time"])])
    assert "start rebuild max |diff| = 0 m" in capsys.readouterr().out
    targets = [["--target", "cpu"]]
    if shutil.which("g++"):
        targets.append(["--emulate"])
    answers = []
    for i, target in enumerate(targets):
        out = tmp_path / f"out{i}"
        gc.main(["run", str(prep), "--out", str(out), "--workers", "1", *target])
        rows = (out / "rows.jsonl").read_text()
        gc.main(["run", str(prep), "--out", str(out), "--workers", "1", *target])
        assert (out / "rows.jsonl").read_text() == rows  # a rerun resumes: nothing twice
        gc.main(["answer", str(prep), str(out), "--into", str(tmp_path / f"answer{i}")])
        answers.append(_rows(tmp_path / f"answer{i}" / SCENE.stem / "attractors.json"))
    cli = tmp_path / "cli"
    # --max-time = --end-time: the offloaded census runs every start for the first leg only
    # (no settle-or-extend on the node), so the command is asked for the same runs
    assert main(["attractors", str(SCENE), "--starts", str(ARGS["starts"]), "--meshes",
                 ARGS["meshes"], "--structured", ARGS["structured"], "--end-time",
                 str(ARGS["end_time"]), "--max-time", str(ARGS["end_time"]), "-o", str(cli),
                 "--no-certify"]) == 0
    reference = _rows(cli / "attractors.json")
    assert len(reference) == 3
    for rows in answers:
        assert rows == reference


def test_offloaded_census_bad_input_one_line_exit_2(tmp_path, capsys):
    gc = _gpu_census()
    for argv, words in ((["run", str(tmp_path), "--out", str(tmp_path / "o")], "no batch files"),
                        (["answer", str(tmp_path), str(tmp_path / "o"), "--into",
                          str(tmp_path / "a")], "rows.jsonl not found")):
        with pytest.raises(SystemExit) as exc:
            gc.main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and words in err and len(err.strip().splitlines()) == 1
