"""docker/compare_summaries.py: summaries equal to round-off pass, real differences fail."""

from __future__ import annotations

import copy
import importlib.util
import json
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "compare_summaries", REPO / "docker" / "compare_summaries.py")
cs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(cs)

SUMMARY = {"status": "completed", "mode": 4, "celerity_m_s": -2519.5887789643566,
           "limit_cycle": False, "fractions": {"stick": 0.0, "slip": 0.5555555555555556},
           "wall_time_s": 7.3, "profile_s": {"time-loop": 1.98},
           "scheme": {"beta2": 0.6, "kernel_first_call_s": 1.05}}


def _tree(root: Path, summary: dict) -> Path:
    d = root / "runs" / "a"
    d.mkdir(parents=True)
    (d / "summary.json").write_text(json.dumps(summary))
    return root


def test_equal_up_to_round_off_and_timings_pass(tmp_path):
    other = copy.deepcopy(SUMMARY)
    other["celerity_m_s"] *= 1 + 1e-12  # round-off, far inside rtol = 1e-9
    other["wall_time_s"] = 99.0         # timings are machine-dependent: skipped
    other["profile_s"] = {"other": 1.0}
    other["scheme"]["kernel_first_call_s"] = 6.4  # numba compiles in a fresh container
    n, diffs, worst = cs.compare(_tree(tmp_path / "a", SUMMARY), _tree(tmp_path / "b", other))
    assert n == 1 and diffs == [] and 0 < worst < 1e-11


def test_physical_and_status_differences_fail(tmp_path):
    other = copy.deepcopy(SUMMARY)
    other["celerity_m_s"] *= 1 + 1e-6
    other["mode"] = 3
    other["fractions"]["stick"] = 1e-30  # an exact zero must stay zero
    other["status"] = "diverged"
    _, diffs, _ = cs.compare(_tree(tmp_path / "a", SUMMARY), _tree(tmp_path / "b", other))
    assert len(diffs) == 4, diffs


def test_missing_summary_or_key_fails(tmp_path):
    ref = _tree(tmp_path / "a", SUMMARY)
    (tmp_path / "b").mkdir()
    assert cs.main([str(ref), str(tmp_path / "b")]) == 1
    other = dict(SUMMARY)
    del other["mode"]
    _, diffs, _ = cs.compare(ref, _tree(tmp_path / "c", other))
    assert diffs and "keys differ" in diffs[0]
