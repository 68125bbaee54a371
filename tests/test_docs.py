"""The documentation site: it builds with warnings as errors (Sphinx + MyST), the generated
references cover every scene key and every CLI option, no page links to a missing file,
and the literate demos run (sphinx-gallery executes each one during the build)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

import stickslip_reference as reference  # noqa: E402

#: Files of the docs tree that users read (the generated gallery output is checked by Sphinx).
PAGES = sorted(p for p in DOCS.rglob("*.md")
               if "_build" not in p.parts and p.parent.name != "demos")
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")


def _links(page: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # not inside code blocks
    return [a or b for a, b in LINK.findall(text)]


def test_every_scene_key_is_in_the_scene_reference(tmp_path):
    """Every key of a resolved scene.toml (the one ``stickslip run`` writes) has a row."""
    from stickslip.solver.scene import dumps_toml, load_scene

    page = reference.scene_markdown()
    resolved = tomllib.loads(dumps_toml(load_scene("figure3_n132_damped")))
    keys = [k for k, v in resolved.items() if not isinstance(v, dict)]
    keys += [f"{s}.{k}" for s, t in resolved.items() if isinstance(t, dict) for k in t]
    assert len(keys) >= 40  # 2 top-level keys and 38 in the nine sections today
    for key in keys:
        assert f"| `{key}` |" in page, key
    assert "| `loading.f` | number | `0.7` | 0 &lt;= f &lt;= 1e3" in page  # type, default and range


def test_every_cli_command_and_option_is_in_the_command_reference():
    import argparse

    from stickslip.cli.main import build_parser

    page = reference.cli_markdown()
    commands = reference._subcommands(build_parser())
    assert {"run", "sweep", "travel", "flutter-fe", "wave"} <= set(commands)
    for name, sub in commands.items():
        assert f"## `stickslip {name}`" in page, name
        section = page.split(f"## `stickslip {name}`", 1)[1].split("\n## ", 1)[0]
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            for opt in action.option_strings or [action.dest]:
                assert f"`{opt}`" in section, (name, opt)


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(DOCS)) for p in PAGES])
def test_no_page_links_to_a_missing_file(page):
    for target in _links(page):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue  # a web address or an anchor on the same page
        path = target.split("#", 1)[0]
        resolved = (page.parent / path).resolve()
        # a page the build writes (the references, the demos' gallery) is not in git: a
        # Markdown link to it is dead on GitHub; the {doc} role names it for the site
        assert resolved.name not in GENERATED and DOCS / "demos" not in resolved.parents, \
            f"{page.relative_to(REPO)} links to the generated {target}: use {{doc}}`...`"
        assert resolved.exists(), f"{page.relative_to(REPO)} links to {target}"


def test_readme_links_exist():
    readme = REPO / "README.md"
    for target in _links(readme):
        if not re.match(r"[a-z]+:", target) and not target.startswith("#"):
            assert (REPO / target.split("#", 1)[0]).exists(), target


def test_docs_carry_no_history():
    """Docs are for users: no session, attempt or issue numbers (they live in git)."""
    pattern = re.compile(r"\b(session|attempt)s?\b|\bissue \d+|\(issue|#\d{2,}\b", re.I)
    for page in [*PAGES, REPO / "README.md"]:
        for n, line in enumerate(page.read_text().splitlines(), 1):
            assert not pattern.search(line), f"{page.relative_to(REPO)}:{n}: {line.strip()}"


#: Pages written by the build (docs/_ext/stickslip_reference.py), not kept in git.
GENERATED = {"cli.md", "scene.md"}

#: The budget of the user docs (Markdown, generated reference pages excepted): the whole site,
#: and any one page (a page past it is a log or a study, which belongs in archive/). It holds
#: the tutorials, how-tos, theory and evidence pages of every command, with room for a
#: page's new table, not for run logs (348.3 kB: the birth of a two-wave state and its step
#: dependence at P and Figure 3, the census's sideband test with P's ladder rows it changed,
#: P's and Figure 3's degree-2 rungs that check "degree 2 is a rung ahead" at two more
#: points, the 8 s cap that shows the tutorial's chaotic start to be transient chaos, and the
#: 3D tube at N_theta = 264).
DOCS_BYTES, PAGE_BYTES = 348_300, 36_000


def test_user_docs_stay_small():
    """docs/ holds what a user reads: the pages within the budget, no raw run logs."""
    pages = [p for p in DOCS.rglob("*.md") if p.name not in GENERATED
             and "_build" not in p.parts and "auto_demos" not in p.parts]
    sizes = {str(p.relative_to(DOCS)): p.stat().st_size for p in pages}
    assert sum(sizes.values()) < DOCS_BYTES, f"{sum(sizes.values())} bytes of Markdown"
    large = {k: v for k, v in sizes.items() if v > PAGE_BYTES}
    assert not large, f"pages over {PAGE_BYTES} bytes: {large}"
    assert not list(DOCS.glob("*.jsonl")), "raw run logs belong in archive/"


@pytest.mark.dolfinx
def test_the_site_builds_with_warnings_as_errors_and_runs_the_demos(tmp_path):
    """``sphinx-build -W``: a broken link, a missing page, a bad docstring or a failing
    demo fails the build. The demos run inside the build (sphinx-gallery)."""
    pytest.importorskip("dolfinx")
    pytest.importorskip("sphinx_gallery")
    out = tmp_path / "html"
    env = dict(os.environ, STICKSLIP_OUTPUT=str(tmp_path / "runs"), MPLBACKEND="Agg",
               STICKSLIP_DOCS_RERUN="1", STICKSLIP_DOCS_DEMOS="1")
    res = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b",
                          "html", "-d", str(tmp_path / "doctrees"), str(DOCS), str(out)],
                         cwd=REPO, env=env, capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr[-4000:]
    for page in ("index.html", "tutorial/first-run.html", "reference/scene.html",
                 "reference/cli.html", "reference/api.html", "reference/output-files.html"):
        assert (out / page).stat().st_size > 5_000, page
    demos = sorted((out / "demos").glob("demo_*.html"))
    assert len(demos) >= 5
    images = list((out / "_images").glob("sphx_glr_demo_*.png"))
    assert len(images) >= 5, "each demo renders its figures"
