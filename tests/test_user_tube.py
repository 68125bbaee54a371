"""A user's finite tube (``mesh.file`` with ``mesh.dim = 3``, meshes.user_tube): the same tube
as the built-in one, a tube with graded axial layers, and the checks.

The files are written here with gmsh: the smoke scene's annulus (R = 1 to 1.25, N = 36, 2
layers through the wall, ``meshes.annulus.annulus_surfaces``) extruded along z in hexahedra,
its surfaces grouped by position as "contact" (r = R), "clamped" (r = 1.25) and "ends".
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("dolfinx")
gmsh = pytest.importorskip("gmsh")

from mpi4py import MPI  # noqa: E402

from stickslip.solver.scene import SceneError, load_scene  # noqa: E402

#: the smoke scene as the 3D tube of 0.3 m in quadrilaterals (hexahedra), a step below the
#: limit of both the uniform (0.1 m) and the graded (0.05 m) layers
TUBE = ("mesh.cell=quadrilateral", "mesh.dim=3", "geometry.length=0.3", "time.dt=6e-5",
        "output.sample_interval=6e-5", "time.end_time=0.006")


def write_tube(path, layers: list[int], heights: list[float] | None = None,
               length: float = 0.3, ends: bool = True, hexahedra: bool = True,
               contact_sectors: int = 4) -> str:
    """The smoke annulus extruded over ``length`` in ``layers`` (gmsh ``Layers``: counts and
    cumulated heights), hexahedra (else prisms); the surface groups by position, the
    contact group the first ``contact_sectors`` quarters of r = R. Returns the path."""
    from stickslip.meshes.annulus import annulus_surfaces

    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        gmsh.model.add("tube")
        surfaces, _, _ = annulus_surfaces(1.0, 1.25, 36, 2, recombine=hexahedra)
        gmsh.model.geo.extrude([(2, s) for s in surfaces], 0.0, 0.0, length,
                               numElements=layers, heights=heights or [], recombine=hexahedra)
        gmsh.model.geo.synchronize()
        gmsh.model.mesh.generate(3)
        groups: dict[str, list[int]] = {"contact": [], "clamped": [], "ends": []}
        for _, tag in gmsh.model.getEntities(2):
            xyz = gmsh.model.mesh.getNodes(2, tag, includeBoundary=True)[1].reshape(-1, 3)
            r = np.hypot(xyz[:, 0], xyz[:, 1])
            if np.allclose(r, 1.0, atol=1e-9):
                groups["contact"].append(tag)
            elif np.allclose(r, 1.25, atol=1e-9):
                groups["clamped"].append(tag)
            elif np.ptp(xyz[:, 2]) < 1e-12 and ends:
                groups["ends"].append(tag)
        groups["contact"] = groups["contact"][:contact_sectors]
        for name, tags in groups.items():
            if tags:
                gmsh.model.addPhysicalGroup(2, tags, name=name)
        gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], name="tube")
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return str(path)


def test_the_built_in_tube_as_a_users_file_runs_the_same(tmp_path):
    """The built-in tube (3 layers of 0.1 m) and the same tube written to a .msh: the same
    ring of contact nodes, the same steady state and run. The file's nodes are gmsh's, the
    built-in tube snaps both cylinders to exact angles and the levels; the file's contact
    surface is snapped radially and in z, its angles are gmsh's (2e-9 rad off), so the
    runs agree to that size over 100 steps: asserted 1e-7 of max |u_r - d| (measured
    2.7e-9), statuses equal. The summary reads the file's layers and length."""
    from stickslip import run

    msh = write_tube(tmp_path / "tube.msh", [3])
    sets = [*TUBE, "boundary.ends=free", "mesh.n_axial=3"]
    built = run("smoke", tmp_path / "built", overrides=sets, force=True, quiet=True)
    users = run("smoke", tmp_path / "file", overrides=[*sets, f'mesh.file="{msh}"'],
                force=True, quiet=True)
    assert built["status"] == users["status"] == "completed"
    assert users["tube_3d"]["n_axial"] == 3
    assert users["tube_3d"]["length_m"] == pytest.approx(0.3, abs=1e-12)
    a, b = (np.load(tmp_path / d / "samples.npz") for d in ("built", "file"))
    wave = a["u_r"] - 0.0004
    assert np.max(np.abs(b["u_r"] - a["u_r"])) < 1e-7 * np.max(np.abs(wave))
    np.testing.assert_array_equal(a["status"], b["status"])
    sa, sb = (np.load(tmp_path / d / "surface.npz") for d in ("built", "file"))
    np.testing.assert_allclose(sb["z"], sa["z"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(sb["theta"], sa["theta"], rtol=0, atol=1e-8)


def test_a_tube_with_graded_layers_runs_with_its_own_rings(tmp_path):
    """Layers refined towards both ends (0.05, 0.05, 0.1, 0.05, 0.05 m): the run samples
    the ring at the middle level, surface.npz holds the file's levels, roller ends hold
    the ends group (u_z = 0 there, moving elsewhere), and the CEA runs on the same
    scene."""
    from stickslip import run
    from stickslip.cli.main import main

    msh = write_tube(tmp_path / "graded.msh", [1, 1, 1, 1, 1],
                     [1 / 6, 2 / 6, 4 / 6, 5 / 6, 1.0])
    sets = [*TUBE, f'mesh.file="{msh}"', "boundary.ends=roller", "time.dt=3e-5"]
    summary = run("smoke", tmp_path / "run", overrides=sets, force=True, quiet=True)
    assert summary["status"] == "completed", summary.get("message")
    assert summary["tube_3d"]["ring_z_m"] == pytest.approx(0.1, abs=1e-12)
    surface = np.load(tmp_path / "run" / "surface.npz")
    np.testing.assert_allclose(surface["z"], [0, 0.05, 0.1, 0.2, 0.25, 0.3], atol=1e-12)
    assert (surface["status"] >= 0).all()
    assert not surface["u_z"][:, [0, -1]].any() and surface["u_z"][:, 1:-1].any()
    sets_cli = [a for s in sets for a in ("--set", s)]
    assert main(["flutter-fe", "smoke", *sets_cli, "--fmax-hz", "3000", "--top", "1"]) == 0


def test_a_users_tube_that_does_not_fit_is_one_line(tmp_path):
    """One line each: a length, a layer count or ``mesh.n_inner`` other than the file's;
    held ends without an ends group; a file whose rings are not at the same angles, or
    cover half the tube; cells
    other than hexahedra (prisms); a 2D file given as a 3D tube."""
    good = write_tube(tmp_path / "tube.msh", [3])
    noends = write_tube(tmp_path / "noends.msh", [3], ends=False)
    scene = [*TUBE, f'mesh.file="{good}"']
    for extra, words in ((["geometry.length=0.25"], "set geometry.length = 0.3"),
                         (["geometry.length=0"], "set geometry.length = 0.3"),
                         (["mesh.n_axial=4"], "has 3 layers"),
                         (["mesh.n_inner=40"], "set mesh.n_inner = 36"),
                         ([f'mesh.file="{noends}"', "boundary.ends=roller"],
                          "does not have")):
        with pytest.raises(SceneError, match=words) as err:
            load_scene("smoke", [*scene, *extra])
        assert "\n" not in str(err.value)
    load_scene("smoke", [*TUBE, f'mesh.file="{noends}"'])  # free ends need no group
    twisted = tmp_path / "twisted.msh"
    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        gmsh.open(good)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        xyz = xyz.reshape(-1, 3)
        top = np.abs(xyz[:, 2] - 0.3) < 1e-9
        turn = 0.01  # the top ring turned by 0.01 rad
        c, s = np.cos(turn), np.sin(turn)
        for tag, (x, y, z) in zip(tags[top], xyz[top], strict=True):
            gmsh.model.mesh.setNode(int(tag), [c * x - s * y, s * x + c * y, z], [])
        gmsh.write(str(twisted))
    finally:
        gmsh.finalize()
    with pytest.raises(SceneError, match="other angles .* Extrude"):
        load_scene("smoke", [*TUBE, f'mesh.file="{twisted}"'])
    half = write_tube(tmp_path / "half.msh", [3], contact_sectors=2)
    with pytest.raises(SceneError, match="leaves a gap of 180.0 degrees"):
        load_scene("smoke", [*TUBE, f'mesh.file="{half}"', "mesh.n_inner=19"])
    prisms = write_tube(tmp_path / "prisms.msh", [3], hexahedra=False)
    with pytest.raises(SceneError, match="need 8-node hexahedra alone"):
        load_scene("smoke", [*TUBE, f'mesh.file="{prisms}"'])
    flat = tmp_path / "flat.geo"
    flat.write_text('Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {1, 1, 0};\n'
                    'Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 1};\n'
                    'Curve Loop(1) = {1, 2, 3}; Plane Surface(1) = {1};\n')
    with pytest.raises(SceneError, match="no volume cells"):
        load_scene("smoke", [*TUBE, f'mesh.file="{flat}"'])


@pytest.mark.parallel
def test_a_users_tube_runs_the_same_on_every_rank_count(tmp_path):
    """The file's tube on one rank and on ``MPI.COMM_WORLD`` (``mpirun -n 2`` in the parallel
    pass): statuses equal and the ring's u_r to 1e-10 of max u_r (the partitions sum K u
    in other orders: round-off); the surface gathered from the ranks the same."""
    from stickslip.solver.run import Simulation

    world = MPI.COMM_WORLD
    path = world.bcast(write_tube(tmp_path / "tube.msh", [3]) if world.rank == 0 else None)
    scene = load_scene("smoke", [*TUBE, f'mesh.file="{path}"', "boundary.ends=free"])
    results = {}
    for name, comm in (("serial", MPI.COMM_SELF), ("world", world)):
        sim = Simulation(scene, comm)
        sim.proceed()
        surface = sim.columns.surface_arrays()  # collective: gathered to rank 0
        if comm.rank == 0:
            results[name] = (sim.recorder.arrays(), surface)
    if world.rank == 0:
        (a, surface_a), (b, surface_b) = results["serial"], results["world"]
        np.testing.assert_array_equal(a["status"], b["status"])
        np.testing.assert_array_equal(surface_a["status"], surface_b["status"])
        assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-10 * np.max(np.abs(a["u_r"]))
