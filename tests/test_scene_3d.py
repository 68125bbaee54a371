"""The 3D scene keys (mesh.dim, geometry.length, mesh.n_axial, boundary.ends) and their
compatibility rule: a key that applies to 3D scenes only is left out of a plane-strain
scene's resolved text and hashes (``solver.scene.model.scene_to_dict``), so every scene
written before the keys existed still resolves, writes and hashes as it did; a 3D scene
writes them and loads back; bad values are one line each; ``stickslip flutter-fe`` reads
them, and the commands that run the transient refuse a 3D scene in one line."""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

import pytest

from stickslip.solver.scene import (
    PLANE_STRAIN_ONLY,
    Scene,
    SceneError,
    dumps_toml,
    list_scenes,
    load_scene,
    scene_to_dict,
    write_scene,
)
from stickslip.solver.scene.files import scene_difference, scene_digest
from stickslip.studies.rundir.checkpoint import scene_fingerprint

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "docs" / "_ext"))

import stickslip_reference as reference  # noqa: E402

#: name -> (scene_digest, scene_fingerprint) of every shipped scene and of ``Scene()``,
#: computed by the code before the 3D keys existed (commit 39710ca). scene_digest is the
#: SHA-256 of the written resolved text (dumps_toml), so an equal digest is an equal text;
#: scene_fingerprint hashes scene_to_dict (checkpoints, continuations). Regenerate (only on
#: a deliberate change of the resolved scene, which makes every run directory look stale):
#:   for p in list_scenes(): s = load_scene(p); print(p.stem, scene_digest(s),
#:                                                    scene_fingerprint(s))
BEFORE = {
    "figure1": ("e4bf7d0f9dae5b2e645d99a56d7c683452e52a17cc42e55a9774d887148b96ba",
                "7dcbcc41f1998131c7de41802345f32c20dbd394855fb15ad8beff29142b7e94"),
    "figure1_n132_damped": ("9072c67f4e27b17b0e3d19e95b7c8d8ca63a8870d3292733ecb4000c09833e8b",
                            "75e7b635c6e013c6392a018f621e8ac4ed3195ea91c2731796fb9ce397098061"),
    "figure2_n132": ("32534245339ddb6e24d91790e9ae30fbb56499f002c11162fb8a2baf6d7e332d",
                     "e4c977aa391afd40ee52a6f24ac32d4ae954c7773d2ec36cbe3e009f6790b06b"),
    "figure2_n36": ("41884d088d2786767998a61a8bd75a41d84eef7c51515168724c33e29e65c13f",
                    "a2866c53a0a7c9d4adebdde7ed73687847aa5272c619044237896fce0581b888"),
    "figure3_n132": ("d0c338c58ca7a46b55750b6e58a705d925b7631ad4a8ad41ba2adeebae0cee0e",
                     "4496e086302654c9528762a8d90c3600e894f77c8dcc090319a97f242a2b2d67"),
    "figure3_n132_damped": ("a7ede35cbbd36a8c0bb2624fef35089d198bf491b647baa6b3cec6dd806cf9ff",
                            "67f7b9b1bb750e0f9649f2b792a4c1b3fed19ec9680ffbad920eb6d452c2652b"),
    "figure3_n36": ("26750bb732e75c311adfb2f11b3ea28aefe15ff13e684d2a2ae579893b06435d",
                    "dd744b09f862a8d77c7922e6cc419a9aae656dc0d9de7e11a9eefe9fc311d73f"),
    "figure4_d0005": ("f28f6a8cf4da3cbfbadd7056ff503d47395fd5c8289af218d2d6887d522c1305",
                      "f555d9af8a8ea6499a96fd14895053ebdb482a1b172f539f8038739bc2f609b9"),
    "figure4_d001": ("94008518a8a5585c53ff9db4f2f439b108d10a6f99105602b37e80a53c2bea13",
                     "2bc913180b23bd315c67bfaf5ee1ab31561fbc9147aedfacdfe6b0dc8ef7d147"),
    "figure4_d005": ("c292afd0039778a33f37fda432f9ec7808282d96169ceb73958b43531b17ad10",
                     "29299210ec43d0c56e391f323e9498386943e491969366a9b1199bbb6bdb576c"),
    "figure5_w1000": ("99ad2c2cdcec3697aee43af736cb585c774b0e6d4bd1744bbcf17fd2d0a74866",
                      "535667fea8cbca9b1e0fa9be17dece8c1de7e69452cd8484f0e356038a92b68f"),
    "figure5_w32": ("65ed11aa5f5478f8fa5995d051344e4cf8a9fd0d843316fde258a9b00f75898e",
                    "3712c45b6e9b611dd6179995649cf9d4d364ac9b03846b8f6bb2d6acc2476c2b"),
    "figure5_w380": ("eec845fcbd6c949b1db4a3eb13a0726dd69af5caa4d8f9705f79a711c7e87c3e",
                     "dc6c6f8fceb02abbc2fc768d93647bf8c9f4d3543bf759e2d96cf02c48ad93a4"),
    "figure6_k2": ("b4344de0a015cc68b0fbfe643e26de84a97813c20eff3a4a129356d4f6bbf0d3",
                   "f511b95ec812bd50f2fe82a00d7103fe842f5ee2302a1f479f32b4f5c8763fb9"),
    "figure6_k3": ("46276d6fc8a23219edad81e1d2b2b4f3bd08b8b7ddb9ed5060269e636fd08ba6",
                   "be1d8f6de24fc91add20c5f077410fee916d7e288d2d73ba9bdfd99b61b8bacc"),
    "figure6_k4": ("c8e8320289f80a5f9d77fe1e2e718fcfa11f34b588a92168a5763dace3a163e6",
                   "36d6778e9c21370539c6fa56409c1f5d892349877329c8286512c91e0d684e83"),
    "smoke": ("4d9c9791bc721aa906a71209275d7427bbb8f13cba7ee8780ef58cf2403174c1",
              "74b72584449192d9b7e3d1b0ee92d93b09c5adda6ff59a8b9cc0b098a5f59b35"),
    "tube_four_clamps": ("c6911ecd1856d43be55ec55619abf344fac5efecb29f0c4572d7048b72d94c5e",
                         "ca82f19f903f63a9d1e9b8cffe09ddc0dd0eca00ce7c560f34c71e886914a6d8"),
    "Scene()": ("f6c3fb27e105b64c2b38affd94a674ca76d684fde0aea21a7197f4bcccc3375e",
                "c378aa8ce15b49e175180061a98178608bac3e371ac32d6a53eee46495a2555f"),
}

#: The 3D tube of tests/test_tube3d.py's CLI case: Figure 1, N = 32, quadrilaterals (the
#: cross-section the hexahedra extrude), L = 50 mm in 4 layers, roller ends.
TUBE = ["mesh.n_inner=32", "mesh.cell=quadrilateral"]
TUBE_3D = [*TUBE, "mesh.dim=3", "geometry.length=0.05", "mesh.n_axial=4",
           'boundary.ends="roller"']


def test_every_shipped_scene_resolves_writes_and_hashes_as_before():
    """The 18 shipped plane-strain scenes and the default scene: the digest of the written
    resolved text and the checkpoint's fingerprint are those of the code before the 3D keys;
    no 3D key and no [boundary] table in any of them. The shipped 3D scene writes its keys."""
    every = {p.stem: load_scene(p) for p in list_scenes()}
    shipped = {name: s for name, s in every.items() if s.mesh.dim == 2}
    assert set(every) - set(shipped) == {"tube3d_figure3_damped"}
    assert tomllib.loads(dumps_toml(every["tube3d_figure3_damped"]))["boundary"] == {
        "ends": "free"}
    assert len(shipped) == 18 and set(shipped) | {"Scene()"} == set(BEFORE)
    for name, scene in {**shipped, "Scene()": Scene()}.items():
        assert (scene_digest(scene), scene_fingerprint(scene)) == BEFORE[name], name
        written = tomllib.loads(dumps_toml(scene))
        assert "boundary" not in written, name
        assert not {"dim", "n_axial"} & set(written["mesh"]), name
        assert "length" not in written["geometry"], name


def test_a_3d_scene_writes_its_keys_and_loads_back(tmp_path):
    """A 3D scene writes all four keys, defaults too (n_axial = 0, ends = "free"), loads
    back to the same scene and text, and hashes apart from its plane-strain twin."""
    scene = load_scene("figure1", [*TUBE, "mesh.dim=3", "geometry.length=0.05"])
    d = scene_to_dict(scene)
    assert (d["mesh"]["dim"], d["mesh"]["n_axial"], d["geometry"]["length"]) == (3, 0, 0.05)
    assert d["boundary"] == {"ends": "free"}
    back = load_scene(write_scene(scene, tmp_path / "scene.toml"))
    assert back == scene and dumps_toml(back) == dumps_toml(scene)
    flat = load_scene("figure1", TUBE)
    assert scene_digest(flat) != scene_digest(scene)
    assert scene_fingerprint(flat) != scene_fingerprint(scene)
    assert scene_difference(flat, scene) == "geometry.length = 0.0, not 0.05"
    assert scene_difference(flat.with_overrides("mesh.n_axial=0"), flat) is None
    again = flat.with_overrides("mesh.dim=3", "geometry.length=0.05")  # 2D + overrides
    assert dumps_toml(again) == dumps_toml(scene)


@pytest.mark.parametrize("sets, words", [
    (["mesh.dim=4"], "mesh.dim = 4 is not allowed: must be one of 2, 3"),
    (["mesh.dim=3"], "geometry.length = 0.0 is out of range: must satisfy length > 0 (m) "
                     "with mesh.dim = 3"),
    (["mesh.dim=3", "geometry.length=-0.1"], "geometry.length = -0.1 is out of range"),
    (["mesh.dim=3", "geometry.length=0.1", "mesh.n_axial=-1"],
     "mesh.n_axial = -1 is out of range: must satisfy 0 <= n_axial <= 1e7"),
    (["mesh.dim=3", "geometry.length=0.1", 'boundary.ends="hinged"'],
     "boundary.ends = 'hinged' is not allowed: must be one of 'free', 'roller', 'clamped'"),
    (["geometry.length=0.1"], "geometry.length = 0.1 only applies to mesh.dim = 3 (the "
                              "finite tube): set mesh.dim = 3 or drop geometry.length"),
    (["mesh.n_axial=3"], "mesh.n_axial = 3 only applies to mesh.dim = 3"),
    (['boundary.ends="roller"'], "boundary.ends = 'roller' only applies to mesh.dim = 3"),
    (["mesh.dim=3", "geometry.length=0.1", "mesh.degree=2"],
     "mesh.degree = 2 is out of range: must satisfy degree = 1 with mesh.dim = 3"),
    (["mesh.dim=3", "geometry.length=0.1", 'mesh.file="meshes/tube_four_clamps.geo"',
      "mesh.n_inner=48"], "no volume cells: mesh the tube in 3D"),
])
def test_bad_3d_keys_are_one_line_errors(sets, words):
    with pytest.raises(SceneError) as err:
        load_scene("figure1", sets)
    assert words in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_the_scene_reference_lists_the_3d_keys():
    """The generated reference (docs/_ext/stickslip_reference.py) has a row per 3D key with
    its default and rule, and the [boundary] table."""
    page = reference.scene_markdown()
    assert "## `[boundary]`" in page
    for row in ("| `mesh.dim` | integer | `2` | one of 2, 3 |",
                "| `geometry.length` | number | `0.0` | length >= 0",
                "| `mesh.n_axial` | integer | `0` | 0 &lt;= n\\_axial &lt;= 1e7",
                "| `boundary.ends` | string | `\"free\"` | one of 'free', 'roller', 'clamped' |"):
        assert row in page, row


def test_the_plane_strain_commands_refuse_a_3d_scene(tmp_path, capsys):
    """``stickslip travel`` on a 3D scene: exit 2, one line (``PLANE_STRAIN_ONLY``); ``rpo``
    on a run directory whose scene.toml is 3D, likewise. ``run``, ``sweep``, ``continue``
    and ``attractors`` run it (tests/test_tube3d_transient.py)."""
    from stickslip.cli.main import main

    (tmp_path / "run").mkdir()
    path = write_scene(load_scene("smoke", ["mesh.dim=3", "geometry.length=0.1"]),
                       tmp_path / "run" / "scene.toml")
    for argv in (["travel", str(path), "--k", "4"],
                 ["rpo", str(path.parent), "--period", "0.01", "--shift", "1"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and PLANE_STRAIN_ONLY in err, (argv, err)


def test_flutter_fe_reads_the_3d_keys_of_the_scene(tmp_path, capsys):
    """``stickslip flutter-fe`` of a scene with the 3D keys gives the eigenvalues of the same
    tube through ``--length 0.05 --n-axial 4 --ends roller`` (tests/test_tube3d.py's case),
    to round-off; the options override the scene's keys."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    scene = write_scene(load_scene("figure1", TUBE_3D), tmp_path / "tube.toml")
    args = ["--fmax-hz", "3000", "--json"]
    assert main(["flutter-fe", str(scene), *args]) == 0
    keys = json.loads(capsys.readouterr().out)
    options = [f"--set={s}" for s in TUBE]
    assert main(["flutter-fe", "figure1", *options, "--length", "0.05", "--n-axial", "4",
                 "--ends", "roller", *args]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert keys["tube_3d"] == cli["tube_3d"] == {"length_m": 0.05, "n_axial": 4,
                                                 "ends": "roller"}
    assert len(keys["unstable"]) == len(cli["unstable"]) >= 8
    for a, b in zip(keys["unstable"], cli["unstable"], strict=True):
        assert (a["k"], a["axial_order"]) == (b["k"], b["axial_order"])
        assert a["frequency_hz"] == pytest.approx(b["frequency_hz"], rel=1e-10, abs=1e-9)
        assert a["growth_rate"] == pytest.approx(b["growth_rate"], rel=1e-8, abs=1e-6)
    assert main(["flutter-fe", str(scene), "--ends", "free", "--top", "1"]) == 0
    assert "3D tube: length 0.05 m, 4 axial layers, free ends" in capsys.readouterr().out


def test_the_api_runs_the_cea_of_a_3d_scene_and_refuses_its_travelling_wave(tmp_path):
    """``stickslip.cea`` of a 3D scene is its tube's (the same unstable modes as the CLI);
    ``stickslip.travel`` refuses it in one line."""
    pytest.importorskip("dolfinx")
    import stickslip

    res = stickslip.cea("figure1", overrides=TUBE_3D, fmax_hz=3000.0)
    assert res.levels == 5 and len(res.unstable()) >= 8
    with pytest.raises(SceneError, match="plane strain only"):
        stickslip.travel("smoke", k=4, overrides=["mesh.dim=3", "geometry.length=0.1"])
