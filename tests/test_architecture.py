"""The package layout (docs/architecture.md): imports run one way, and there is no circle.

Layers, top to bottom: ``cli`` -> ``studies`` -> ``postprocess`` -> ``solver`` -> ``forms`` ->
``meshes``. ``semianalytic`` and ``exact`` are leaves: numpy/scipy only, no dolfinx, no other
package of the project. Every import is read with :mod:`ast`, including the ones inside
functions (a lazy import can close a circle as well as a top-level one).
"""

from __future__ import annotations

import ast
import importlib.util
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: Rank of each package: a module may import only from packages of a lower rank (or its own).
LAYERS = {"meshes": 0, "forms": 1, "solver": 2, "postprocess": 3, "studies": 4, "cli": 5,
          "stickslip": 5}
#: Leaves: import nothing of the project outside themselves, and no FE stack.
LEAVES = ("semianalytic", "exact")
FE_STACK = ("dolfinx", "ufl", "basix", "petsc4py", "slepc4py", "mpi4py", "gmsh", "pyvista")
PACKAGES = (*LAYERS, *LEAVES)
#: The design card's folders, installed as ``stickslip.<folder>``.
FOLDERS = tuple(p for p in PACKAGES if p != "stickslip")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((REPO / pkg).rglob("*.py")) if (REPO / pkg).is_dir() else []:
            out[_module_name(path)] = path
    return out


MODULES = _modules()


def _local(mod: str) -> str:
    """The folder-relative name of an installed name: ``stickslip.solver.run`` -> ``solver.run``.

    The folders are installed as subpackages of ``stickslip`` (pyproject.toml's package-dir
    maps ``stickslip.solver`` to ``solver/``), so the layers are the folders.
    """
    head, _, rest = mod.partition(".")
    return rest if head == "stickslip" and rest.split(".")[0] in PACKAGES else mod


def _imports(name: str, path: Path) -> set[str]:
    """Every module (project or not) that ``name`` imports, anywhere in the file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(_local(alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module's package
                base = name.split(".")
                base = base[: len(base) - node.level + (1 if is_pkg else 0)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            subs = {_local(f"{mod}.{alias.name}") for alias in node.names}
            subs &= set(MODULES)  # ``from pkg import submodule``
            found |= subs
            if mod != "stickslip" or len(subs) < len(node.names):
                found.add(_local(mod))
    return found


def _project(mod: str) -> str | None:
    """The project module that ``mod`` names (its closest importable ancestor), or None."""
    while mod and mod not in MODULES:
        mod = mod.rpartition(".")[0]
    return mod or None


GRAPH = {name: {p for m in _imports(name, path) if (p := _project(m)) and p != name}
         for name, path in MODULES.items()}


def test_every_import_uses_the_installed_namespace():
    """Only ``stickslip`` is installed: ``import solver`` would load a second copy of a module."""
    bare = []
    for path in sorted(REPO.rglob("*.py")):
        rel = path.relative_to(REPO)
        if rel.parts[0] in ("archive", "build") or rel.parts[0].startswith("."):
            continue  # ./dev's editable install (.dev-site/) is generated, not the project's
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and not node.level else [])
            bare += [f"{rel}:{node.lineno} {n}" for n in names if n and n.split(".")[0] in FOLDERS]
    assert not bare, f"import through the installed namespace (stickslip.<pkg>): {bare[:10]}"


def test_the_folders_are_the_installed_subpackages():
    """``stickslip.<pkg>`` is the design card's folder ``<pkg>/``, mapped by pyproject.toml's
    package-dir, with no link in the tree (an import-graph tool, a linter or an IDE sees one
    package, not two floors), and the import system finds it there."""
    setuptools = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert setuptools["package-dir"] == {"stickslip": "stickslip",
                                         **{f"stickslip.{pkg}": pkg for pkg in FOLDERS}}
    links = [str(path.relative_to(REPO)) for top in ("stickslip", *FOLDERS)
             for path in (REPO / top, *(REPO / top).rglob("*")) if path.is_symlink()]
    assert not links, f"links in the package tree: {links}"
    for pkg in FOLDERS:
        spec = importlib.util.find_spec(f"stickslip.{pkg}")
        assert spec and Path(spec.origin) == REPO / pkg / "__init__.py", (pkg, spec)


def test_the_layout_is_found():
    for pkg in ("meshes", "forms", "solver", "postprocess", "studies", "cli", "semianalytic"):
        assert pkg in MODULES, pkg
    assert len(MODULES) > 40


@pytest.mark.parametrize("name", sorted(MODULES))
def test_imports_run_downwards(name):
    pkg = name.split(".")[0]
    for target in sorted(GRAPH[name]):
        tpkg = target.split(".")[0]
        if tpkg == pkg:
            continue
        if pkg in LEAVES:
            pytest.fail(f"{name} imports {target}: {pkg}/ is a leaf (numpy/scipy only)")
        if tpkg in LEAVES:
            continue  # anyone may use the analytical references
        assert LAYERS[tpkg] < LAYERS[pkg], (
            f"{name} imports {target}: upward import ({pkg} must not depend on {tpkg}); "
            f"layers bottom-up: {', '.join(LAYERS)}")


@pytest.mark.parametrize("leaf", LEAVES)
def test_leaves_are_free_of_the_fe_stack(leaf):
    for name, path in MODULES.items():
        if name.split(".")[0] != leaf:
            continue
        for mod in _imports(name, path):
            assert mod.split(".")[0] not in FE_STACK, f"{name} imports {mod}"


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of ``graph`` with more than one node."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return circles


def test_no_import_circles():
    """The module graph has no circle: its strongly connected components are all of size one."""
    circles = _circles(GRAPH)
    assert not circles, f"import circles: {circles}"


def _part(module: str) -> str | None:
    """The part of ``studies/`` or ``solver/`` that ``module`` belongs to: its sub-package
    (``studies.sweep``) or, directly in the folder, the module itself (``solver.run``)."""
    parts = module.split(".")
    return ".".join(parts[:2]) if parts[0] in ("studies", "solver") and len(parts) > 1 else None


def _part_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """The import graph between the parts of one folder (``_part``): an edge where any
    module of a part imports any module of another part of the same folder."""
    parts: dict[str, set[str]] = {}
    for name, targets in graph.items():
        here = _part(name)
        if here is None:
            continue
        for target in targets:
            there = _part(target)
            if there and there != here and there.split(".")[0] == here.split(".")[0]:
                parts.setdefault(here, set()).add(there)
    return parts


def test_no_import_circle_between_the_sub_packages():
    """A sub-package of ``studies/`` or ``solver/`` (or a module beside them) never imports,
    through any of its modules and imports inside functions included, a part that imports it
    back: ``studies.sweep`` uses ``studies.rundir``, never the other way."""
    circles = _circles(_part_graph(GRAPH))
    assert not circles, f"import circles between sub-packages: {circles}"


#: In-function imports of the project: at most this many, each with its reason in a comment
#: on its line or the line above (an optional heavy dependency, the FE stack where a module
#: must import without it); every other import of the project sits at its module's top.
LAZY_IMPORTS_MAX = 30
#: Modules left out of the count (none: every module's imports are counted).
LAZY_IMPORTS_NOT_COUNTED: tuple[str, ...] = ()


def _lazy_project_imports(path: Path) -> list[int]:
    """The lines of the imports of the project (``stickslip.*``, relative) inside functions."""
    lines = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for inner in ast.walk(node):
            if isinstance(inner, ast.Import):
                project = any(a.name.split(".")[0] == "stickslip" for a in inner.names)
            elif isinstance(inner, ast.ImportFrom):
                project = inner.level > 0 or (inner.module or "").split(".")[0] == "stickslip"
            else:
                continue
            if project:
                lines.append(inner.lineno)
    return sorted(set(lines))  # a nested function's import is found from both functions


def _has_reason(source: list[str], lineno: int) -> bool:
    """A comment on the import's line or alone on the line above it (a ``noqa`` or a
    ``type:`` comment says no reason)."""
    line, above = source[lineno - 1], source[lineno - 2].strip() if lineno > 1 else ""
    comment = line.partition("  # ")[2] or (above[2:] if above.startswith("# ") else "")
    return bool(comment) and not comment.startswith(("noqa", "type:"))


def test_project_imports_sit_at_the_module_top():
    """Hidden dependencies are few and explained: imports of the project inside functions,
    at most ``LAZY_IMPORTS_MAX``, each with its reason on its line or the line above."""
    lazy, unexplained = [], []
    for name, path in MODULES.items():
        if name in LAZY_IMPORTS_NOT_COUNTED:
            continue
        source = path.read_text().splitlines()
        for lineno in _lazy_project_imports(path):
            where = f"{path.relative_to(REPO)}:{lineno}"
            lazy.append(where)
            if not _has_reason(source, lineno):
                unexplained.append(where)
    assert len(lazy) <= LAZY_IMPORTS_MAX, f"{len(lazy)} imports inside functions: {lazy}"
    assert not unexplained, f"imports inside functions without a reason: {unexplained}"
    for name in LAZY_IMPORTS_NOT_COUNTED:
        assert name in MODULES, f"{name}: no such module (remove it from the list)"


def test_the_checkers_see_a_part_circle_and_an_unexplained_lazy_import(tmp_path):
    """The two checks above are not vacuous."""
    graph = {"studies.sweep.batch": {"studies.rundir.writer"},
             "studies.rundir.continuation": {"studies.sweep.batch"}, "studies.rundir.writer": set()}
    assert _circles(_part_graph(graph)) == [["studies.rundir", "studies.sweep"]]
    assert not _circles(graph)  # no circle between the modules themselves
    src = tmp_path / "m.py"
    src.write_text("import os\n\n\ndef f():\n    from stickslip.solver import run\n"
                   "    # numba on first use\n    from stickslip.solver import fused\n"
                   "    from . import x  # cupy\n    import json\n"
                   "    from . import y  # noqa: F401\n")
    assert _lazy_project_imports(src) == [5, 7, 8, 10]
    lines = src.read_text().splitlines()
    assert [_has_reason(lines, n) for n in (5, 7, 8, 10)] == [False, True, True, False]


def test_the_checker_sees_a_circle_and_an_upward_import(tmp_path):
    """The checks above are not vacuous: the parser resolves relative and lazy imports."""
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from stickslip.studies.rundir import run_scene\n"
                   "    from . import x\n    from stickslip import forms\n")
    found = _imports("solver.run", src)
    assert "studies.rundir" in found and _project("studies.rundir") == "studies.rundir"
    assert "solver" in found or "solver.x" in found
    assert "forms" in found and "stickslip" not in found


#: The scheme registry (solver.schemes.select): the one module that branches on a scene's
#: beta1, on the kernel and on the backend; the scene package may validate ``time.beta1``
#: (its own input).
SCHEME_CHOICE = "solver.schemes.select"
#: The values a branch on the kernel or the backend compares with.
KERNEL_NAMES = ("numpy", "numba", "cuda", "xp", "cpu", "gpu")
#: The batched stepper, whose array strategy may ask whether its namespace is numpy.
ARRAY_STRATEGY = "solver.ensemble"
#: Names a stepper goes by in the code, and what duck-typing one would ask it.
STEPPER_NAMES = ("stepper", "integrator", "integ", "it", "st")
STEPPER_ATTRS = ("kernel", "damped", "compiled_loop", "tau", "xp", "work_totals",
                 "damping_work_local", "refresh_ku", "after_step")


def _is_scene_choice(part: ast.AST) -> bool:
    """``<x>.time.beta1``, ``ts.beta1``, ``<x>.time.kernel``, ``ts.kernel``."""
    return (isinstance(part, ast.Attribute) and part.attr in ("beta1", "kernel")
            and ((isinstance(part.value, ast.Attribute) and part.value.attr == "time")
                 or (isinstance(part.value, ast.Name) and part.value.id == "ts")))


def _names_a_kernel(part: ast.AST) -> bool:
    """``kernel``, ``x.backend``, ``meta["kernel"]``, ``facts.get("kernel")``: a value that
    names a kernel or a backend, whatever it is compared with."""
    words = ("kernel", "backend")
    if isinstance(part, ast.Name | ast.Attribute):
        return _last_name(part) in words
    if isinstance(part, ast.Subscript):
        return isinstance(part.slice, ast.Constant) and part.slice.value in words
    if isinstance(part, ast.Call) and isinstance(part.func, ast.Attribute) and part.args:
        first = part.args[0]
        return part.func.attr == "get" and isinstance(first, ast.Constant) \
            and first.value in words
    return False


def _last_name(node: ast.AST) -> str:
    """``stepper`` for ``stepper``, ``self.stepper`` or ``batch.stepper``."""
    if isinstance(node, ast.Attribute):
        return node.attr
    return node.id if isinstance(node, ast.Name) else ""


def _scheme_decisions(tree: ast.AST, array_strategy: bool = False) -> list[str]:
    """Decisions on a scene's scheme, kernel or backend, and duck-typed steppers:

    * a comparison reading ``<x>.time.beta1``, ``ts.beta1`` or ``<x>.time.kernel``;
    * an (in)equality with a kernel's or a backend's name (``KERNEL_NAMES``), or of a value
      that names one (``_names_a_kernel``; the array strategy compares a checkpoint's kernel
      with its own, to adopt the other's layout);
    * ``xp is np`` / ``xp is not np`` (unless ``array_strategy``);
    * a call of ``resolve_kernel``;
    * ``getattr``/``hasattr`` on a stepper (``STEPPER_NAMES``) or asking for what only a
      stepper of some kind has (``STEPPER_ATTRS``).
    """
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            parts = (node.left, *node.comparators)
            text = ast.unparse(node)
            if any(_is_scene_choice(part) for part in parts):
                found.append(f"line {node.lineno}: compares {text}")
            elif (isinstance(node.ops[0], ast.Eq | ast.NotEq)
                  and any((isinstance(part, ast.Constant) and part.value in KERNEL_NAMES)
                          or (_names_a_kernel(part) and not array_strategy)
                          for part in parts)):
                found.append(f"line {node.lineno}: compares with a kernel: {text}")
            elif (not array_strategy and isinstance(node.ops[0], ast.Is | ast.IsNot)
                  and {_last_name(part) for part in parts} == {"xp", "np"}):
                found.append(f"line {node.lineno}: branches on the array module: {text}")
        elif isinstance(node, ast.Call):
            fn = node.func
            name = fn.attr if isinstance(fn, ast.Attribute) else getattr(fn, "id", "")
            if name == "resolve_kernel":
                found.append(f"line {node.lineno}: calls resolve_kernel")
            if name in ("getattr", "hasattr") and len(node.args) >= 2:
                obj, attr = node.args[0], node.args[1]
                asked = attr.value if isinstance(attr, ast.Constant) else None
                if _last_name(obj) in STEPPER_NAMES or asked in STEPPER_ATTRS:
                    found.append(f"line {node.lineno}: duck-types {ast.unparse(node)}")
    return found


def test_only_the_registry_chooses_the_scheme_kernel_and_backend():
    """Every branch on a scene's beta1 (explicit or implicit), on the kernel and on the
    backend lives in the scheme registry (solver/schemes/select.py), and nothing duck-types
    a stepper (``getattr``/``hasattr``): callers use the ``Stepper`` protocol."""
    offenders = {}
    for name, path in MODULES.items():
        if name == SCHEME_CHOICE or name.startswith("solver.scene"):
            continue
        if name.split(".")[0] not in ("solver", "studies", "cli", "postprocess", "stickslip"):
            continue
        hits = _scheme_decisions(ast.parse(path.read_text(), filename=str(path)),
                                 array_strategy=name == ARRAY_STRATEGY)
        if hits:
            offenders[name] = hits
    assert not offenders, f"scheme decisions outside {SCHEME_CHOICE}: {offenders}"
    select = MODULES[SCHEME_CHOICE]
    assert _scheme_decisions(ast.parse(select.read_text())), "the checker finds nothing"


def test_the_checker_sees_kernel_branches_and_duck_typing():
    """Each kind of decision the architecture test forbids is found in a small source."""
    src = ("if backend == 'gpu':\n    pass\n"
           "k = 1 if getattr(stepper, 'kernel', 'numpy') == 'numba' else 0\n"
           "if hasattr(self.integrator, 'damped'):\n    pass\n"
           "if xp is not np:\n    pass\n"
           "if scene.time.beta1 > 0.0:\n    pass\n"
           "if meta['backend'] != here:\n    pass\n"
           "if sim.stepper.facts().get('kernel', '') != kernel:\n    pass\n")
    hits = _scheme_decisions(ast.parse(src))
    assert len(hits) == 8, hits  # the ternary holds two: the getattr and the comparison
    assert not _scheme_decisions(ast.parse("if xp is np:\n    pass\n"), array_strategy=True)


def test_a_scheme_is_registered_once_and_asked_once():
    """The registry holds the explicit and the implicit Newmark; each kind of a run's
    columns (one scene: ``SceneColumn``; a batch: ``BatchColumns``) asks it one question
    (``for_scene``) and nothing else of it; the run itself (``solver.run``) never enters it."""
    from stickslip.solver.schemes.select import SCHEMES

    assert list(SCHEMES) == ["explicit", "implicit"]
    for name in ("solver.scene_column", "solver.ensemble_run"):
        tree = ast.parse(MODULES[name].read_text())
        imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                    and _local(node.module or "") == SCHEME_CHOICE for alias in node.names}
        assert imported == {"for_scene"}, (name, imported)
        calls = [node for node in ast.walk(tree) if isinstance(node, ast.Call)
                 and getattr(node.func, "id", "") == "for_scene"]
        assert len(calls) == 1, name
    # one scene: the scheme builds its parts with its own step (``Scheme.build``), so the
    # registry is entered once, not once per question
    tree = ast.parse(MODULES["solver.scene_column"].read_text())
    asked = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)
             and isinstance(node.value, ast.Call)
             and getattr(node.value.func, "id", "") == "for_scene"}
    assert asked == {"build"}, asked
    assert not [node for node in ast.walk(tree) if isinstance(node, ast.Attribute)
                and node.attr == "time_step"]
    tree = ast.parse(MODULES["solver.run"].read_text())
    assert not [node for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                and _local(node.module or "") == SCHEME_CHOICE]


def _function(module: str, name: str) -> ast.FunctionDef:
    tree = ast.parse(MODULES[module].read_text())
    return next(node for node in ast.walk(tree)
                if isinstance(node, ast.FunctionDef) and node.name == name)


def test_one_run_class_and_one_time_loop():
    """B ≥ 1 is the only kind of run: in the product, one class advances scenes
    (``solver.run.Simulation``, the only one with ``proceed`` that calls ``run_loop``), and
    ``run_loop`` is called nowhere else; the batch's columns are built by it, not beside it."""
    calls, loop_classes = [], []
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text())
        calls += [name for node in ast.walk(tree) if isinstance(node, ast.Call)
                  and getattr(node.func, "id", "") == "run_loop"]
        for cls in (n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)):
            methods = {f.name for f in cls.body if isinstance(f, ast.FunctionDef)}
            if "proceed" in methods:
                loop_classes.append(f"{name}.{cls.name}")
    assert calls == ["solver.run"], calls
    assert loop_classes == ["solver.run.Simulation"], loop_classes


@pytest.mark.dolfinx
@pytest.mark.parametrize("overrides", [(), ('time.kernel="numpy"',),
                                       ("time.beta1=0.25", "time.dt_fraction=2")],
                         ids=["numba", "numpy", "implicit"])
def test_one_recorder_for_every_scheme_and_every_b(overrides):
    """One recorder family: a scene alone, whatever its scheme and kernel, and a batch's
    scenes record with ``BatchRecorder``, the scene alone through its face
    ``MemberRecords``."""
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from stickslip.solver.ensemble_observers import BatchRecorder, MemberRecords
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene

    scene = load_scene("smoke", ["output.progress=false", *overrides])
    alone = Simulation(scene, MPI.COMM_SELF)
    assert isinstance(alone.columns.sampler, BatchRecorder)
    assert isinstance(alone.recorder, MemberRecords)
    if not overrides:
        batch = Simulation.batch([scene, scene])
        assert isinstance(batch.columns.recorder, BatchRecorder)


def test_summary_json_is_written_by_one_function():
    """Every ``summary.json`` of the product (a run, a batch member, a census start, a
    sweep's failed or interrupted scene, a travelling wave) is written by
    ``studies.rundir.summary_file.write_summary``: no other module writes a file named
    ``summary.json`` (an ``atomic_write_text`` or ``open(..., "w")`` of a path that ends in
    it), so its format and its atomicity live in one place."""
    writers = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.Call):
                continue
            func = getattr(node.func, "id", getattr(node.func, "attr", ""))
            if func not in ("atomic_write_text", "write_text", "open"):
                continue
            path_of = node.func.value if func == "write_text" else (
                node.args[0] if node.args else node.func)
            target = ast.unparse(path_of)
            if "summary.json" in target or "SUMMARY" in target:
                writers.append(f"{name}:{node.lineno}")
    assert writers == ["studies.rundir.summary_file:" + str(_line_of(
        "studies.rundir.summary_file", "atomic_write_text"))], writers


def _line_of(module: str, call: str) -> int:
    """The line of the first call of ``call`` in ``module``."""
    tree = ast.parse(MODULES[module].read_text())
    return min(n.lineno for n in ast.walk(tree) if isinstance(n, ast.Call)
               and getattr(n.func, "id", "") == call)


def test_the_run_command_and_the_api_share_one_run_function():
    """``stickslip run`` and ``stickslip.run`` refuse an aliasing scene and draw the figures
    in one place (``studies.rundir.run_scene``: ``check_sampling``, ``plot``): neither
    writes those checks itself."""
    for module, name in (("cli.run", "_run"), ("stickslip.api", "run")):
        names = {node.id for node in ast.walk(_function(module, name))
                 if isinstance(node, ast.Name)}
        names |= {node.attr for node in ast.walk(_function(module, name))
                  if isinstance(node, ast.Attribute)}
        assert "run_scene" in names, module
        assert not names & {"sampling_problem", "plot_run", "PLOTTABLE"}, (module, names)


#: Every class of the production code with a ``step`` method: the explicit step's kernel
#: strategies of ``BatchedExplicit`` (B scenes, or one as a batch of one), the one-scene view
#: of a batch of one, the implicit scheme, the protocol, and the travelling-wave Newton's
#: ``step(omega)`` (not a time step).
STEP_CLASSES = {
    ("solver/ensemble.py", "BatchedExplicit"), ("solver/ensemble.py", "ArrayColumns"),
    ("solver/ensemble.py", "SceneArrayColumns"), ("solver/ensemble.py", "NumbaColumns"),
    ("solver/ensemble.py", "CudaColumns"), ("solver/scene_explicit.py", "SceneExplicit"),
    ("solver/implicit.py", "ImplicitNewmark"), ("solver/stepper.py", "Stepper"),
    ("studies/travel/frame.py", "FrameOperators"),
    ("studies/travel/newton.py", "CircleProblem"),
}


def test_the_explicit_step_is_written_once_per_backend():
    """No time stepper outside ``STEP_CLASSES``; the two numpy strategies (the batch's, with
    its law in arrays, and one scene's, with its own product and contact step) both step
    through ``internal_force`` and ``newmark_update``, the numpy step written once; numba
    and CUDA are each one kernel family (``solver._fused_kernels``, ``ensemble_cuda``)."""
    found, calls = set(), {}
    for path in sorted((REPO / "solver").rglob("*.py")) + sorted((REPO / "studies").rglob(
            "*.py")):
        rel = path.relative_to(REPO).as_posix()
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ClassDef):
                continue
            for item in node.body:
                if isinstance(item, ast.FunctionDef) and item.name == "step":
                    found.add((rel, node.name))
                    calls[node.name] = {c.func.id for c in ast.walk(item)
                                        if isinstance(c, ast.Call)
                                        and isinstance(c.func, ast.Name)}
    assert found == STEP_CLASSES
    for strategy in ("ArrayColumns", "SceneArrayColumns"):
        assert {"internal_force", "newmark_update"} <= calls[strategy], strategy


def test_every_scheme_follows_the_stepper_protocol():
    """The three steppers implement ``solver.stepper.Stepper`` (checked at run time
    on the classes' attributes: set_state, step, advance, facts)."""
    pytest.importorskip("dolfinx")
    from stickslip.solver.ensemble import BatchedExplicit
    from stickslip.solver.implicit import ImplicitNewmark
    from stickslip.solver.scene_explicit import SceneExplicit
    from stickslip.solver.stepper import Stepper

    for cls in (SceneExplicit, ImplicitNewmark, BatchedExplicit):
        for method in ("set_state", "step", "advance", "facts", "attach", "state", "restore"):
            assert callable(getattr(cls, method, None)), f"{cls.__name__}.{method}"
    for method in ("keep_nodes", "mask", "host_state", "kick", "host_column"):  # BatchStepper
        assert callable(getattr(BatchedExplicit, method, None)), method
    import numpy as np
    from conftest import explicit_stepper

    stepper = explicit_stepper(lambda u, out: np.multiply(u, 1.0, out=out), np.ones(4), 0.1)
    assert isinstance(stepper, Stepper)
    stepper.set_state(np.ones(4), np.zeros(4))
    assert stepper.advance(3) == 3 and stepper.step_count == 3
    assert stepper.facts()["scheme"] == "explicit"


#: The walk of a scene from ``stickslip run``: the modules it enters, and how often it comes
#: back into a module it has already left (a scene handed back and forth between rooms),
#: the registry's second visit (the build, after its check before meshing) among them.
WALK_RETURNS = 11


@pytest.mark.dolfinx
def test_the_walk_of_a_scene_from_the_run_command(tmp_path):
    """Trace ``stickslip run smoke`` (``sys.setprofile``): every call of the project's code
    that receives the ``Scene`` is a step of the walk, its module a room. The walk comes
    back into a room it has left at most ``WALK_RETURNS`` times, and enters the scheme
    registry twice: before anything is meshed or made (``unsteppable``: can it step the
    scene?) and to build the step, where it asks every other question in one visit."""
    pytest.importorskip("dolfinx")
    import contextlib
    import io
    import sys

    from stickslip.cli.main import main
    from stickslip.solver.scene import Scene

    rooms: list[str] = []

    def profile(frame, event, arg):  # noqa: ANN001, ANN202
        code = frame.f_code
        if event != "call" or str(REPO) not in code.co_filename:
            return
        args = code.co_varnames[:code.co_argcount + code.co_kwonlyargcount]
        if any(isinstance(frame.f_locals.get(a), Scene) for a in args):
            path = Path(code.co_filename).resolve().relative_to(REPO).with_suffix("")
            room = ".".join(part for part in path.parts if part != "__init__")
            if not rooms or rooms[-1] != room:
                rooms.append(room)

    sys.setprofile(profile)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            rc = main(["run", str(REPO / "scenes" / "smoke.toml"), "--set",
                       "time.end_time=0.002", "-o", str(tmp_path / "run")])
    finally:
        sys.setprofile(None)
    assert rc == 0
    returns = len(rooms) - len(set(rooms))
    assert returns <= WALK_RETURNS, " -> ".join(rooms)
    assert rooms.count(SCHEME_CHOICE) == 2, " -> ".join(rooms)
