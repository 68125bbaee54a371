"""``Scene``: the whole validated scene, its dict form and ``--set key=value`` overrides."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import Field, dataclass, field, fields, replace
from typing import Any

from stickslip.solver.scene.sections import (
    _SECTIONS,
    Boundary,
    Damping,
    Friction,
    Geometry,
    Initial,
    Loading,
    Material,
    Mesh,
    Output,
    Time,
)
from stickslip.solver.scene.values import (
    MAX_AXIAL_LAYERS,
    MAX_STRAIN,
    SceneError,
    _fmt,
    _opt,
    _require,
    _Section,
    _suggest,
    _to_float,
    check_range,
    check_speed_ratio,
)

_TOP_SCALARS = ("name", "description")
#: Input-only alternatives: (section, canonical key, alternative key).
_EXCLUSIVE = (("material", "wave_speed", "rho"), ("geometry", "delta", "d"))
#: A safe file name: it starts with a letter, digit or '_' (never '.', '..', '-x' or hidden).
_NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]{0,127}")


@dataclass(frozen=True)
class Scene(_Section):
    """A complete, validated simulation description."""

    name: str = _opt("scene", "str")
    """Short identifier (letters, digits, '_', '-', '.'); used for output names."""
    description: str = _opt("", "str")
    material: Material = field(default_factory=Material)
    geometry: Geometry = field(default_factory=Geometry)
    loading: Loading = field(default_factory=Loading)
    mesh: Mesh = field(default_factory=Mesh)
    boundary: Boundary = field(default_factory=Boundary)
    time: Time = field(default_factory=Time)
    initial: Initial = field(default_factory=Initial)
    output: Output = field(default_factory=Output)
    damping: Damping = field(default_factory=Damping)
    friction: Friction = field(default_factory=Friction)

    def _check(self) -> None:
        if not _NAME_RE.fullmatch(self.name):
            raise SceneError(
                f"name = {_fmt(self.name)} is not allowed: it names the run directory, so it "
                "must be 1 to 128 letters, digits, '_', '-' or '.', starting with a letter, "
                "digit or '_' (not '.' or '..')"
            )
        g, lo = self.geometry, self.loading
        check_speed_ratio(g.R, lo.omega, self.material.wave_speed,
                          f"loading.omega = {_fmt(lo.omega)}, material.wave_speed = "
                          f"{_fmt(self.material.wave_speed)}, geometry.R = {_fmt(g.R)}")
        for sec, cls in _SECTIONS.items():
            if not isinstance(getattr(self, sec), cls):
                raise SceneError(f"{sec} must be a {cls.__name__} (got {getattr(self, sec)!r})")
        if self.friction.enabled and self.time.beta1 != 0.0:
            raise SceneError(
                f"friction.regularization = {self.friction.regularization!r} needs the explicit "
                f"scheme (time.beta1 = 0; got {self.time.beta1}): the law is built into its "
                "forward-increment contact projection")
        if self.friction.filtered and self.time.beta1 != 0.0:
            raise SceneError(
                f"friction.filter = {self.friction.filter!r} needs the explicit scheme "
                f"(time.beta1 = 0; got {self.time.beta1}): the filtered bound couples "
                "neighbouring nodes, which the implicit active set does not model; use "
                'time.beta1 = 0 or friction.filter = "nodal"')
        self._check_needs()
        if self.mesh.file:  # a user's cross-section or tube: read and checked (meshes.user_*)
            facts = self.mesh.file_facts(self.geometry.R)
            if self.mesh.dim == 3:
                self._check_tube_file(facts)
        half = self.mesh.n_inner // 2
        why = f"mesh.n_inner // 2 = {half} (at least 2 contact nodes per wavelength)"
        if self.initial.perturbation == "mode":
            _require(
                "initial.mode", self.initial.mode, self.initial.mode <= half, f"1 <= mode <= {why}"
            )
        if self.initial.perturbation == "random":
            _require(
                "initial.n_modes",
                self.initial.n_modes,
                self.initial.n_modes <= half,
                f"1 <= n_modes <= {why}",
            )

    def _check_tube_file(self, facts) -> None:  # noqa: ANN001 - meshes.user_tube.TubeFileFacts
        """A user's 3D tube against the scene's keys: its length, its layers and the group
        that ``boundary.ends`` holds (one line each, naming the file's value)."""
        file, length = _fmt(self.mesh.file), facts.length
        if abs(self.geometry.length - length) > 1e-6 * length:
            raise SceneError(f"geometry.length = {_fmt(self.geometry.length)}: the tube of "
                             f"mesh.file = {file} is {length:.9g} m long (its contact surface "
                             f"along z): set geometry.length = {length:.9g}")
        if self.mesh.n_axial not in (0, facts.n_axial):
            raise SceneError(f"mesh.n_axial = {self.mesh.n_axial}: the contact surface of "
                             f"mesh.file = {file} has {facts.n_axial} layers: set "
                             f"mesh.n_axial = 0 (the file's) or {facts.n_axial}")
        if self.boundary.ends != "free" and not facts.ends_tag:
            raise SceneError(f"boundary.ends = {_fmt(self.boundary.ends)} holds the group "
                             f"mesh.ends_group = {_fmt(self.mesh.ends_group)}, which mesh.file "
                             f"= {file} does not have: add Physical Surface"
                             f"(\"{self.mesh.ends_group}\") = {{...}} on the ends, or set "
                             "boundary.ends = \"free\"")

    def _check_needs(self) -> None:
        """The 3D tube's length, and no key off its default where it does not apply
        (``NEEDS``): one line that names the key, its value and the fix."""
        if self.mesh.dim == 3:
            if not self.mesh.file:  # a user's tube: its file's length (``_check_tube_file``)
                _require("geometry.length", self.geometry.length, self.geometry.length > 0,
                         "length > 0 (m) with mesh.dim = 3 (the tube's length along z: give "
                         "geometry.length)")
                g = self.geometry
                lo, hi = LENGTH_RATIO
                _require("geometry.length", g.length, lo <= g.length / g.R <= hi,
                         f"{lo:g} R <= length <= {hi:g} R with mesh.dim = 3 (R = {g.R:g} m: "
                         f"{lo * g.R:.4g} to {hi * g.R:.4g} m; a brake pad's L/R is about 0.1 "
                         "to 2, and far outside the range the tube's cells cannot be meshed)")
                longest = MAX_AXIAL_LAYERS * 2.0 * math.pi * g.R / self.mesh.n_inner
                _require("geometry.length", g.length,
                         self.mesh.n_axial or tube_axial_layers(self) <= MAX_AXIAL_LAYERS,
                         f"length <= {longest:.4g} m with mesh.n_axial = 0 (cells as long as "
                         f"they are wide: at most {MAX_AXIAL_LAYERS:.0e} layers along z); "
                         "shorten it or set mesh.n_axial")
            if self.boundary.ends == "clamped" and tube_axial_layers(self) < 2:
                _require("mesh.n_axial", self.mesh.n_axial, False,
                         f"n_axial >= 2 with clamped ends, here {tube_axial_layers(self):g} "
                         "layers (the ends hold their rings: a ring of contact nodes must lie "
                         "between them)")
        for sec in _SECTIONS:
            obj = getattr(self, sec)
            for f in fields(obj):
                need = f.metadata.get("needs")
                if need and not NEEDS[need][0](self) and getattr(obj, f.name) != f.default:
                    _, where, fix = NEEDS[need]
                    raise SceneError(f"{sec}.{f.name} = {_fmt(getattr(obj, f.name))} only "
                                     f"applies to {where}: {fix} or drop {sec}.{f.name}")

    def with_overrides(self, *overrides: str) -> Scene:
        """Return a copy with ``"section.key=value"`` overrides applied (and re-validated)."""
        return scene_from_dict(apply_overrides(scene_to_dict(self), overrides))

    def replace(self, **changes: Any) -> Scene:
        """``dataclasses.replace`` shortcut (validated)."""
        return replace(self, **changes)


#: The conditions of the keys that apply to some scenes only (``values._opt(needs=...)``):
#: name -> (does ``scene`` meet it, the words that name it in an error, the fix).
NEEDS: dict[str, tuple[Callable[[Scene], bool], str, str]] = {
    "3d": (lambda scene: scene.mesh.dim == 3, "mesh.dim = 3 (the finite tube)",
           "set mesh.dim = 3"),
}

#: The 3D tube's length in units of R that a generated tube may have (``_check_needs``).
LENGTH_RATIO = (1e-3, 1e3)

#: Why a 3D scene cannot run the transient (``require_plane_strain``).
PLANE_STRAIN_ONLY = ("mesh.dim = 3: travel and rpo are plane strain only for now; `stickslip "
                     "run`, `sweep`, `continue` and `attractors` run the 3D tube's transient, "
                     "`stickslip flutter-fe` its CEA")


def require_plane_strain(scene: Scene) -> None:
    """Raise :class:`SceneError` (``PLANE_STRAIN_ONLY``, one line) unless ``scene`` is a
    plane-strain scene: the commands that run the transient call it where they load one."""
    if scene.mesh.dim != 2:
        raise SceneError(PLANE_STRAIN_ONLY)


#: A 3D tube above this many dofs solves its steady state iteratively
#: (``forms.steady.static_sliding``): the LU's fill-in grows faster than the dofs.
STEADY_DIRECT_DOFS = 150_000


def axial_layers(scene: Scene, length: float) -> float:
    """Element layers along a finite tube of ``length`` (m) whose cells are as long as they
    are wide on the contact surface, round(L N / (2 pi R)), at least 1 (a float: huge or
    infinite lengths are compared before they are rounded)."""
    layers = max(1.0, length * scene.mesh.n_inner / (2.0 * math.pi * scene.geometry.R))
    return float(round(layers)) if math.isfinite(layers) else layers


def tube_axial_layers(scene: Scene) -> float:
    """Element layers along the tube of a 3D scene (``mesh.dim`` = 3): ``mesh.n_axial``, or
    where it is 0 the user's file's, else the square cells' ``axial_layers`` of
    ``geometry.length``."""
    n_axial = scene.mesh.n_axial
    if not n_axial and scene.mesh.file:  # a user's tube: its own (meshes.user_tube)
        return float(scene.mesh.file_facts(scene.geometry.R).n_axial)
    return float(n_axial) if n_axial else axial_layers(scene, scene.geometry.length)


def _written(scene: Scene, obj: _Section, f: Field) -> bool:
    """The compatibility rule: a key is written unless it applies to some scenes only
    (``NEEDS``), ``scene`` is not one of them, and it is at its default. Adding such a key
    leaves every other scene's resolved text, digest and hashes as they were."""
    need = f.metadata.get("needs")
    return not need or NEEDS[need][0](scene) or getattr(obj, f.name) != f.default


def scene_warnings(scene: Scene) -> list[str]:
    """Legal but doubtful choices of ``scene``, one line each with the fix: said before a
    run starts and kept in its summary (``warnings``), so that a sweep's table shows them.

    The start's strain is only warned of, not refused: a start far beyond the small-strain
    model is still a legitimate way to make a run blow up on purpose (a divergence test)."""
    out = []
    ini, n, g = scene.initial, scene.mesh.n_inner, scene.geometry
    if ini.perturbation == "mode" and n / ini.mode < 8:
        out.append(
            f"initial.mode = {ini.mode} has only {n / ini.mode:.1f} contact nodes per "
            f"wavelength on mesh.n_inner = {n}; the wave will be poorly resolved "
            f"(use mesh.n_inner >= {8 * ini.mode})"
        )
    start = g.d * (1.0 + ini.amplitude) / g.strained_length
    if ini.perturbation != "none" and start > MAX_STRAIN:
        most = MAX_STRAIN * g.strained_length / g.d - 1.0
        out.append(
            f"initial.amplitude = {ini.amplitude:g} starts the contact circle up to "
            f"d (1 + amplitude) = {g.d * (1.0 + ini.amplitude):.3g} m out, a strain of about "
            f"{start:.3g} over min(R, (xi - 1) R) = {g.strained_length:.3g} m, above the "
            f"{MAX_STRAIN:.0%} that the small-strain model allows: the run does not describe "
            f"this tube; use initial.amplitude <= {most:.3g}"
        )
    out_ = scene.output
    if out_.sample_interval > scene.time.end_time:
        out.append(
            f"output.sample_interval = {out_.sample_interval} s is longer than time.end_time "
            f"= {scene.time.end_time} s: at most one sample, nothing to analyse (use "
            "output.sample_interval <= time.end_time / 100)"
        )
    return out


# ----------------------------------------------------------------------------- dict <-> Scene


def _unknown(key: str, allowed: Sequence[str], word: str | None = None) -> SceneError:
    """Error for an unknown ``key``; suggests the closest of ``allowed`` to ``word``."""
    leaf = key.rsplit(".", 1)[-1] if word is None else word
    return SceneError(
        f"unknown key {key!r} (allowed: {', '.join(allowed)}){_suggest(leaf, allowed)}"
    )


def _allowed_keys(section: str) -> list[str]:
    keys = [f.name for f in fields(_SECTIONS[section])]
    for sec, canon, alt in _EXCLUSIVE:
        if sec == section:
            keys.insert(keys.index(canon) + 1, alt)
    return keys


def scene_from_dict(data: Mapping[str, Any]) -> Scene:
    """Validate a nested dict (as parsed from TOML) and build a :class:`Scene`."""
    if not isinstance(data, Mapping):
        raise SceneError(f"a scene must be a table/dict (got {type(data).__name__})")
    top_allowed = [*_TOP_SCALARS, *_SECTIONS]
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key not in top_allowed:
            raise _unknown(str(key), top_allowed)
        if key in _TOP_SCALARS:
            kwargs[key] = value
            continue
        if not isinstance(value, Mapping):
            raise SceneError(
                f"{key} = {_fmt(value)} has the wrong type: must be a table "
                f"([{key}] in TOML, keys: {', '.join(_allowed_keys(key))})"
            )
        allowed = _allowed_keys(key)
        sub = dict(value)
        for k in sub:
            if k not in allowed:
                raise _unknown(f"{key}.{k}", allowed)
        kwargs[key] = _build_section(key, sub)
    return Scene(**kwargs)


def _build_section(section: str, sub: dict[str, Any]) -> _Section:
    if section == "material" and "rho" in sub:
        _exactly_one(section, sub, "wave_speed", "rho", "wave_speed = sqrt(E/rho)")
        rho = _to_float("material.rho", sub.pop("rho"))
        check_range("material.rho", rho)
        E = _to_float("material.E", sub.get("E", Material.E))
        check_range("material.E", E)
        sub["wave_speed"] = math.sqrt(E / rho)
    if section == "geometry" and "d" in sub:
        _exactly_one(section, sub, "delta", "d", "delta = d/R")
        d = _to_float("geometry.d", sub.pop("d"))
        check_range("geometry.d", d)
        R = _to_float("geometry.R", sub.get("R", Geometry.R))
        check_range("geometry.R", R)
        sub["delta"] = d / R
    return _SECTIONS[section](**sub)


def _exactly_one(section: str, sub: Mapping[str, Any], a: str, b: str, rel: str) -> None:
    if a in sub and b in sub:
        raise SceneError(
            f"{section}: give exactly one of '{section}.{a}' or '{section}.{b}' "
            f"(got both: {a} = {_fmt(sub[a])}, {b} = {_fmt(sub[b])}; {rel})"
        )


def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """Resolved nested dict of ``scene`` (defaults filled in; lists for tuples), less the keys
    that the compatibility rule (``_written``) leaves out and the sections left empty by it.
    It is what a run writes (``files.dumps_toml``) and what every scene hash reads
    (``files.scene_digest``, ``studies.rundir.checkpoint.scene_fingerprint``, the sweep's,
    batch's and census's keys), so a plane-strain scene has no 3D key in any of them."""
    out: dict[str, Any] = {"name": scene.name, "description": scene.description}
    for sec in _SECTIONS:
        obj = getattr(scene, sec)
        table = {f.name: list(v) if isinstance(v := getattr(obj, f.name), tuple) else v
                 for f in fields(obj) if _written(scene, obj, f)}
        if table:
            out[sec] = table
    return out


# ----------------------------------------------------------------------------- overrides


def parse_override(text: str) -> tuple[tuple[str, ...], Any]:
    """Split ``"section.key=value"`` into a key path and a TOML-parsed value.

    The value is parsed as a TOML value (``132``, ``0.7``, ``"quadrilateral"``,
    ``[0.0, 90.0]``, ``true``); anything that is not valid TOML is taken as a bare string.
    """
    if "=" not in text:
        raise SceneError(
            f"override {text!r} must look like 'section.key=value' (e.g. mesh.n_inner=132)"
        )
    raw_key, raw_value = (s.strip() for s in text.split("=", 1))
    path = tuple(p.strip() for p in raw_key.split("."))
    if len(path) == 1 and path[0] in _TOP_SCALARS:
        pass
    elif len(path) == 2 and path[0] in _SECTIONS:
        allowed = _allowed_keys(path[0])
        if path[1] not in allowed:
            raise _unknown(raw_key, allowed)
    elif path[0] in _SECTIONS:
        raise SceneError(
            f"override key {raw_key!r} must name one key of [{path[0]}] "
            f"(allowed: {', '.join(f'{path[0]}.{k}' for k in _allowed_keys(path[0]))})"
        )
    elif path[0] in _TOP_SCALARS:
        raise SceneError(f"override key {raw_key!r}: {path[0]!r} is a string, not a table")
    else:
        raise _unknown(raw_key, [*_TOP_SCALARS, *_SECTIONS], word=path[0])
    try:
        value = tomllib.loads(f"v = {raw_value}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw_value
    return path, value


def apply_overrides(data: Mapping[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """Return a copy of the nested ``data`` with ``"section.key=value"`` overrides applied.

    Setting one of a mutually exclusive pair (``wave_speed``/``rho``, ``delta``/``d``)
    removes the other from the copy.
    """
    if isinstance(overrides, str):
        overrides = (overrides,)
    out: dict[str, Any] = {k: dict(v) if isinstance(v, Mapping) else v for k, v in data.items()}
    for text in overrides:
        path, value = parse_override(text)
        if len(path) == 1:
            out[path[0]] = value
            continue
        sec, key = path
        table = out.setdefault(sec, {})
        if not isinstance(table, dict):
            raise SceneError(f"{sec} must be a table (got {_fmt(table)})")
        for s, a, b in _EXCLUSIVE:
            if s == sec and key in (a, b):
                table.pop(b if key == a else a, None)
        table[key] = value
    return out


