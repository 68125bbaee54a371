"""One validated reader for every file that stickslip reads back.

Each reader checks what it reads: the file's type (a JSON object, a TOML scene, a numpy
archive without pickles), the keys, shapes and value types the writer makes. A corrupt,
truncated, foreign or edited file raises :class:`ReadError`, whose message is one line naming
the file, what is wrong and the fix; ``cli.main`` prints it and exits 2.

=====================  ==================================================================
``read_summary``       ``summary.json`` of a run (or travel) directory: an object with a
                       string ``scene`` and a known ``status``
``read_scene_file``    ``scene.toml`` (a scene that loads and validates)
``read_samples``       ``samples.npz``: ``t`` (n,), ``theta`` (m,), ``u_r``, ``u_theta``,
                       ``status`` (n, m); finite times in increasing order
``read_field``         ``final_field.npz``: ``points`` (p, >=2), ``u`` (p, 2), ``cells``,
                       ``cell_types``, ``time``
``read_sweep_table``   ``sweep.json``: the sweep kind, ``parameters`` and ``rows`` objects
``check_run_dir``      every file of a run directory, and that they agree, before a
                       command uses it
=====================  ==================================================================

Light (standard library and numpy; the scene reader imports ``solver.scene`` on use).
"""

from __future__ import annotations

import json
import os
import tomllib
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from stickslip.solver.scene import SceneError, load_scene, scene_to_dict
from stickslip.solver.scene.files import scene_digest
from stickslip.studies.rundir.ownership import open_regular
from stickslip.studies.rundir.summary_file import SUMMARY

__all__ = ["STATUSES", "ReadError", "check_run_dir", "read_field", "read_json_object",
           "check_agreement", "read_samples", "read_scene_file", "read_summary", "read_surface",
           "read_sweep_table", "samples_problem"]

#: Every status a summary may hold (``studies.rundir.scene_run``, the sweep's table).
STATUSES = ("running", "completed", "diverged", "failed", "stopped", "interrupted",
            "converged", "crashed")
_RERUN = "run it again (or delete the directory)"


class ReadError(ValueError):
    """A file that stickslip wrote cannot be used as it is: one line, file, fault, fix."""

    def __init__(self, path: str | Path, fault: str, fix: str = _RERUN) -> None:
        super().__init__(f"{path}: {fault}; {fix}")
        self.path = Path(path)


def _no_link(p: Path, fix: str = _RERUN) -> None:
    """Refuse a file that is a symbolic link: stickslip writes each file itself (atomic
    rename), so a link is someone else's and may point anywhere."""
    if p.is_symlink():
        raise ReadError(p, "is a symbolic link, which stickslip never writes (replaced by "
                           "hand?)", fix)


def _read_bytes(p: Path) -> bytes:
    """The bytes of ``p``, a regular file (``ownership.open_regular``: OSError otherwise)."""
    with os.fdopen(open_regular(p), "rb") as fh:
        return fh.read()


def read_json_object(path: str | Path, fix: str = _RERUN) -> dict:
    """The JSON object in ``path`` (a list, a number, bad JSON or bad UTF-8 is refused)."""
    p = Path(path)
    _no_link(p, fix)
    try:
        text = _read_bytes(p).decode("utf-8")
    except FileNotFoundError:
        raise ReadError(p, "missing", fix) from None
    except UnicodeDecodeError as err:
        raise ReadError(p, f"not UTF-8 text (byte {err.start})", fix) from None
    except OSError as err:
        raise ReadError(p, f"cannot be read ({err.strerror})", fix) from None
    try:
        data = json.loads(text)
    except (ValueError, RecursionError) as err:
        raise ReadError(p, f"not valid JSON ({str(err)[:60]})", fix) from None
    if not isinstance(data, dict):
        raise ReadError(p, f"holds a JSON {type(data).__name__}, not the object stickslip "
                           "writes", fix)
    return data


def read_summary(run_dir: str | Path) -> dict:
    """``RUN_DIR/summary.json``, checked: an object with a string ``scene`` and a status."""
    p = Path(run_dir) / SUMMARY
    s = read_json_object(p)
    status = s.get("status")
    if status not in STATUSES:
        raise ReadError(p, f"status {status!r} is not one that stickslip writes")
    if "scene" in s and not isinstance(s["scene"], str):
        raise ReadError(p, "'scene' is not a scene name")
    return s


def read_scene_file(path: str | Path) -> Any:
    """The :class:`solver.scene.Scene` in ``path`` (a saved ``scene.toml``)."""
    p = Path(path)
    _no_link(p)
    if not p.is_file():
        raise ReadError(p, "missing" if not p.exists() else "not a regular file (a FIFO, a "
                        "device or a folder?)")
    try:
        scene = load_scene(p)
        written = tomllib.loads(p.read_text(encoding="utf-8"))
    except SceneError as err:
        raise ReadError(p, f"not a valid scene ({str(err).removeprefix(f'{p}: ')[:120]})") \
            from None
    except (RecursionError, MemoryError):
        raise ReadError(p, "nested too deeply to be a scene") from None
    missing = [k for k, v in scene_to_dict(scene).items() if isinstance(v, dict)
               and k not in written]
    if missing:  # stickslip writes every section; defaults would stand in for them
        raise ReadError(p, f"has no [{'], ['.join(missing)}] (not the resolved scene "
                           "stickslip writes; edited or truncated)")
    return scene


def _load_npz(p: Path, keys: tuple[str, ...], fix: str = _RERUN) -> dict[str, np.ndarray]:
    """Every member of the archive ``p`` (no pickles), with ``keys`` required. A plain
    ``.npy`` array, a member too large to hold and a damaged archive are refused alike."""
    _no_link(p, fix)
    if not p.is_file():
        raise ReadError(p, "missing", fix)
    try:
        with os.fdopen(os.open(p, os.O_RDONLY | os.O_NOFOLLOW), "rb") as fh:
            data = np.load(fh, allow_pickle=False)
            if not isinstance(data, np.lib.npyio.NpzFile):
                raise ReadError(p, "holds one bare array, not the archive stickslip writes "
                                   "(replaced?)", fix)
            with data:
                missing = [k for k in keys if k not in data.files]
                if missing:
                    raise ReadError(p, f"has no {', '.join(missing)} (not written by "
                                       "stickslip)", fix)
                return {k: data[k] for k in data.files}
    except ReadError:
        raise
    except (OSError, ValueError, KeyError, EOFError, MemoryError, zipfile.BadZipFile,
            zipfile.LargeZipFile, NotImplementedError) as err:
        raise ReadError(p, f"not a readable numpy archive ({type(err).__name__}: "
                           f"{' '.join(str(err).split())[:60]})", fix) from None


def _shape(p: Path, a: np.ndarray, name: str, shape: tuple) -> None:
    """Shape ``shape`` (None: any length) and a real numeric dtype, else ReadError."""
    ok = a.ndim == len(shape) and all(s is None or s == n for s, n in zip(shape, a.shape,
                                                                          strict=True))
    if not ok or not (np.issubdtype(a.dtype, np.number) and not np.iscomplexobj(a)):
        want = "x".join("n" if s is None else str(s) for s in shape) or "scalar"
        raise ReadError(p, f"{name} has shape {a.shape} and dtype {a.dtype}, not {want} "
                           "numbers (edited or foreign)")


def read_samples(run_dir: str | Path, need: int = 1) -> dict[str, np.ndarray]:
    """``RUN_DIR/samples.npz``, checked (keys, shapes, times); at least ``need`` samples."""
    p = Path(run_dir) / "samples.npz"
    data = _load_npz(p, ("t", "theta", "u_r", "u_theta", "status"))
    t, theta = data["t"], data["theta"]
    _shape(p, t, "t", (None,))
    _shape(p, theta, "theta", (None,))
    for key in ("u_r", "u_theta", "status"):
        _shape(p, data[key], key, (t.size, theta.size))
    if t.size and (not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0)):
        raise ReadError(p, "the sample times t are not finite and increasing (edited)")
    if t.size < need:
        fix = ("run longer (time.end_time) or sample more often (output.sample_interval)")
        why = ("holds no sample: the run ended before its first sample period" if not t.size
               else f"holds {t.size} samples, fewer than the {need} needed")
        raise ReadError(p, why, fix)
    return data


def read_surface(run_dir: str | Path, samples: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``RUN_DIR/surface.npz`` of a 3D run, checked against its ``samples`` (read_samples):
    the same times, u and statuses on a (samples, rings, angles) grid."""
    p = Path(run_dir) / "surface.npz"
    data = _load_npz(p, ("t", "z", "theta", "u_r", "u_theta", "u_z", "status"))
    _shape(p, data["z"], "z", (None,))
    _shape(p, data["theta"], "theta", (samples["theta"].size,))
    grid = (samples["t"].size, data["z"].size, data["theta"].size)
    for key in ("u_r", "u_theta", "u_z", "status"):
        _shape(p, data[key], key, grid)
    if not np.array_equal(data["t"], samples["t"]):
        raise ReadError(p, "its times are not samples.npz's (edited, or of another run)",
                        "run the scene again")
    return data


def read_field(run_dir: str | Path) -> dict[str, np.ndarray]:
    """``RUN_DIR/final_field.npz``, checked (points, displacement, cells, time)."""
    p = Path(run_dir) / "final_field.npz"
    data = _load_npz(p, ("points", "cells", "cell_types", "u", "time"))
    pts = data["points"]
    if pts.ndim != 2 or pts.shape[1] < 2:
        raise ReadError(p, f"points has shape {pts.shape}, not n x 2 or n x 3 (edited)")
    _shape(p, data["u"], "u", (pts.shape[0], None))  # 2 components, 3 in a 3D tube
    _shape(p, data["time"], "time", ())
    _shape(p, data["cells"], "cells", (None,))
    return data


def read_sweep_table(sweep_dir: str | Path, kind: str) -> dict:
    """``SWEEP_DIR/sweep.json`` of a ``kind`` sweep, checked (kind, parameters, rows)."""
    p = Path(sweep_dir) / "sweep.json"
    meta = read_json_object(p, "run the sweep again to rebuild its table")
    fix = "run the sweep again to rebuild its table"
    if meta.get("kind") != kind:
        raise ReadError(p, f"kind {meta.get('kind')!r} is not {kind!r} (not a sweep table)",
                        fix)
    params, rows = meta.get("parameters"), meta.get("rows")
    if not isinstance(params, list) or not all(isinstance(k, str) for k in params):
        raise ReadError(p, "'parameters' is not a list of scene keys (edited)", fix)
    if not isinstance(rows, list) or not all(isinstance(r, dict) and isinstance(
            r.get("status"), str) and isinstance(r.get("id"), str) for r in rows):
        raise ReadError(p, "'rows' is not a list of rows with an id and a status (edited)",
                        fix)
    missing = next((k for k in params for r in rows if k not in r), None)
    if missing is not None:
        raise ReadError(p, f"'parameters' names {missing!r}, which its rows do not have "
                           "(edited)", fix)
    m = meta.get("map")
    if m is not None and not isinstance(m, dict):
        raise ReadError(p, "'map' is not an object (edited)", fix)
    for key, value in (m or {}).items():
        rule = _MAP_RULES.get(key, lambda v: True)
        if not (rule(value) and (key not in ("x", "y") or value is None or value in params)):
            raise ReadError(p, f"map.{key} = {value!r} is not one a sweep file allows "
                               "(edited)", fix)
    return meta


#: What a sweep file's ``[map]`` may say (``studies.sweep.spec``); ``x`` and ``y`` are also
#: swept keys (``parameters``) or None.
_MAP_RULES = {
    "x": lambda v: v is None or isinstance(v, str),
    "y": lambda v: v is None or isinstance(v, str),
    "xscale": lambda v: v in ("auto", "linear", "log"),
    "yscale": lambda v: v in ("auto", "linear", "log"),
    "semianalytic": lambda v: isinstance(v, bool),
    "k": lambda v: isinstance(v, list) and all(type(k) is int and k >= 1 for k in v),
    "junctions": lambda v: isinstance(v, list) and all(j in ("impact", "smooth") for j in v),
}


def check_run_dir(run_dir: str | Path, need: int = 1) -> None:
    """Every file a command reads from a run directory: summary, scene, samples (``need``),
    and the final field where there is one. Raises :class:`ReadError` for the first fault."""
    d = Path(run_dir)
    if not (d / "samples.npz").exists():
        raise ReadError(d, "has no samples.npz (not a finished run directory)",
                        "give a run directory of `stickslip run`")
    samples = read_samples(d, need)
    summary = read_summary(d)
    scene = read_scene_file(d / "scene.toml")
    if (d / "final_field.npz").exists():
        read_field(d)
    check_agreement(d, summary, scene, samples)


def samples_problem(run_dir: str | Path, need: int = 1) -> str | None:
    """Why the run directory ``run_dir`` cannot be read back (a missing, corrupt, edited or
    too short file: ``check_run_dir``), or None: the one line a command prints."""
    try:
        check_run_dir(run_dir, need)
    except ReadError as err:
        return str(err)
    return None


def check_agreement(run_dir: Path, summary: dict, scene: Any, samples: dict) -> None:
    """The run's files tell of one run: the scene of ``scene.toml`` is the one the summary
    names (and, where recorded, hashes), with the samples' number of contact nodes; else
    :class:`ReadError` naming the first difference (an edited or swapped file)."""
    fix = "put the run's own files back, or run the scene again"
    p = Path(run_dir) / "scene.toml"
    if isinstance(summary.get("scene"), str) and summary["scene"] != scene.name:
        raise ReadError(p, f"is scene {scene.name!r}, but summary.json is of "
                           f"{summary['scene']!r} (swapped)", fix)
    if summary.get("scene_sha256") not in (None, scene_digest(scene)):
        raise ReadError(p, "is not the scene the run used (edited after the run: its hash "
                           "differs from summary.json's scene_sha256)", fix)
    nodes = samples["theta"].size
    if scene.mesh.n_inner != nodes:
        raise ReadError(p, f"has mesh.n_inner = {scene.mesh.n_inner}, but samples.npz has "
                           f"{nodes} contact nodes", fix)
    if summary.get("contact_nodes") not in (None, nodes):
        raise ReadError(Path(run_dir) / "samples.npz", f"has {nodes} contact nodes, but "
                        f"summary.json says {summary['contact_nodes']}", fix)
    if isinstance(summary.get("samples"), int) and summary["samples"] != samples["t"].size:
        raise ReadError(Path(run_dir) / "samples.npz", f"has {samples['t'].size} samples, "
                        f"but summary.json says {summary['samples']}", fix)
