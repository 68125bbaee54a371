"""The half-step test of a census member: is it an end state of the finer scheme too?

A census runs every start at the scene's step Δt (0.9 Δt_crit by default). The time step is
a rung of the discretisation as the mesh is (docs/attractors.md, "The time step is a rung
too"): a companion wave of a multi-wave member can be the step's. The test restarts the
member's first start where its checkpoint stands, (u, v~) as (u_0, v_0), in the same scene
at half the step (``time.dt_fraction`` / 2, or ``time.dt`` / 2), runs it alone on this rank
for ``HALF_STEP_WINDOWS`` census windows W, and compares the features of its last window
with the start's own last window (``features.differences``, the census's tolerances):
**kept** when they match; otherwise what moved, and the components at Δt/2 say what the
state became. Taking v~ for v_0 perturbs the velocity by O(Δt a), about a kick test's size:
an end state of the finer scheme returns from it. Nothing of the start is written or
changed. ``stickslip attractors ... --half-step`` runs it on every multi-wave member.
"""

from __future__ import annotations

import json
from pathlib import Path

from stickslip.studies.attractors.features import (
    Features,
    components_text,
    differences,
    window_features,
)
from stickslip.studies.rpo.birth import checkpoint_state, restart
from stickslip.studies.rundir.readers import ReadError

__all__ = ["HALF_STEP_WINDOWS", "at_checkpoint", "half_step_line", "half_step_members",
           "half_step_run"]

#: The census windows W a restarted start runs at Δt/2; its last one is compared.
HALF_STEP_WINDOWS = 4


def at_checkpoint(row: dict) -> bool:
    """Whether a start's run completed at a whole level, its checkpoint a test's start (a
    batch member's, or a one-scene run's: a 3D tube, an implicit scene)."""
    try:
        summary = json.loads((Path(row["run_dir"]) / "summary.json").read_text())
    except (OSError, ValueError, KeyError):
        return False
    return summary.get("status") == "completed"


def half_step_run(run_dir: str | Path, windows: int, window: float) -> dict:
    """The samples (``samples``) of ``run_dir``'s scene at half its step (``dt_s``) from its
    checkpoint's (u, v~) (``studies.rpo.birth.restart``), over ``windows`` W, and the contact
    radius (``radius``)."""
    scene, state = checkpoint_state(run_dir)  # KeyError: no v~ (implicit scheme)
    ts = scene.time
    key, value = (("time.dt", ts.dt / 2) if ts.dt > 0
                  else ("time.dt_fraction", ts.dt_fraction / 2))
    samples, dt, _ = restart(scene, state, key, value, windows * window)
    return {"samples": samples, "dt_s": dt, "radius": float(scene.geometry.R)}


def half_step_members(groups: dict[str, list[dict]], window: float, tol) -> dict[str, dict]:  # noqa: ANN001 - features.Tolerances
    """The half-step test (module docstring) of each member of ``groups`` (key: "N:member",
    its rows, first start first); never raises. Per key: {"kept", "differences", "start",
    "dt_s", "components"} or {"message"} where it could not run."""
    out: dict[str, dict] = {}
    for key, rows in groups.items():
        row = next((r for r in rows if r.get("features") and at_checkpoint(r)), None)
        if row is None:
            out[key] = {"message": "not run: no start of it ended at a checkpoint"}
            continue
        try:
            run = half_step_run(row["run_dir"], HALF_STEP_WINDOWS, window)
            samples = run["samples"]
            t_end = float(samples["t"][-1])
            after = window_features(samples, run["radius"], t_end - window, t_end)
            why = differences(Features.from_dict(row["features"]), after, tol)
            out[key] = {"kept": not why, "differences": why, "start": row["id"],
                        "dt_s": run["dt_s"], "components": components_text(after.components)}
        except (ReadError, ValueError, KeyError, OSError, RuntimeError) as err:
            out[key] = {"message": f"not run: {type(err).__name__}: {err}"}
    return out


def half_step_line(result: dict) -> str:
    """One short phrase for a half-step test (``half_step_members``)."""
    if "kept" not in result:
        return f"at Δt/2 {result.get('message', 'not run')}"
    if result["kept"]:
        return f"kept at Δt/2 ({result['dt_s']:.3g} s)"
    return (f"moved at Δt/2 ({result['dt_s']:.3g} s: {'; '.join(result['differences'][:2])}); "
            f"there: {result['components']}")
