"""Sphinx extension: the command and scene-key references, generated from the code.

* ``reference/cli.md``: every ``stickslip`` command with its usage, description and options,
  read from the argparse parser (``cli.main.build_parser``);
* ``reference/scene.md``: every scene key with its type, default, unit, range and meaning,
  read from the scene dataclasses (``solver.scene.sections``): the attribute docstrings for
  the meaning and unit, the ``_check`` methods for the ranges and allowed values.

Both pages are written when the build starts (``builder-inited``) and are not kept in git.
``python3 docs/_ext/stickslip_reference.py OUT_DIR`` writes them without Sphinx.
"""

from __future__ import annotations

import argparse
import ast
import inspect
import re
import sys
import textwrap
from dataclasses import MISSING, fields
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


#: A code span: ``x`` (the docstrings' literal) or `x` (Markdown's), read as one piece.
CODE_SPAN = re.compile(r"(``.+?``|`[^`]+`)")


def _cell(text: str, table: bool = True) -> str:
    """Docstring text as Markdown: one line, no raw HTML, no stray emphasis. Outside code
    spans ``*``, ``_`` and ``<`` are escaped, so a formula such as p_{i-1} + 2 p_i is not read
    as italics; inside them the text is kept as written. ``table``: the text goes in a table
    cell, where ``|`` ends the cell even inside code and is escaped everywhere."""
    pieces = CODE_SPAN.split(" ".join(str(text).split()))
    for i in range(0, len(pieces), 2):  # the even pieces are outside code spans
        for raw, escaped in (("\\", "\\\\"), ("*", "\\*"), ("_", "\\_"), ("<", "&lt;")):
            pieces[i] = pieces[i].replace(raw, escaped)
    text = "".join(pieces)
    return text.replace("|", "\\|") if table else text


# ------------------------------------------------------------------------------ the CLI


def _code(value: object) -> str:
    """``value`` as inline code in a table cell: a ``|`` (``A|B`` metavars) escaped, as the
    table syntax needs even inside code."""
    return "`" + str(value).replace("|", "\\|") + "`"


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _option_rows(parser: argparse.ArgumentParser) -> list[str]:
    rows = []
    for a in parser._actions:
        if isinstance(a, argparse._HelpAction | argparse._SubParsersAction):
            continue
        names = ", ".join(f"`{s}`" for s in a.option_strings) or f"`{a.dest}`"
        if a.option_strings and a.nargs != 0:
            names += f" {_code(a.metavar or a.dest.upper())}"
        default = "" if a.default in (None, argparse.SUPPRESS, False, []) or not \
            a.option_strings else _code(a.default)
        choices = ", ".join(f"`{c}`" for c in a.choices) if a.choices else ""
        # what --help prints: argparse formats help strings (%(default)s, %% for %)
        helptext = (a.help or "").replace("%(default)s", str(a.default)).replace("%%", "%")
        rows.append(f"| {names} | {_cell(helptext)} | {default} | {choices} |")
    return rows


def cli_markdown() -> str:
    """The command reference, one section per subcommand, from the argparse parser."""
    sys.path.insert(0, str(REPO))
    from stickslip.cli.main import build_parser

    parser = build_parser()
    parser.prog = "stickslip"
    out = ["# Command reference", "",
           "Generated from the `stickslip` command's argparse parser: every command and "
           "option. `stickslip COMMAND --help` prints the same text.", "",
           "```text", parser.format_usage().strip(), "```", "",
           _cell(parser.description or "", table=False), ""]
    for name, sub in _subcommands(parser).items():
        sub.prog = f"stickslip {name}"
        rows = _option_rows(sub)
        table = (["| argument | meaning | default | choices |", "|---|---|---|---|", *rows]
                 if rows else ["No arguments."])
        out += [f"## `stickslip {name}`", "", _cell(sub.description or "", table=False), "",
                "```text", sub.format_usage().strip(), "```", "", *table, ""]
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------------------ the scene


def _attribute_docs(cls: type) -> dict[str, str]:
    """``{field: docstring}`` from the string literal that follows each annotated field."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body
    docs = {}
    for node, nxt in zip(body, body[1:], strict=False):
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and \
                isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant) and \
                isinstance(nxt.value.value, str):
            docs[node.target.id] = " ".join(nxt.value.value.split())
    return docs


def _string(node: ast.AST) -> str | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr):  # f-string: its literal parts
        return "".join(v.value for v in node.values if isinstance(v, ast.Constant))
    return None


def _rules(cls: type, module) -> dict[str, list[str]]:
    """``{field: [rule, ...]}`` read from ``cls._check``: ``_require(self._key("x"), v, ok,
    "rule")``, ``_choice(self._key("x"), v, ALLOWED)`` and ``check_range(self._key(name))``
    (``RANGES``), including the loop ``for name in (...)``."""
    from stickslip.solver.scene.values import RANGES

    section = cls.SECTION
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls._check)))
    rules: dict[str, list[str]] = {}
    loop_names: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.For) and isinstance(node.iter, ast.Tuple):
            loop_names = [e.value for e in node.iter.elts if isinstance(e, ast.Constant)]
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.args):
            continue
        key = node.args[0]
        names: list[str] = []
        if isinstance(key, ast.Call) and key.args:
            if isinstance(key.args[0], ast.Constant):
                names = [key.args[0].value]
            elif isinstance(key.args[0], ast.Name):
                names = loop_names
        fn = node.func.id
        for name in names:
            rule = None
            if fn == "_require" and len(node.args) >= 4:
                rule = _string(node.args[3])
            elif fn == "_choice" and len(node.args) >= 3:
                allowed = node.args[2]
                values = (getattr(module, allowed.id) if isinstance(allowed, ast.Name) else
                          ast.literal_eval(allowed))
                rule = "one of " + ", ".join(repr(v) for v in values)
            elif fn == "check_range" and f"{section}.{name}" in RANGES:
                rule = RANGES[f"{section}.{name}"].rule
            if rule and rule not in rules.setdefault(name, []):
                rules[name].append(rule)
    return rules


def _default(f) -> str:
    value = f.default if f.default is not MISSING else f.default_factory()  # type: ignore[misc]
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple):
        return "[" + ", ".join(repr(v) for v in value) + "]"
    if isinstance(value, float) and value != 0 and not 1e-3 <= abs(value) < 1e5:
        return f"{value:.6g}"  # 1e+09, not 1000000000.0
    return repr(value)


def _kind(f) -> str:
    return {"float": "number", "int": "integer", "str": "string", "bool": "boolean",
            "floats": "list of numbers"}.get(f.metadata.get("kind", ""), "")


def scene_markdown() -> str:
    """The scene-key reference, one table per section, from the dataclasses."""
    sys.path.insert(0, str(REPO))
    import stickslip.solver.scene.sections as sections
    from stickslip.solver.scene.model import Scene
    from stickslip.solver.scene.values import RANGES

    out = ["# Scene keys", "",
           "Generated from the scene dataclasses (`solver/scene/sections.py`). A scene is a "
           "TOML file; every table and key is optional and takes the default below. Units "
           "are SI. Unknown keys, wrong types and values out of range are refused when the "
           "scene is loaded, with the key, the value and the rule. Override any key on the "
           "command line with `--set section.key=value`, or in Python with "
           "`stickslip.load_scene(scene, {\"section.key\": value})`. A scene may start "
           "from another, as a sweep file does: `base = \"figure1_n132_damped\"` (a path "
           "relative to the file, or a shipped scene name) takes every key of that scene and "
           "the file's own keys replace them one by one (its `name` and `description` are "
           "not inherited).", "",
           "## Top level", "", "| key | type | default | meaning |", "|---|---|---|---|"]
    docs = {"description": "Free text saying what the scene is for.", **_attribute_docs(Scene)}
    for name in ("name", "description"):
        f = next(f for f in fields(Scene) if f.name == name)
        out.append(f"| `{name}` | {_kind(f)} | `{_default(f)}` | {_cell(docs.get(name, ''))} |")
    out.append("")
    alternatives = {"material": "`rho` (kg/m³) may be given instead of `wave_speed`: "
                    f"{RANGES['material.rho'].rule}.",
                    "geometry": "`d` (m) may be given instead of `delta`: "
                    f"{RANGES['geometry.d'].rule}."}
    for section, cls in sections._SECTIONS.items():
        docs = _attribute_docs(cls)
        rules = _rules(cls, sections)
        summary = " ".join((cls.__doc__ or "").split())
        out += [f"## `[{section}]`", "", _cell(summary, table=False), "",
                "| key | type | default | allowed | meaning |", "|---|---|---|---|---|"]
        for f in fields(cls):
            allowed = "; ".join(rules.get(f.name, []))
            out.append(f"| `{section}.{f.name}` | {_kind(f)} | `{_default(f)}` | "
                       f"{_cell(allowed)} | {_cell(docs.get(f.name, ''))} |")
        if section in alternatives:
            out += ["", alternatives[section]]
        out.append("")
    return "\n".join(out) + "\n"


def write_pages(out_dir: Path) -> list[Path]:
    """Write ``cli.md`` and ``scene.md`` into ``out_dir`` (only where the text changed, so
    an unchanged page is not rebuilt)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, text in (("cli.md", cli_markdown()), ("scene.md", scene_markdown())):
        path = out_dir / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
        written.append(path)
    return written


def _on_builder_inited(app) -> None:
    write_pages(Path(app.srcdir) / "reference")


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"parallel_read_safe": True, "parallel_write_safe": True}


if __name__ == "__main__":
    for p in write_pages(Path(sys.argv[1] if len(sys.argv) > 1 else REPO / "docs" / "reference")):
        print(p)
