"""Scene values: coercion of TOML values, the one table of ranges (also read by the
``wave``/``flutter`` CLI), and the validated-section base class. Standard library only."""

from __future__ import annotations

import difflib
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, ClassVar

#: Directory of the scenes shipped with the project: ``<repo>/scenes``, or ``$STICKSLIP_SCENES``
#: where the project is installed away from its source tree (the Docker image).
SCENES_DIR = Path(os.environ.get("STICKSLIP_SCENES")
                  or Path(__file__).resolve().parents[2] / "scenes")


class SceneError(ValueError):
    """Invalid scene: the message names the dotted key, the bad value and the fix."""


# ----------------------------------------------------------------------------- type coercion


def _fmt(value: Any) -> str:
    """Render a value for an error message (TOML-ish: strings quoted, bools lower-case)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _to_float(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a number "
            f"(got {type(value).__name__})"
        )
    x = float(value)
    if not math.isfinite(x):
        raise SceneError(f"{key} = {_fmt(value)} is out of range: must be a finite number")
    return x


def _to_int(key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be an integer "
            f"(got {type(value).__name__})"
        )
    return int(value)


def _to_str(key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a string "
            f"(got {type(value).__name__}; quote it in TOML)"
        )
    return value


def _to_bool(key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a boolean true/false "
            f"(got {type(value).__name__})"
        )
    return value


def _to_floats(key: str, value: Any) -> tuple[float, ...]:
    if not isinstance(value, list | tuple):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a list of numbers "
            f"such as [0.0, 90.0] (got {type(value).__name__})"
        )
    return tuple(_to_float(f"{key}[{i}]", v) for i, v in enumerate(value))


_COERCE: dict[str, Callable[[str, Any], Any]] = {
    "float": _to_float,
    "int": _to_int,
    "str": _to_str,
    "bool": _to_bool,
    "floats": _to_floats,
}


def _opt(default: Any, kind: str, needs: str = "") -> Any:
    """Dataclass field with a coercion kind (key of ``_COERCE``) in its metadata, and the
    condition (a key of ``model.NEEDS``, e.g. "3d") that a scene must meet for the key to
    apply: such a key is left out of the resolved scene while it is at its default and the
    scene does not meet it (``model.scene_to_dict``), and refused off its default there."""
    return field(default=default, metadata={"kind": kind, "needs": needs} if needs
                 else {"kind": kind})


def _require(key: str, value: Any, ok: bool, rule: str) -> None:
    """Raise a range error for ``key`` unless ``ok``."""
    if not ok:
        raise SceneError(f"{key} = {_fmt(value)} is out of range: must satisfy {rule}")


def _choice(key: str, value: str, allowed: Sequence[Any]) -> None:
    if value not in allowed:
        opts = ", ".join(_fmt(a) for a in allowed)
        hint = _suggest(value, [str(a) for a in allowed]) if isinstance(value, str) else ""
        raise SceneError(f"{key} = {_fmt(value)} is not allowed: must be one of {opts}{hint}")


def _suggest(word: str, candidates: Sequence[str]) -> str:
    """ "; did you mean 'x'?" for the closest candidate (case-insensitive), else ""."""
    lower = {c.lower(): c for c in candidates}
    close = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return f"; did you mean {lower[close[0]]!r}?" if close else ""


@dataclass(frozen=True)
class Range:
    """An allowed range: ``ok(value)`` and the rule as the user reads it."""

    ok: Callable[[float], bool]
    rule: str


#: The largest strain a scene may impose (the mismatch, ``Geometry``) and start from (the
#: initial bump, ``scene_warnings``): the small-strain model drops the geometric terms
#: (1/2) grad(u)^T grad(u), whose size relative to the strain eps is about eps / 2, i.e. an
#: error of 2.5 % at this bound. The shipped scenes reach 2 % (Figure 4: delta = 0.005 on
#: a wall of 0.25 R), 2.5 times below it.
MAX_STRAIN = 0.05

#: Element layers along a 3D tube, at most (``mesh.n_axial``, or those of
#: ``geometry.length``): beyond it the mesh's cell count leaves 32-bit indices (dolfinx's).
MAX_AXIAL_LAYERS = 10_000_000

#: The physical ranges, in one place for the scenes and the reduced-model CLI (``wave``,
#: ``flutter``): key -> range. Keys are dotted scene keys.
RANGES: dict[str, Range] = {
    "material.E": Range(lambda x: 1 <= x <= 1e13,
                        "E >= 1 and E <= 1e13 (Pa; a soft gel is about 1e2, diamond 1.2e12: "
                        "outside, the lumped mass E / wave_speed^2 or the stiffness under- or "
                        "overflows the eigensolvers)"),
    "material.wave_speed": Range(lambda x: x > 0, "wave_speed > 0 (m/s)"),
    "material.rho": Range(lambda x: x > 0, "rho > 0 (kg/m^3)"),
    "material.nu": Range(
        lambda x: 0 <= x < 0.5,
        "0 <= nu < 0.5 (incompressible nu = 0.5 is not supported by the displacement "
        "formulation)",
    ),
    "geometry.R": Range(lambda x: x > 0, "R > 0 (m)"),
    "geometry.xi": Range(lambda x: x > 1, "xi > 1 (outer/inner radius ratio)"),
    "geometry.delta": Range(
        lambda x: 0 < x <= MAX_STRAIN,
        f"delta > 0 and delta <= {MAX_STRAIN:g} (mismatch d/R; with delta = 0 the tube is not "
        "pressed on the cylinder: no contact pressure, no friction, nothing to simulate; d/R "
        f"is the hoop strain the cylinder imposes, and the small-strain model allows at most "
        f"{MAX_STRAIN:.0%}: lower delta, or d below {MAX_STRAIN:g} R)",
    ),
    "geometry.d": Range(lambda x: x > 0, "d > 0 (m; the cylinder must press the tube)"),
    "loading.omega": Range(lambda x: x > 0, "omega > 0 (rad/s)"),
    "loading.f": Range(lambda x: 0 <= x <= 1e3,
                       "0 <= f <= 1e3 (Coulomb friction coefficient: real contacts have f "
                       "below about 2; near 1e308 the reduced model's matrices overflow)"),
    "initial.mode": Range(lambda x: x >= 1, "mode >= 1"),
}

#: Allowed rim-speed ratio R*omega/wave_speed: outside it the numbers of the model
#: (gamma**2 in eqs. [2]-[3], steps per turn) leave double precision or make no sense.
SPEED_RATIO = (1e-12, 1e6)


def check_range(key: str, value: Any, label: str | None = None) -> None:
    """Raise :class:`SceneError` unless ``value`` is in ``RANGES[key]``; names ``label``."""
    r = RANGES[key]
    _require(label or key, value, r.ok(value), r.rule)


def check_speed_ratio(R: float, omega: float, wave_speed: float, label: str) -> None:
    """Raise :class:`SceneError` unless R*omega/wave_speed is within :data:`SPEED_RATIO`."""
    lo, hi = SPEED_RATIO
    with_ratio = R * omega / wave_speed if wave_speed > 0 else math.inf
    if not (lo <= with_ratio <= hi):
        raise SceneError(
            f"{label}: the rim-speed ratio R*omega/wave_speed = {with_ratio:.3g} is out of "
            f"range: must satisfy {lo:g} <= R*omega/wave_speed <= {hi:g} (check "
            "loading.omega and material.wave_speed)"
        )


class _Section:
    """Mixin: coerce field types from metadata, then run the section's range checks."""

    SECTION: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            kind = f.metadata.get("kind")
            if kind is None:
                continue
            key = f"{self.SECTION}.{f.name}" if self.SECTION else f.name
            object.__setattr__(self, f.name, _COERCE[kind](key, getattr(self, f.name)))
        self._check()

    def _key(self, name: str) -> str:
        return f"{self.SECTION}.{name}"

    def _check(self) -> None:  # pragma: no cover - overridden
        pass


