"""Scene files: load a TOML scene (with overrides), write the resolved one; the shipped scenes."""

from __future__ import annotations

import math
import tomllib
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene.model import (
    _EXCLUSIVE,
    _TOP_SCALARS,
    Scene,
    apply_overrides,
    scene_from_dict,
    scene_to_dict,
)
from stickslip.solver.scene.sections import _SECTIONS
from stickslip.solver.scene.values import (
    SCENES_DIR,
    SceneError,
)

# ----------------------------------------------------------------------------- files


def list_scenes() -> list[Path]:
    """The ``*.toml`` scenes shipped in :data:`SCENES_DIR`, sorted."""
    return sorted(SCENES_DIR.glob("*.toml"))


def _resolve(path: str | Path) -> Path:
    p = Path(path)
    if p.is_dir():
        raise SceneError(f"scene file {str(path)!r} is a directory: give a scene .toml file "
                         "(e.g. scenes/smoke.toml)")
    if p.exists():
        return p
    if p.parent == Path(".") and (SCENES_DIR / f"{p.stem}.toml").is_file():
        return SCENES_DIR / f"{p.stem}.toml"
    shipped = ", ".join(s.stem for s in list_scenes())
    raise SceneError(f"scene file {str(path)!r} not found (shipped scenes: {shipped})")


def load_scene(path: str | Path, overrides: Sequence[str] = ()) -> Scene:
    """Load and validate a scene file, applying ``"section.key=value"`` overrides.

    ``path`` may also be the bare name of a shipped scene (``"figure3_n36"``).
    A missing ``name`` defaults to the file stem.
    """
    p = _resolve(path)
    data = _with_base(_read_toml(p), p, (p.resolve(),))
    data.setdefault("name", p.stem)
    data = apply_overrides(data, overrides)
    try:
        return scene_from_dict(data)
    except SceneError as exc:
        where = f"{p} with --set {' '.join(overrides)}" if overrides else str(p)
        raise SceneError(f"{where}: {exc}") from exc


def _read_toml(p: Path) -> dict:
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except UnicodeDecodeError as exc:
        raise SceneError(f"{p}: not a text TOML file (byte {exc.start} is not UTF-8); "
                         "give a scene .toml file") from exc
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{p}: invalid TOML: {exc}") from exc
    except OSError as exc:
        raise SceneError(f"{p}: cannot read the scene file ({exc.strerror}); check the "
                         "path and its permissions") from exc


def _with_base(data: dict, p: Path, chain: tuple[Path, ...]) -> dict:
    """``data`` on top of its ``base = "..."`` scene (as in a sweep file: a path relative to
    ``p``'s folder or the current one, or a shipped scene name), key by key; the base's
    ``name`` and ``description`` are its own and are not inherited. ``chain``: the files
    already on the way (a base that comes back to one of them is refused)."""
    if "base" not in data:
        return data
    base = data.pop("base")
    if not isinstance(base, str) or not base:
        raise SceneError(f"{p}: base = {base!r}: give a scene file or a shipped scene name")
    candidates = [c for c in (p.parent / base, Path(base)) if c.is_file()]
    shipped = SCENES_DIR / f"{Path(base).stem}.toml"
    if not candidates and Path(base).parent == Path(".") and shipped.is_file():
        candidates = [shipped]
    if not candidates:
        raise SceneError(f"{p}: base = {base!r} not found (relative to the scene file, the "
                         "current directory, or a shipped scene name)")
    bp = candidates[0].resolve()
    if bp in chain:
        raise SceneError(f"{p}: base = {base!r} comes back to {bp} (a cycle of bases)")
    merged = {k: v for k, v in _with_base(_read_toml(bp), bp, (*chain, bp)).items()
              if k not in _TOP_SCALARS}
    for key, value in data.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            section = dict(merged[key])
            for sec, a, b in _EXCLUSIVE:  # the file's rho replaces the base's wave_speed
                if sec == key and (a in value or b in value):
                    section.pop(a, None)
                    section.pop(b, None)
            merged[key] = {**section, **value}
        else:
            merged[key] = value
    return merged


def _toml_str(s: str) -> str:
    out = ['"']
    for ch in s:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif ch == "\r":
            out.append("\\r")
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SceneError(f"cannot write non-finite float {v!r}")
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise SceneError(f"cannot write value {v!r} of type {type(v).__name__} to TOML")


def dumps_toml(scene: Scene) -> str:
    """Serialise ``scene`` (fully resolved) as TOML text."""
    d = scene_to_dict(scene)
    lines = ["# stickslip scene (resolved: all defaults written out)"]
    lines += [f"{k} = {_toml_value(d[k])}" for k in _TOP_SCALARS]
    for sec in (s for s in _SECTIONS if s in d):  # a section the rule left empty: none
        lines += ["", f"[{sec}]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in d[sec].items()]
    return "\n".join(lines) + "\n"


def write_scene(scene: Scene, path: str | Path) -> Path:
    """Atomically write ``scene`` as TOML to ``path`` (temp file + os.replace)."""
    return atomic_write_text(path, dumps_toml(scene))


#: The sections that fix the physical problem and its mesh, on which a run's wave depends;
#: ``time``, ``initial`` and ``output`` say how it is computed, started and recorded.
PHYSICS_SECTIONS = ("material", "geometry", "loading", "mesh", "boundary", "damping",
                    "friction")


def scene_digest(scene: Scene) -> str:
    """SHA-256 of the resolved scene's TOML (:func:`dumps_toml`): a run records it, so an
    edited or swapped ``scene.toml`` is told from the one the run used."""
    import hashlib

    return hashlib.sha256(dumps_toml(scene).encode()).hexdigest()


def scene_difference(a: Scene, b: Scene, sections: Sequence[str] = PHYSICS_SECTIONS
                     ) -> str | None:
    """The first ``section.key`` in ``sections`` where ``a`` and ``b`` differ, as
    ``"section.key = A, not B"``; None if they agree there. Every key is compared, those
    that ``scene_to_dict`` leaves out at their default too."""
    for sec in sections:
        sa, sb = getattr(a, sec), getattr(b, sec)
        for f in fields(sa):
            va, vb = (list(v) if isinstance(v, tuple) else v
                      for v in (getattr(sa, f.name), getattr(sb, f.name)))
            if va != vb:
                return f"{sec}.{f.name} = {va!r}, not {vb!r}"
    return None
