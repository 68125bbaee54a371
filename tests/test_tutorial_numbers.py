"""Every number README.md and the tutorial state comes from one place that CI checks: the
scene file it describes, a run this test makes (the first run, N = 132, a few seconds), the
code's own defaults, or a committed facts file that ``benchmarks/doc_facts.py`` regenerates
(``docs/facts/tutorial_census.json`` from the tutorial's census, minutes under ``mpirun``;
``docs/facts/timings.json``, the stated run times measured on a 2-core machine).

Each check below names a phrase of a page and where its numbers come from. The inventory
test then removes every checked phrase from the page and fails on any number with a unit,
count of attractors or time left over: a new number needs a source and a check.
docs/tutorial/attractors.md shows a census's printed report, whose wording the census command
owns: it is left out of the inventory.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FACTS = REPO / "docs" / "facts"
CENSUS = json.loads((FACTS / "tutorial_census.json").read_text())
TIMINGS = json.loads((FACTS / "timings.json").read_text())["cases"]
TUTORIAL = REPO / "docs" / "tutorial"
#: The pages whose every number is checked.
PAGES = ["README.md", *sorted(str(p.relative_to(REPO)) for p in TUTORIAL.glob("*.md")
                              if p.name != "attractors.md")]
#: A stated run time may miss the measured one by at most this factor either way (the
#: docs state times loosely, "about 10 s"; a shared machine moves a run by some 30 %).
TIME_FACTOR = 1.5
WORDS = ["no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten"]
SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _comments(block: re.Match) -> str:
    """A shell block's comments (statements; its commands are checked by parsing)."""
    if block[1] not in ("bash", "sh"):
        return " "
    found = (re.search(r"(?:^|\s)# (.*)$", ln) for ln in block[2].splitlines())
    return " " + " ".join(m[1] for m in found if m) + " "


def prose(page: str) -> str:
    """The page's statements: its text and its shell blocks' comments, without inline code,
    link targets and other code blocks, whitespace collapsed (the commands are checked by
    parsing, test_readme.py; printed output by running it, below)."""
    text = re.sub(r"```(\w*)\n(.*?)```", _comments, (REPO / page).read_text(), flags=re.S)
    text = re.sub(r"`[^`]*`", " ", text)
    text = re.sub(r"\]\([^)]*\)", "]", text)  # link targets (anchors hold numbers)
    return re.sub(r"\s+", " ", text)


def power(x: float) -> str:
    """1e-3 -> '10⁻³', 1.135e-5 -> '1.135 · 10⁻⁵' (the pages' notation)."""
    mant, exp = f"{x:.3e}".split("e")
    mant = f"{float(mant):g}"
    head = "" if mant == "1" else f"{mant} · "
    return f"{head}10{str(int(exp)).translate(SUPERSCRIPT)}"


def about(page_seconds: float, key: str) -> None:
    """A stated time (s) is within TIME_FACTOR of the measured one (timings.json)."""
    measured = TIMINGS[key]["seconds"]
    assert measured / TIME_FACTOR <= page_seconds <= measured * TIME_FACTOR, \
        f"the page says {page_seconds:g} s, {key} measured {measured:g} s " \
        "(./dev python3 benchmarks/doc_facts.py timings)"


def load(name: str):
    from stickslip.solver.scene import load_scene

    return load_scene(name)


# ------------------------------------------------------------------ the census facts

def member(n: str, cls: str, k: int | None = None) -> dict:
    found = [m for m in CENSUS["meshes"][n]["members"]
             if m["class"] == cls and (k is None or m["k"] == k)]
    assert len(found) == 1, (n, cls, k, found)
    return found[0]


def main_wave(n: str) -> dict:
    """The rigid wave that most starts of mesh ``n`` reach."""
    return max((m for m in CENSUS["meshes"][n]["members"] if m["class"] == "wave"),
               key=lambda m: m["count"])


def census_phrases() -> list[str]:
    """The README's sentences on the tutorial's census, built from the facts file."""
    scene = load(CENSUS["scene"])
    big, small = sorted(CENSUS["meshes"], key=int)[::-1]
    wave = max((m for m in CENSUS["meshes"][big]["members"] if m["class"] == "wave"),
               key=lambda m: m["count"])
    others = [m for m in CENSUS["meshes"][big]["members"]
              if m["class"] == "wave" and m is not wave]
    rejected = [m for m in CENSUS["meshes"][big]["members"] if m["class"] == "transient"]
    coarse = [m for m in CENSUS["meshes"][small]["members"] if m["class"] == "wave"
              and (m["k"], m["direction"]) == (wave["k"], wave["direction"])]
    seed, coarse_count = CENSUS["seed"], sum(m["count"] for m in coarse)
    return [
        f"Ω = {scene.loading.omega:g} rad/s, δ = {power(scene.geometry.delta)}, "
        f"f = {scene.loading.f:g}",
        f"{CENSUS['starts']} random starts (seeds {seed} … {seed + CENSUS['starts'] - 1}), "
        f"first leg {CENSUS['first_leg_s']:g} s, continued up to {CENSUS['max_time_s']:g} s",
        f"at N = {big} (Δt = {power(CENSUS['meshes'][big]['dt_s'])} s), {wave['count']} settle "
        f"by {wave['settle_time_s_max']:.2f} s on the rigid k = {wave['k']} wave against the "
        f"rotation ({wave['celerity_m_s']:.1f} m/s, {wave['frequency_hz']:.0f} Hz, certified "
        f"stable)".replace("-", "−"),
        "; ".join(f"{m['count']} on the rigid k = {m['k']} ({m['celerity_m_s']:.1f} m/s, also "
                  "certified stable)".replace("-", "−") for m in others),
        ", ".join(f"{m['count']} on a k = {m['k']} that failed a certificate"
                  for m in rejected),
        f"at N = {small} (Δt = {power(CENSUS['meshes'][small]['dt_s'])} s) "
        f"{WORDS[CENSUS['meshes'][small]['attractors']]} attractors, the rigid k = {wave['k']} "
        f"from {coarse_count} start" + ("" if coarse_count == 1 else "s"),
    ]


def test_the_census_facts_are_one_finished_census():
    assert CENSUS["finished"] is True and CENSUS["command"].endswith(
        f"--starts {CENSUS['starts']} --meshes {','.join(sorted(CENSUS['meshes'], key=int))}")
    for n, mesh in CENSUS["meshes"].items():
        assert sum(m["count"] for m in mesh["members"]) == mesh["counted_starts"] \
            == CENSUS["starts"], n
        assert mesh["attractors"] == sum(m["class"] in ("wave", "multi-wave", "chaotic")
                                         for m in mesh["members"])
        for m in mesh["members"]:
            if m["class"] == "transient":  # failed a certificate: never certified stable
                assert m["stable"] is not True, m
    assert main_wave(max(CENSUS["meshes"], key=int))["stable"] is True


def test_readme_quotes_the_census_facts():
    text = prose("README.md")
    for phrase in census_phrases():
        assert phrase in text, f"README.md should say: {phrase}"
    assert CENSUS["command"] in (REPO / "README.md").read_text()


def test_the_census_tutorial_quotes_the_census_facts():
    """docs/tutorial/attractors.md's summary of the tutorial census: the settle times of the
    N = 264 attractor (to the 0.01 s printed) and the number of attractors at N = 132, from
    the same facts file as README."""
    text = prose("docs/tutorial/attractors.md")
    wave = main_wave("264")
    low, high = wave["settle_time_s_min"], wave["settle_time_s_max"]
    assert f"settled by {low:.2f} – {high:.2f} s" in text
    words = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five", 6: "six"}
    assert f"N = 132 shows {words[CENSUS['meshes']['132']['attractors']]} attractors" in text
    assert f"from {wave['count']} of {CENSUS['starts']} starts" in text


# ------------------------------------------------------------------ the checks per page

@dataclass
class Check:
    """``pattern`` (regex on the page's prose) and what its match must satisfy."""

    page: str
    pattern: str
    verify: object = None  # callable(match) -> None, asserting

    def matches(self) -> list[re.Match]:
        return list(re.finditer(self.pattern, prose(self.page)))


def _scene_check(name: str, **want) -> object:
    def verify(_m: re.Match) -> None:
        s = load(name)
        got = {"R": s.geometry.R, "R_outer": s.geometry.R * s.geometry.xi,
               "delta": s.geometry.delta, "omega": s.loading.omega, "f": s.loading.f,
               "n": s.mesh.n_inner, "beta2": s.time.beta2, "end_time": s.time.end_time,
               "loss": s.damping.loss_factor, "f_ref": s.damping.reference_frequency_hz}
        for k, v in want.items():
            assert math.isclose(got[k], v, rel_tol=1e-12), (name, k, got[k], v)
    return verify


def _paper_scenes_undamped(_m: re.Match) -> None:
    for path in sorted((REPO / "scenes").glob("figure*.toml")):
        if "damped" not in path.stem:
            s = load(str(path))
            assert s.time.beta2 == 0.6 and s.damping.tau == 0.0, path.name


def _damped_scenes(_m: re.Match) -> None:
    for path in sorted((REPO / "scenes").glob("figure*_damped.toml")):
        s = load(str(path))
        assert (s.time.beta2, s.damping.loss_factor, s.damping.reference_frequency_hz) \
            == (0.5, 0.02, 1600.0), path.name


def _progress_interval(m: re.Match) -> None:
    import inspect

    from stickslip.solver.observers import Progress

    default = inspect.signature(Progress).parameters["interval"].default
    assert float(m[1]) == default


def _plot_window(m: re.Match) -> None:
    from stickslip.postprocess.plotting import DEFAULT_WINDOW

    assert DEFAULT_WINDOW == f"{m[1]}T"


def _flutter_fmax(m: re.Match) -> None:
    from stickslip.cli.main import build_parser

    ns = build_parser().parse_args(["flutter-fe", "figure3_n132"])
    assert ns.fmax_hz == 1e3 * float(m[1])


def _estimate_accuracy(m: re.Match) -> None:
    """The pre-run estimate (``studies.resources``, computed now: a change of the cost model
    is checked) against the runs' own wall times measured on both Figure-3 scenes
    (benchmarks/doc_facts.py timings)."""
    from benchmarks.doc_facts import TIMED, pre_run_estimate

    for key in ("figure3_n132", "figure3_n264", "damped_n132", "damped_n264"):
        ratio = pre_run_estimate(TIMED[key][0]).seconds / TIMINGS[key]["best"]["run_wall_s"]
        assert abs(ratio - 1.0) <= float(m[1]) / 100.0, (key, ratio)


def _regime_map(m: re.Match) -> None:
    """The sweep's scene count and scenes (its file), and its time (a range: the map's
    figure and a shared machine move it most)."""
    import tomllib

    sweep = tomllib.loads((REPO / "sweeps" / "omega_delta_damped.toml").read_text())
    assert math.prod(len(v) for v in sweep["grid"].values()) == int(m[1])
    scene = load(str(REPO / "scenes" / "figure3_n132_damped.toml"))
    assert (scene.mesh.n_inner, scene.time.end_time) == (132, 0.3)
    measured = TIMINGS["regime_map"]["seconds"]
    assert 60.0 * float(m[2]) / TIME_FACTOR <= measured <= 60.0 * float(m[3]) * TIME_FACTOR


def _start_up(m: re.Match) -> None:
    """The command's time beyond the run's own wall (imports, the scene, the exit)."""
    for key in ("damped_n132", "damped_n264", "damped_n528"):
        best = TIMINGS[key]["best"]
        extra = best["process_s"] - best["run_wall_s"]
        assert float(m[1]) / TIME_FACTOR <= extra <= float(m[1]) * TIME_FACTOR, (key, extra)


def _docker_uid(m: re.Match) -> None:
    assert f"--uid {m[1]} stickslip" in (REPO / "Dockerfile").read_text()


def _mpirun_kill_wait(m: re.Match) -> None:
    assert f"{m[1]} s later, SIGKILL" in (REPO / "docker" / "bin" / "mpirun").read_text()


CHECKS = [
    # README
    Check("README.md", r"The run takes about (\d+) s on one core",
          lambda m: about(float(m[1]), "main_job")),
    Check("README.md", r"against the rotation at about (\d+) m/s", "first_run_celerity"),
    Check("README.md", r"no physical dissipation, β₂ = 0\.6", _paper_scenes_undamped),
    Check("README.md", r"Kelvin–Voigt (?:loss )?2 % at 1\.6 kHz, β₂ = ½", _damped_scenes),
    Check("README.md", r"β₂ = ½, Kelvin–Voigt 2 % at 1\.6 kHz", _damped_scenes),
    *[Check("README.md", re.escape(p), None) for p in census_phrases()],
    # the first run
    Check("docs/tutorial/first-run.md",
          r"inner radius R = 1 m and outer radius 1\.25 m, clamped outside, pressed on a "
          r"cylinder of radius R\(1 \+ δ\), δ = 4·10⁻⁴, that turns at Ω = 50 rad/s with "
          r"friction f = 0\.7; 132 nodes on the contact circle, explicit Newmark β₂ = 0\.6, "
          r"0\.3 s of physical time",
          _scene_check("figure3_n132", R=1.0, R_outer=1.25, delta=4e-4, omega=50.0, f=0.7,
                       n=132, beta2=0.6, end_time=0.3)),
    Check("docs/tutorial/first-run.md", r"a progress line every (\d+) s", _progress_interval),
    Check("docs/tutorial/first-run.md", r"within (\d+) % of the run's own wall time at "
          r"N = 132 and 264", _estimate_accuracy),
    Check("docs/tutorial/first-run.md", r"It takes about (\d+) s on one core",
          lambda m: about(float(m[1]), "main_job")),
    # the figures
    Check("docs/tutorial/figures.md", r"The last (\d+) periods by default", _plot_window),
    Check("docs/tutorial/figures.md", r"\((\d+) % of the cylinder's work here\)",
          "first_run_algorithmic"),
    # the travelling wave
    Check("docs/tutorial/travelling-wave.md", r"started at -2300 m/s: about (\d+) s",
          lambda m: about(float(m[1]), "travel_k4")),
    # the CEA
    Check("docs/tutorial/cea.md", r"unstable modes up to (\d+) kHz", _flutter_fmax),
    # the regime map
    Check("docs/tutorial/regime-map.md",
          r"Its (\d+) scenes \(N = 132, 0\.3 s each\) and the map take (\d+) – (\d+) min under",
          _regime_map),
    # the how-to on settings (not in the inventory: its accuracy columns are
    # benchmarks/convergence.py's), its wall times
    *[Check("docs/howto/choose-settings.md", rf"\| {n} \| {f} \| (\d+) \|",
            lambda m, key=key: about(float(m[1]), key))
      for n, f, key in ((132, r"0\.9", "damped_n132"), (264, r"0\.9", "damped_n264"),
                        (264, r"0\.45", "damped_n264_dt045"), (528, r"0\.9", "damped_n528"),
                        (1056, r"0\.9", "damped_n1056"))],
    Check("docs/howto/choose-settings.md", r"adds about (\d+) s of start-up", _start_up),
    # Docker
    Check("docs/tutorial/docker.md", r"the non-root user \(uid (\d+)\)", _docker_uid),
    Check("docs/tutorial/docker.md", r"kills the ranks (0\.25) s after", _mpirun_kill_wait),
]


@pytest.mark.parametrize("check", [c for c in CHECKS if not isinstance(c.verify, str)],
                         ids=lambda c: f"{c.page}:{c.pattern[:40]}")
def test_every_checked_phrase_is_on_its_page_and_true(check):
    found = check.matches()
    assert found, f"{check.page} no longer says /{check.pattern}/"
    for m in found:
        if check.verify is not None:
            check.verify(m)


#: A number a reader takes as a measured or stated quantity: with a unit, or a count of
#: attractors or of starts.
UNITS = r"(?:%|s|ms|min|minutes?|hours?|h|Hz|kHz|m/s|rad/s|m|MB|GB|kB|x|×|times)"
QUANTITY = re.compile(
    rf"(?<![\w.·])(?:\d[\d.,]*|{'|'.join(WORDS[1:])})\s?(?:·\s?10[⁻⁰-⁹]+\s?)?{UNITS}(?![\w/])"
    rf"|\b(?:{'|'.join(WORDS[1:])}|\d+) (?:\w+ )?(?:attractors?|others)\b"
    rf"|\b\d+ (?:of \d+ |\w+ )?starts?\b")


@pytest.mark.parametrize("page", PAGES)
def test_no_page_states_an_unchecked_number(page):
    text = prose(page)
    for check in CHECKS:
        if check.page == page:
            text = re.sub(check.pattern, " ", text)
    left = [m[0] for m in QUANTITY.finditer(text)]
    assert not left, f"{page} states {left} with no check in tests/test_tutorial_numbers.py"


def test_the_tutorial_index_promises_no_time_it_cannot_keep():
    text = prose("docs/tutorial/index.md")
    assert not re.search(r"seconds to a minute|a few minutes", text)


# ------------------------------------------------------------------ the first run

@pytest.fixture(scope="module")
def first_run(tmp_path_factory):
    """The tutorial's first run (README's main job without the pictures)."""
    pytest.importorskip("dolfinx")
    out = tmp_path_factory.mktemp("first_run") / "figure3_n132"
    res = subprocess.run([sys.executable, "-m", "stickslip.cli.main", "run",
                          "scenes/figure3_n132.toml", "-o", str(out)], cwd=REPO,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    return res.stdout, json.loads((out / "summary.json").read_text())


def test_the_first_run_prints_what_the_tutorial_shows(first_run):
    """The printed block of first-run.md, line for line (the estimate line up to its '...');
    the estimate's step count within the few per cent the page promises."""
    stdout, summary = first_run
    page = (TUTORIAL / "first-run.md").read_text()
    block = re.search(r"```text\n(.*?)```", page, flags=re.S)[1].splitlines()
    printed = [ln.strip() for ln in stdout.splitlines()]
    for line in block:
        line = line.strip()
        if line.endswith("..."):
            assert any(p.startswith(line[:-3]) for p in printed), line
        else:
            assert line in printed, f"first-run.md shows {line!r}; the run printed:\n{stdout}"
    est = int(re.search(r"~(\d+) steps", stdout)[1])
    assert abs(est / summary["steps"] - 1.0) < 0.1  # "a few per cent off"


def test_the_first_runs_numbers_on_the_pages(first_run):
    _, summary = first_run
    assert summary["regime"] == "stick-slip-separation" and summary["mode"] == 4
    c = summary["celerity_m_s"]
    for m in Check("README.md", r"against the rotation at about (\d+) m/s").matches():
        assert c < 0 and abs(-c / float(m[1]) - 1.0) < 0.05, (c, m[0])  # "about": 5 %
    e = summary["energy"]
    share = -e["balance_residual_J_per_m"] / e["work_cylinder_J_per_m"]  # β₂ = 0.6's loss
    for m in Check("docs/tutorial/figures.md", r"\((\d+) % of the cylinder's work here\)"
                   ).matches():
        assert round(100 * share) == int(m[1]), share


def test_the_refused_value_is_printed_as_the_page_shows():
    """parameters.md's error line is what ``stickslip run`` prints (before any meshing)."""
    page = (TUTORIAL / "parameters.md").read_text()
    shown = re.search(r"```text\n(error: .*?)\n```", page, flags=re.S)[1]
    res = subprocess.run([sys.executable, "-m", "stickslip.cli.main", "run",
                          "scenes/figure3_n132.toml", "--set", "loading.f=-1"], cwd=REPO,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and res.stderr.strip() == shown
