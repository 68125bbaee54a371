"""The package layout (docs/architecture.md): imports run one way, and there is no circle.

Layers, top to bottom: ``cli`` -> ``studies`` -> ``postprocess`` -> ``solver`` -> ``forms`` ->
``meshes``. ``semianalytic`` and ``exact`` are leaves: numpy/scipy only, no dolfinx, no other
package of the project. Every import is read with :mod:`ast`, including the ones inside
functions (a lazy import can close a circle as well as a top-level one).
"""

from __future__ import annotations

import ast
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


def _imports(name: str, path: Path) -> set[str]:
    """Every module (project or not) that ``name`` imports, anywhere in the file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module's package
                base = name.split(".")
                base = base[: len(base) - node.level + (1 if is_pkg else 0)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            found.add(mod)
            for alias in node.names:  # ``from pkg import submodule``
                if f"{mod}.{alias.name}" in MODULES:
                    found.add(f"{mod}.{alias.name}")
    return found


def _project(mod: str) -> str | None:
    """The project module that ``mod`` names (its closest importable ancestor), or None."""
    while mod and mod not in MODULES:
        mod = mod.rpartition(".")[0]
    return mod or None


GRAPH = {name: {p for m in _imports(name, path) if (p := _project(m)) and p != name}
         for name, path in MODULES.items()}


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


def test_no_import_circles():
    """Tarjan's strongly connected components of the module graph: all of size one."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH[v]:
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

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    assert not circles, f"import circles: {circles}"


def test_the_checker_sees_a_circle_and_an_upward_import(tmp_path):
    """The checks above are not vacuous: the parser resolves relative and lazy imports."""
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from studies.rundir import run_scene\n    from . import x\n")
    found = _imports("solver.run", src)
    assert "studies.rundir" in found and _project("studies.rundir") == "studies.rundir"
    assert "solver" in found or "solver.x" in found


#: The one module that decides which time scheme and kernel a scene runs with
#: (solver.schemes.select); the scene package may validate ``time.beta1`` (its own input).
SCHEME_CHOICE = "solver.schemes.select"


def _scheme_decisions(tree: ast.AST) -> list[str]:
    """Decisions on a scene's scheme: a comparison reading ``<x>.time.beta1``, ``ts.beta1`` or
    ``<x>.time.kernel``, and any call of ``resolve_kernel``."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            for part in (node.left, *node.comparators):
                if (isinstance(part, ast.Attribute) and part.attr in ("beta1", "kernel")
                        and ((isinstance(part.value, ast.Attribute)
                              and part.value.attr == "time")
                             or (isinstance(part.value, ast.Name)
                                 and part.value.id == "ts"))):
                    found.append(f"line {node.lineno}: compares {ast.unparse(part)}")
        elif isinstance(node, ast.Call):
            fn = node.func
            name = fn.attr if isinstance(fn, ast.Attribute) else getattr(fn, "id", "")
            if name == "resolve_kernel":
                found.append(f"line {node.lineno}: calls resolve_kernel")
    return found


def test_only_the_selection_module_chooses_the_scheme():
    """Every branch on a scene's beta1 (explicit or implicit) and kernel lives in
    solver/schemes/select.py; the scene package validates its own input there too."""
    offenders = {}
    for name, path in MODULES.items():
        if name == SCHEME_CHOICE or name.startswith("solver.scene"):
            continue
        if name.split(".")[0] not in ("solver", "studies", "cli", "postprocess"):
            continue
        hits = _scheme_decisions(ast.parse(path.read_text(), filename=str(path)))
        if hits:
            offenders[name] = hits
    assert not offenders, f"scheme decisions outside {SCHEME_CHOICE}: {offenders}"
    select = MODULES[SCHEME_CHOICE]
    assert _scheme_decisions(ast.parse(select.read_text())), "the checker finds nothing"


def test_every_scheme_follows_the_stepper_protocol():
    """The five schemes implement ``solver.schemes.protocol.Stepper`` (checked at run time
    on the classes' attributes: set_state, step, advance, facts)."""
    pytest.importorskip("dolfinx")
    from solver.ensemble import BatchedExplicit
    from solver.fused import FusedNewmark
    from solver.implicit import ImplicitNewmark
    from solver.newmark import DampedNewmark, Newmark
    from solver.schemes.protocol import Stepper

    for cls in (Newmark, DampedNewmark, FusedNewmark, ImplicitNewmark, BatchedExplicit):
        for method in ("set_state", "step", "advance", "facts", "attach"):
            assert callable(getattr(cls, method, None)), f"{cls.__name__}.{method}"
    import numpy as np

    stepper = Newmark(lambda u, out: np.multiply(u, 1.0, out=out), np.ones(4), 0.1)
    assert isinstance(stepper, Stepper)
    stepper.set_state(np.ones(4), np.zeros(4))
    assert stepper.advance(3) == 3 and stepper.step_count == 3
    assert stepper.facts()["scheme"] == "explicit"
