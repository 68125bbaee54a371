"""Tests of solver.scene: schema, validation messages, overrides, TOML round trip."""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from pathlib import Path

import pytest

from stickslip.solver.scene import (
    SCENES_DIR,
    Geometry,
    Material,
    Mesh,
    Scene,
    SceneError,
    dumps_toml,
    list_scenes,
    load_scene,
    scene_from_dict,
    scene_to_dict,
    write_scene,
)

SHIPPED = {
    # name: (omega, delta, f, n_inner, n_radial, end_time)
    "figure1": (40.0, 0.001, 0.7, 132, 0, 0.3),
    "figure2_n36": (1.0, 0.0004, 0.3, 36, 0, 0.3),
    "figure2_n132": (1.0, 0.0004, 0.3, 132, 0, 0.3),
    "figure3_n36": (50.0, 0.0004, 0.7, 36, 0, 0.3),
    "figure3_n132": (50.0, 0.0004, 0.7, 132, 0, 0.3),
    "smoke": (50.0, 0.0004, 0.7, 36, 2, 0.02),
}


def write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


# ----------------------------------------------------------------------------- shipped scenes


def test_shipped_scene_set() -> None:
    """The paper's Figure 1-3 scenes and the smoke scene are shipped (Figure 4-6 scenes are
    checked in tests/test_verification.py); every shipped scene loads and is described."""
    stems = {p.stem for p in list_scenes()}
    assert set(SHIPPED) <= stems
    for path in list_scenes():
        assert load_scene(path).description, path


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_shipped_scene_loads(name: str) -> None:
    path = SCENES_DIR / f"{name}.toml"
    scene = load_scene(path)
    omega, delta, f, n_inner, n_radial, end_time = SHIPPED[name]
    assert scene.name == name
    assert scene.description
    assert scene.loading.omega == omega
    assert scene.loading.f == f
    assert scene.geometry.delta == delta
    assert scene.mesh.n_inner == n_inner
    assert scene.mesh.n_radial == n_radial
    assert scene.time.end_time == end_time
    # common paper settings
    assert scene.material == Material(E=1.0e9, wave_speed=1000.0, nu=0.3)
    assert scene.geometry.R == 1.0 and scene.geometry.xi == 1.25
    assert (scene.initial.perturbation, scene.initial.mode, scene.initial.amplitude) == (
        "mode",
        4,
        0.1,
    )
    assert (scene.time.beta1, scene.time.beta2, scene.time.dt, scene.time.dt_fraction) == (
        0.0,
        0.6,
        0.0,
        0.9,
    )
    # loading and initial must be stated explicitly, not left to defaults
    raw = tomllib.loads(path.read_text())
    assert {"omega", "f"} <= raw["loading"].keys()
    assert {"perturbation", "mode", "amplitude"} <= raw["initial"].keys()
    # bare shipped name resolves to the same scene
    assert load_scene(name) == scene


def test_defaults() -> None:
    s = scene_from_dict({})
    assert s == Scene()
    assert s.mesh == Mesh(n_inner=132, n_radial=0, cell="triangle", degree=1)
    assert s.output.probes_deg == (0.0,)
    assert s.time.end_time == 0.3 and s.time.max_steps == 0
    assert s.initial.n_modes == 16


def test_name_defaults_to_file_stem(tmp_path: Path) -> None:
    assert load_scene(write(tmp_path, "[loading]\nf = 0.2\n", "my_case.toml")).name == "my_case"


def test_frozen_and_hashable() -> None:
    s = load_scene("smoke")
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.mesh.n_inner = 10  # type: ignore[misc]
    assert hash(s) == hash(load_scene("smoke"))


# ----------------------------------------------------------------------------- unknown keys


@pytest.mark.parametrize(
    ("data", "key", "suggestion"),
    [
        ({"nmae": "x"}, "nmae", "name"),
        ({"meshh": {}}, "meshh", "mesh"),
        ({"mesh": {"n_inne": 10}}, "mesh.n_inne", "n_inner"),
        ({"material": {"Nu": 0.3}}, "material.Nu", "nu"),
        ({"geometry": {"delt": 0.1}}, "geometry.delt", "delta"),
        ({"loading": {"omga": 1.0}}, "loading.omga", "omega"),
        ({"time": {"end_tim": 1.0}}, "time.end_tim", "end_time"),
        ({"initial": {"amplitud": 1.0}}, "initial.amplitud", "amplitude"),
        ({"output": {"probe_deg": [1.0]}}, "output.probe_deg", "probes_deg"),
    ],
)
def test_unknown_key_rejected_with_suggestion(data: dict, key: str, suggestion: str) -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict(data)
    msg = str(exc.value)
    assert f"unknown key {key!r}" in msg
    assert f"did you mean {suggestion!r}?" in msg
    assert "allowed: " in msg


def test_unknown_key_message_lists_allowed_keys() -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict({"mesh": {"n_inne": 10}})
    assert str(exc.value) == (
        "unknown key 'mesh.n_inne' (allowed: dim, n_inner, n_radial, n_axial, cell, degree, "
        "file, contact_group, clamped_group, ends_group); "
        "did you mean 'n_inner'?"
    )


def test_unknown_key_in_file_names_file(tmp_path: Path) -> None:
    p = write(tmp_path, "[mesh]\nn_inne = 10\n")
    with pytest.raises(SceneError, match=r"s\.toml: unknown key 'mesh\.n_inne'"):
        load_scene(p)


def test_section_must_be_table() -> None:
    with pytest.raises(SceneError, match=r"^mesh = 3 has the wrong type: must be a table"):
        scene_from_dict({"mesh": 3})


# ----------------------------------------------------------------------------- ranges & types


@pytest.mark.parametrize(
    ("section", "key", "value", "rule"),
    [
        ("material", "nu", 0.5, "0 <= nu < 0.5"),
        ("material", "nu", -0.1, "0 <= nu < 0.5"),
        ("material", "E", 0.0, "E >= 1"),
        ("material", "wave_speed", -1.0, "wave_speed > 0"),
        ("geometry", "xi", 1.0, "xi > 1"),
        ("geometry", "R", 0.0, "R > 0"),
        ("geometry", "delta", -1e-3, "delta > 0"),
        ("geometry", "delta", 0.0, "delta > 0"),  # nothing to simulate
        ("loading", "f", -0.1, "0 <= f <= 1e3"),
        ("loading", "f", 1e308, "0 <= f <= 1e3"),
        ("loading", "omega", 0.0, "omega > 0"),
        ("mesh", "n_inner", 7, "n_inner >= 8"),
        ("mesh", "n_radial", -1, "n_radial >= 0"),
        ("time", "beta2", 0.49, "0.5 <= beta2 <= 1.0"),
        ("time", "beta2", 1.01, "0.5 <= beta2 <= 1.0"),
        ("time", "beta1", 0.51, "0 <= beta1 <= 0.5"),
        ("time", "end_time", 0, "end_time > 0"),
        ("time", "dt", -1e-6, "dt >= 0"),
        ("time", "dt_fraction", 0.0, "0 < dt_fraction <= 1"),
        ("time", "dt_fraction", 1.1, "0 < dt_fraction <= 1"),
        ("time", "max_steps", -1, "max_steps >= 0"),
        ("time", "max_wall_time", -1.0, "max_wall_time >= 0"),
        ("initial", "mode", 0, "mode >= 1"),
        ("initial", "amplitude", -0.1, "amplitude >= 0"),
        ("initial", "seed", -1, "seed >= 0"),
        ("initial", "n_modes", 0, "n_modes >= 1"),
        ("output", "sample_interval", 0.0, "sample_interval > 0"),
        ("output", "field_interval", -1.0, "field_interval > 0"),
    ],
)
def test_range_rejected(section: str, key: str, value: float, rule: str) -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict({section: {key: value}})
    msg = str(exc.value)
    shown = type(getattr(getattr(Scene(), section), key))(value)  # ints shown as floats
    assert msg.startswith(f"{section}.{key} = {shown!r} is out of range: must satisfy ")
    assert rule in msg


def test_nu_message_exact() -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict({"material": {"nu": 0.5}})
    assert str(exc.value) == (
        "material.nu = 0.5 is out of range: must satisfy 0 <= nu < 0.5 "
        "(incompressible nu = 0.5 is not supported by the displacement formulation)"
    )


def test_implicit_scheme_allows_dt_fraction_above_one() -> None:
    """beta1 > 0 (implicit, unconditionally stable for 2 beta1 >= beta2) takes dt_fraction in
    units of the explicit limit, so values > 1 are valid; beta1 = 0 still refuses them."""
    s = scene_from_dict({"time": {"beta1": 0.25, "beta2": 0.5, "dt_fraction": 10.0}})
    assert s.time.dt_fraction == 10.0
    with pytest.raises(SceneError, match=r"implicit scheme, beta1 > 0, allows dt_fraction > 1"):
        scene_from_dict({"time": {"beta1": 0.0, "dt_fraction": 1.5}})
    with pytest.raises(SceneError, match=r"time.dt_fraction = 0.0 is out of range: .*> 0"):
        scene_from_dict({"time": {"beta1": 0.25, "dt_fraction": 0.0}})


def test_range_bounds_inclusive() -> None:
    s = scene_from_dict(
        {
            "material": {"nu": 0.0},
            "loading": {"f": 0.0},
            "mesh": {"n_inner": 8, "n_radial": 0},
            "time": {"beta1": 0.5, "beta2": 1.0, "dt_fraction": 1.0},
            "initial": {"amplitude": 0.0, "perturbation": "none"},
        }
    )
    assert s.mesh.n_inner == 8 and s.time.beta2 == 1.0 and s.loading.f == 0.0
    assert scene_from_dict({"time": {"beta2": 0.5}}).time.beta2 == 0.5


@pytest.mark.parametrize(
    ("section", "key", "value", "allowed"),
    [
        ("mesh", "degree", 3, "must be one of 1, 2"),
        ("mesh", "cell", "hex", "must be one of 'triangle', 'quadrilateral'"),
        ("initial", "perturbation", "modes", "must be one of 'none', 'mode', 'random'"),
    ],
)
def test_choice_rejected(section: str, key: str, value: object, allowed: str) -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict({section: {key: value}})
    msg = str(exc.value)
    assert msg.startswith(f"{section}.{key} = {value!r} is not allowed: {allowed}")


def test_choice_suggestion() -> None:
    with pytest.raises(SceneError, match=r"did you mean 'quadrilateral'\?"):
        scene_from_dict({"mesh": {"cell": "quadrilateal"}})


@pytest.mark.parametrize(
    ("section", "key", "value", "expect"),
    [
        ("mesh", "n_inner", 2.5, "must be an integer (got float)"),
        ("mesh", "n_inner", 132.0, "must be an integer (got float)"),
        ("mesh", "n_inner", True, "must be an integer (got bool)"),
        ("mesh", "degree", "1", "must be an integer (got str)"),
        ("loading", "f", True, "must be a number (got bool)"),
        ("loading", "f", "0.7", "must be a number (got str)"),
        ("mesh", "cell", 3, "must be a string (got int"),
        ("output", "fields", 1, "must be a boolean true/false (got int)"),
        ("output", "probes_deg", 0.0, "must be a list of numbers"),
    ],
)
def test_type_rejected(section: str, key: str, value: object, expect: str) -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict({section: {key: value}})
    msg = str(exc.value)
    assert msg.startswith(f"{section}.{key} = ")
    assert "has the wrong type" in msg and expect in msg


def test_list_element_type_named() -> None:
    with pytest.raises(SceneError, match=r"^output\.probes_deg\[1\] = 'x' has the wrong type"):
        scene_from_dict({"output": {"probes_deg": [0.0, "x"]}})


@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan])
def test_non_finite_rejected(value: float) -> None:
    with pytest.raises(SceneError, match=r"^time\.end_time = .* must be a finite number"):
        scene_from_dict({"time": {"end_time": value}})


def test_floats_accept_ints() -> None:
    s = scene_from_dict({"loading": {"omega": 50, "f": 1}, "output": {"probes_deg": [0, 90]}})
    assert s.loading.omega == 50.0 and isinstance(s.loading.omega, float)
    assert isinstance(s.loading.f, float)
    assert s.output.probes_deg == (0.0, 90.0)
    assert all(isinstance(x, float) for x in s.output.probes_deg)


def test_direct_construction_validated() -> None:
    with pytest.raises(SceneError, match=r"^geometry\.xi = 0\.9 is out of range"):
        Geometry(xi=0.9)
    assert Mesh(n_inner=64).n_inner == 64


def test_mode_must_be_resolvable() -> None:
    with pytest.raises(SceneError, match=r"^initial\.mode = 19 is out of range: .*= 18"):
        scene_from_dict({"mesh": {"n_inner": 36}, "initial": {"mode": 19}})
    assert scene_from_dict({"mesh": {"n_inner": 36}, "initial": {"mode": 18}}).initial.mode == 18
    # irrelevant when the perturbation is not a single mode
    s = scene_from_dict({"mesh": {"n_inner": 36}, "initial": {"mode": 19, "perturbation": "none"}})
    assert s.initial.mode == 19
    with pytest.raises(SceneError, match=r"^initial\.n_modes = 20 is out of range"):
        scene_from_dict(
            {"mesh": {"n_inner": 36}, "initial": {"perturbation": "random", "n_modes": 20}}
        )


@pytest.mark.parametrize("name", ["", "a b", "../x", "x/y"])
def test_bad_name_rejected(name: str) -> None:
    with pytest.raises(SceneError, match=r"^name = .* is not allowed"):
        scene_from_dict({"name": name})


# ----------------------------------------------------------------------------- exactly one of


def test_wave_speed_or_rho() -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict({"material": {"wave_speed": 1000.0, "rho": 1000.0}})
    msg = str(exc.value)
    assert "exactly one of 'material.wave_speed' or 'material.rho'" in msg
    assert "got both" in msg
    s = scene_from_dict({"material": {"E": 2.0e9, "rho": 500.0}})
    assert s.material.wave_speed == pytest.approx(2000.0, rel=1e-15)
    assert s.material.rho == pytest.approx(500.0, rel=1e-15)
    # neither: default wave speed
    assert scene_from_dict({"material": {"E": 4.0e9}}).material.wave_speed == 1000.0
    with pytest.raises(SceneError, match=r"^material\.rho = 0\.0 is out of range"):
        scene_from_dict({"material": {"rho": 0.0}})


def test_delta_or_d() -> None:
    with pytest.raises(SceneError) as exc:
        scene_from_dict({"geometry": {"delta": 0.001, "d": 0.001}})
    assert "exactly one of 'geometry.delta' or 'geometry.d'" in str(exc.value)
    s = scene_from_dict({"geometry": {"R": 2.0, "d": 0.002}})
    assert s.geometry.delta == pytest.approx(0.001, rel=1e-15)
    assert s.geometry.d == pytest.approx(0.002, rel=1e-15)
    with pytest.raises(SceneError, match=r"^geometry\.d = -0\.1 is out of range"):
        scene_from_dict({"geometry": {"d": -0.1}})


def test_derived_properties() -> None:
    s = scene_from_dict(
        {"material": {"E": 2.1e11, "wave_speed": 5000.0}, "geometry": {"R": 0.2, "delta": 0.005}}
    )
    assert s.material.rho == 2.1e11 / 5000.0**2
    assert s.geometry.d == 0.005 * 0.2
    assert s.geometry.R_outer == 1.25 * 0.2
    assert Scene().material.rho == 1000.0
    assert Material.from_rho(E=1.0e9, rho=1000.0).wave_speed == 1000.0


# ----------------------------------------------------------------------------- overrides


def test_overrides_parse_and_apply() -> None:
    s = load_scene(
        SCENES_DIR / "figure3_n36.toml",
        [
            "mesh.n_inner=264",
            "loading.f=0.5",
            "output.probes_deg=[0.0, 90.0]",
            'mesh.cell="quadrilateral"',
            "output.fields=true",
            "time.end_time=1e-3",
            "name=variant",
        ],
    )
    assert s.mesh.n_inner == 264 and isinstance(s.mesh.n_inner, int)
    assert s.loading.f == 0.5
    assert s.output.probes_deg == (0.0, 90.0)
    assert s.mesh.cell == "quadrilateral"
    assert s.output.fields is True
    assert s.time.end_time == 1e-3
    assert s.name == "variant"
    # untouched values kept
    assert s.loading.omega == 50.0 and s.geometry.delta == 0.0004


def test_override_bare_string_and_spaces() -> None:
    s = load_scene("smoke", ["mesh.cell=quadrilateral", " loading.f = 0.25 "])
    assert s.mesh.cell == "quadrilateral"
    assert s.loading.f == 0.25


def test_override_later_wins() -> None:
    assert load_scene("smoke", ["loading.f=0.1", "loading.f=0.2"]).loading.f == 0.2


@pytest.mark.parametrize(
    ("override", "pattern"),
    [
        ("mesh.n_inne=10", r"unknown key 'mesh\.n_inne' .*did you mean 'n_inner'\?"),
        ("meshh.n_inner=10", r"unknown key 'meshh\.n_inner' .*did you mean 'mesh'\?"),
        ("mesh=10", r"override key 'mesh' must name one key of \[mesh\]"),
        ("mesh.n_inner.x=10", r"must name one key of \[mesh\]"),
        ("name.x=1", r"'name' is a string, not a table"),
        ("mesh.n_inner", r"must look like 'section\.key=value'"),
        ("mesh.n_inner=2.5", r"mesh\.n_inner = 2\.5 has the wrong type"),
        ("mesh.n_inner=7", r"mesh\.n_inner = 7 is out of range"),
        ("mesh.cell=hex", r"mesh\.cell = 'hex' is not allowed"),
    ],
)
def test_bad_override_rejected(override: str, pattern: str) -> None:
    with pytest.raises(SceneError, match=pattern):
        load_scene("smoke", [override])


def test_override_switches_exclusive_pair() -> None:
    s = load_scene("smoke", ["material.rho=4000.0"])
    assert s.material.wave_speed == pytest.approx(500.0, rel=1e-15)
    s = load_scene("smoke", ["geometry.d=0.002"])
    assert s.geometry.delta == pytest.approx(0.002, rel=1e-15)
    # and back again within one list of overrides
    s = load_scene("smoke", ["geometry.d=0.002", "geometry.delta=0.003"])
    assert s.geometry.delta == 0.003


def test_with_overrides() -> None:
    base = load_scene("smoke")
    s = base.with_overrides("mesh.n_inner=264", "loading.f=0.5")
    assert (s.mesh.n_inner, s.loading.f) == (264, 0.5)
    assert base.mesh.n_inner == 36  # original unchanged
    assert s == dataclasses.replace(
        base,
        mesh=dataclasses.replace(base.mesh, n_inner=264),
        loading=dataclasses.replace(base.loading, f=0.5),
    )
    assert base.with_overrides() == base
    with pytest.raises(SceneError, match=r"unknown key 'loading\.ff'"):
        base.with_overrides("loading.ff=1")


# ----------------------------------------------------------------------------- round trip


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_round_trip_shipped(tmp_path: Path, name: str) -> None:
    scene = load_scene(name)
    out = write_scene(scene, tmp_path / "out.toml")
    assert load_scene(out) == scene
    assert scene_from_dict(scene_to_dict(scene)) == scene
    assert [p.name for p in tmp_path.iterdir()] == ["out.toml"]  # no temp files left


def test_round_trip_awkward_values(tmp_path: Path) -> None:
    scene = scene_from_dict(
        {
            "name": "odd.case-1",
            "description": 'quote " backslash \\ newline \n tab \t del \x7f unicode Ω',
            "material": {"E": 2.1e11, "rho": 7850.0, "nu": 0.299999999999},
            "geometry": {"R": 0.1 + 0.2, "d": 1e-7},
            "mesh": {"cell": "quadrilateral", "degree": 2, "n_radial": 3},
            "time": {"dt": 1.2345678901234567e-7, "max_steps": 10**12},
            "initial": {"perturbation": "random", "seed": 42, "n_modes": 8},
            "output": {"probes_deg": [], "fields": True, "progress": False},
        }
    )
    out = write_scene(scene, tmp_path / "odd.toml")
    assert load_scene(out) == scene
    assert load_scene(out).output.probes_deg == ()
    # overwrite in place is fine
    scene2 = scene.with_overrides("output.probes_deg=[-45.0, 1e-300]")
    write_scene(scene2, out)
    assert load_scene(out) == scene2


def test_dumps_toml_is_resolved() -> None:
    text = dumps_toml(load_scene("smoke"))
    data = tomllib.loads(text)
    assert data == scene_to_dict(load_scene("smoke"))
    assert set(data) == {
        "name",
        "description",
        "material",
        "geometry",
        "loading",
        "mesh",
        "time",
        "initial",
        "output",
        "damping",
        "friction",
    }
    assert data["material"] == {"E": 1.0e9, "wave_speed": 1000.0, "nu": 0.3}
    assert re.search(r"^field_interval = 0\.001$", text, re.M)


def test_missing_file_and_bad_toml(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"not found \(shipped scenes: .*smoke"):
        load_scene(tmp_path / "nope.toml")
    with pytest.raises(SceneError, match="invalid TOML"):
        load_scene(write(tmp_path, "[mesh\n"))
