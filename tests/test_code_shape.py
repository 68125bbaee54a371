"""Small, public, alive: the shape of the production code, read with :mod:`ast`.

* No function is longer than ``MAX_LINES`` lines (from ``def`` to its last line, docstring
  included), except the compiled kernels in ``KERNELS``: a numba/CUDA kernel is one compiled
  call, so its step cannot be split into Python helpers without a call per node or a second
  compiled function in the hot loop.
* No module imports a private name (``_name``, dunders aside) or a private module from another
  top-level package: what one package uses of another is public.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("meshes", "forms", "semianalytic", "exact", "solver", "postprocess", "studies",
            "cli", "stickslip")
MAX_LINES = 80

#: (module path, function name) of the compiled kernels allowed over ``MAX_LINES``.
KERNELS = {
    # numba @njit: one explicit Newmark step with the contact projection at the contact nodes
    ("solver/_fused_kernels.py", "single_step"),
    # numba @njit: the batched step of B scenes (one column per scene), 4-scene passes
    ("solver/_fused_kernels.py", "batched_step"),
    # numba @njit: the same step in B-long vector loops (a long batch; the same bits)
    ("solver/_fused_kernels.py", "batched_step_long"),
}


def _sources() -> dict[str, ast.Module]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((REPO / pkg).rglob("*.py")):
            out[path.relative_to(REPO).as_posix()] = ast.parse(path.read_text(), str(path))
    return out


SOURCES = _sources()


def _long_functions(sources: dict[str, ast.Module]) -> list[tuple[str, str, int]]:
    """(module path, function name, lines) of every function over ``MAX_LINES`` lines."""
    found = []
    for rel, tree in sources.items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_LINES:
                    found.append((rel, node.name, lines))
    return found


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_imports(sources: dict[str, ast.Module]) -> list[str]:
    """``module: from X import _name`` lines that reach into another top-level package."""
    found = []
    for rel, tree in sources.items():
        own = rel.split("/")[0]
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom) or node.level or not node.module:
                continue
            parts = node.module.split(".")
            if parts[0] == "stickslip" and len(parts) > 1 and parts[1] in PACKAGES:
                parts = parts[1:]  # the installed spelling of a folder: stickslip.<folder>
            module = ".".join(parts)
            if parts[0] == own or parts[0] not in PACKAGES:
                continue
            names = [a.name for a in node.names if _is_private(a.name)]
            if any(_is_private(p) for p in parts):
                names.append(f"(module {module})")
            found += [f"{rel}:{node.lineno}: from {module} import {n}" for n in names]
    return found


def test_the_packages_are_read():
    assert len(SOURCES) > 50
    assert all(any(rel.startswith(f"{pkg}/") for rel in SOURCES) for pkg in PACKAGES)


def test_no_function_is_over_80_lines_except_the_kernels():
    long = [(rel, name, n) for rel, name, n in _long_functions(SOURCES)
            if (rel, name) not in KERNELS]
    assert not long, f"split into named steps (<= {MAX_LINES} lines each): {long}"


def test_the_kernel_exemptions_name_existing_long_kernels():
    """An exemption that no longer applies (renamed, or split) is removed from the list."""
    long = {(rel, name) for rel, name, _ in _long_functions(SOURCES)}
    assert KERNELS <= long, KERNELS - long


def test_no_private_name_is_imported_across_packages():
    found = _private_imports(SOURCES)
    assert not found, "make these public or move them where they are used:\n" + "\n".join(found)


@pytest.mark.parametrize("check", ["long", "private"])
def test_the_checker_sees_a_violation(check):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_LINES))
    sources = {
        "studies/a.py": ast.parse(f"def f():\n{body}\n"),
        "cli/b.py": ast.parse("from stickslip.studies.a import _helper\n"
                              "from stickslip.solver._k import step\n"
                              "from stickslip.cli.c import _own\n"
                              "from stickslip.solver import __version__\n"),
    }
    if check == "long":
        assert _long_functions(sources) == [("studies/a.py", "f", MAX_LINES + 1)]
    else:
        assert _private_imports(sources) == [
            "cli/b.py:1: from studies.a import _helper",
            "cli/b.py:2: from solver._k import (module solver._k)",
        ]
