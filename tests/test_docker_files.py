"""The Dockerfile and ./dev install the same stack (static checks; docker/test-image.sh builds
and runs the image for real, in CI).

The Dockerfile's package pipeline and ./dev's ``packages()`` are both extracted and run with
bash on docker/apt-packages.txt; they must produce the same list. The image must accept
``docker run IMAGE stickslip ...`` and ``docker run IMAGE mpirun -n 4 stickslip ...``.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DOCKERFILE = REPO / "Dockerfile"
DEV = REPO / "dev"
APT_LIST = REPO / "docker" / "apt-packages.txt"


def _instructions() -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) of the Dockerfile, continuation lines joined."""
    text = re.sub(r"\\\n", " ", DOCKERFILE.read_text())
    out = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            word, _, rest = line.partition(" ")
            out.append((word.upper(), rest.strip()))
    return out


def _env() -> dict[str, str]:
    env: dict[str, str] = {}
    for word, rest in _instructions():
        if word == "ENV":
            for item in shlex.split(rest):
                key, _, value = item.partition("=")
                env[key] = value
    return env


def _source_folder(package: str) -> Path:
    """The source folder of an installed package name, by pyproject.toml's package-dir
    (``stickslip.solver.scene`` -> ``solver/scene``)."""
    package_dir = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-dir"]
    head, tail = package, []
    while head not in package_dir:
        head, _, last = head.rpartition(".")
        tail.insert(0, last)
    return REPO / package_dir[head] / Path(*tail)


def _bash(script: str) -> list[str]:
    res = subprocess.run(["bash", "-c", script], capture_output=True, text=True, check=True)
    return res.stdout.split()


def test_dockerfile_and_dev_install_the_same_apt_packages():
    # The Dockerfile copies the list and pipes it through sed | grep into apt-get install.
    copies = [rest.split() for word, rest in _instructions() if word == "COPY"]
    dst = next(c[-1] for c in copies if c[-2] == "docker/apt-packages.txt")
    run = next(rest for word, rest in _instructions() if word == "RUN" and dst in rest)
    pipeline = re.search(r"&&\s*(sed .*?)\|\s*xargs apt-get install", run)
    assert pipeline, run
    docker_pkgs = _bash(pipeline.group(1).replace(dst, shlex.quote(str(APT_LIST))))
    # ./dev: PKG_LIST is docker/apt-packages.txt and packages() filters it.
    dev = DEV.read_text()
    assert 'PKG_LIST="$REPO/docker/apt-packages.txt"' in dev
    body = re.search(r"^packages\(\) \{(.*)\}$", dev, re.M)
    assert body, "packages() not found in ./dev"
    dev_list = REPO / "docker" / "dev-packages.txt"
    dev_pkgs = _bash(f"PKG_LIST={shlex.quote(str(APT_LIST))}; "
                     f"DEV_PKG_LIST={shlex.quote(str(dev_list))}; {body.group(1)}")
    # ./dev adds the development-only list (tests, docs) after the users' list
    dev_only = _bash(f"sed -e 's/#.*//' -e 's/[[:space:]]//g' {shlex.quote(str(dev_list))}")
    assert dev_pkgs == docker_pkgs + dev_only
    assert 'DEV_PKG_LIST="$REPO/docker/dev-packages.txt"' in dev
    # The list holds the stack the sweep needs: dolfinx, MPI launcher, mpi4py, matplotlib.
    assert {"python3-dolfinx", "mpi-default-bin", "python3-mpi4py",
            "python3-matplotlib"} <= set(dev_pkgs)
    # The pip extras come from the same file too.
    assert 'DEV_REQS="$REPO/docker/dev-requirements.txt"' in dev
    assert any(c[-2] == "docker/dev-requirements.txt" for c in copies)


def test_every_copied_path_exists():
    for word, rest in _instructions():
        if word == "COPY":
            sources = [a for a in rest.split() if not a.startswith("--")][:-1]
            for src in sources:
                assert (REPO / src).exists(), f"COPY {src}: missing"


def test_docker_run_image_stickslip_and_mpirun():
    ins = _instructions()
    # No ENTRYPOINT (or a pass-through one): `docker run IMAGE CMD...` runs CMD itself, so
    # both `docker run IMAGE stickslip ...` and `docker run IMAGE mpirun -n 4 ...` work.
    entry = [rest for word, rest in ins if word == "ENTRYPOINT"]
    assert not entry or json.loads(entry[-1]) in ([], ["/usr/bin/env"]), entry
    cmd = json.loads([rest for word, rest in ins if word == "CMD"][-1])
    assert cmd[0] == "stickslip"
    # `stickslip` on PATH: the project is pip-installed (not editable) with its console script,
    # whose module is a file of the project.
    assert any(word == "RUN" and "pip install" in rest and "/opt/stickslip" in rest
               and " -e " not in rest for word, rest in ins)
    scripts = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["stickslip"] == "stickslip.cli.main:main"
    module, _, func = scripts["stickslip"].partition(":")
    package, _, name = module.rpartition(".")
    source = _source_folder(package) / name
    assert func and (source.with_suffix(".py").is_file() or (source / "__init__.py").is_file())
    # Non-root by default; mpirun as root allowed (`--user root`) and -n 4 on fewer cores.
    users = [rest for word, rest in ins if word == "USER"]
    assert users and users[-1] not in ("root", "0")
    env = _env()
    for key in ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM",
                "PRTE_ALLOW_RUN_AS_ROOT", "PRTE_ALLOW_RUN_AS_ROOT_CONFIRM"):
        assert env.get(key) == "1", key
    assert "oversubscribe" in env.get("PRTE_MCA_rmaps_default_mapping_policy", "")
    # Same OpenMPI settings as ./dev, installed where OpenMPI reads them by default.
    assert any(word == "COPY" and rest.split() == ["docker/openmpi-mca-params.conf",
                                                   "/etc/openmpi/openmpi-mca-params.conf"]
               for word, rest in ins)
    assert "docker/openmpi-mca-params.conf" in DEV.read_text()
    # mpirun's session directory in /tmp, in the image and in ./dev (not an unusable TMPDIR)
    assert env.get("PRTE_MCA_prte_tmpdir_base") == "/tmp"
    assert "PRTE_MCA_prte_tmpdir_base=/tmp" in DEV.read_text()
    # Default outputs go to a directory the non-root user owns.
    out = env.get("STICKSLIP_OUTPUT")
    assert out and any(word == "RUN" and f"chown {users[-1]} {out}" in rest
                       for word, rest in ins)


def test_sweeps_doc_shows_the_docker_mpirun_sweep():
    text = re.sub(r"\\\n\s*", " ", (REPO / "docs" / "sweeps.md").read_text())  # join "\"
    assert re.search(r"docker run [^\n]*-v [^\n]*mpirun -n 4 stickslip sweep /data/\S+\.toml",
                     text), "docs/sweeps.md must show docker run -v ... mpirun -n 4 ... sweep"


def _stages() -> list[tuple[str, str, list[tuple[str, str]]]]:
    """(name, parent, instructions) of each build stage, in order."""
    stages: list[tuple[str, str, list[tuple[str, str]]]] = []
    for word, rest in _instructions():
        if word == "FROM":
            parts = rest.split()
            name = parts[2] if len(parts) == 3 and parts[1].upper() == "AS" else ""
            stages.append((name, parts[0], []))
        elif stages:
            stages[-1][2].append((word, rest))
    return stages


def test_runtime_image_needs_nothing_outside_debian():
    """The default target (last stage) and the stages it builds on make no PyPI request: pip
    only installs the project, with --no-index; ruff comes only in the `dev` stage."""
    stages = _stages()
    by_name = {name: (parent, ins) for name, parent, ins in stages}
    name, parent, ins = stages[-1]
    assert name == "runtime"
    chain = list(ins)
    while parent in by_name:  # the runtime's ancestry, up to debian:trixie
        parent, more = by_name[parent]
        chain += more
    assert parent == "debian:trixie"
    pips = [rest for word, rest in chain if word == "RUN" and "pip install" in rest]
    assert pips and all("--no-index" in rest and "--no-deps" in rest for rest in pips), pips
    assert not any("dev-requirements" in rest for _, rest in chain)
    # The dev stage exists and installs the development tools.
    dev = by_name["dev"][1]
    assert any(word == "RUN" and "dev-requirements.txt" in rest for word, rest in dev)
    # The installed code finds the shipped scenes in the source tree copied to the image.
    copy_dst = next(rest.split()[-1] for word, rest in ins
                    if word == "COPY" and rest.startswith(". "))
    scenes = dict(item.partition("=")[::2] for word, rest in ins if word == "ENV"
                  for item in shlex.split(rest)).get("STICKSLIP_SCENES")
    assert scenes == f"{copy_dst}/scenes"
    # Documentation and apt's lists stay out of the image.
    stack_run = next(rest for word, rest in by_name["stack"][1]
                     if word == "RUN" and "apt-get install" in rest)
    assert "path-exclude=/usr/share/doc/*" in stack_run
    assert "rm -rf /var/lib/apt/lists/*" in stack_run


def test_build_context_leaves_out_git_and_outputs():
    ignored = (REPO / ".dockerignore").read_text().split()
    assert {".git", "runs", "**/__pycache__"} <= set(ignored)


def test_ci_runs_the_image_test_after_the_tests():
    """.ci/run: the README's test command, then docker/test-image.sh (which must parse)."""
    ci = (REPO / ".ci" / "run").read_text()
    lines = [ln.strip() for ln in ci.splitlines() if ln.strip() and not ln.startswith("#")]
    tests = next(i for i, ln in enumerate(lines) if "./dev bash tests/run.sh" in ln)
    image = next(i for i, ln in enumerate(lines) if "docker/test-image.sh" in ln)
    assert tests < image
    script = REPO / "docker" / "test-image.sh"
    subprocess.run(["bash", "-n", str(script)], check=True)
    text = script.read_text()
    # The recipe that works on hosts without a Docker daemon (see the script's header).
    for needle in ("docker info", "--runtime runc", "--storage-driver overlay",
                   "--ulimit nofile=", "debootstrap --variant=minbase trixie",
                   "sweeps/smoke4.toml", "mesh.n_inner=-1", "compare_summaries.py"):
        assert needle in text, needle


def test_smoke4_sweep_has_four_smoke_scenes():
    spec = tomllib.loads((REPO / "sweeps" / "smoke4.toml").read_text())
    assert (REPO / "sweeps" / spec["base"]).resolve() == REPO / "scenes" / "smoke.toml"
    n = 1
    for values in spec["grid"].values():
        n *= len(values)
    assert n == 4


def test_installed_code_finds_the_shipped_scenes_through_stickslip_scenes(tmp_path):
    """In the image the code is installed away from its source tree: STICKSLIP_SCENES says
    where the shipped scenes are (bare names like ``smoke`` resolve there)."""
    (tmp_path / "only_here.toml").write_text("")
    code = ("from stickslip.solver.scene import SCENES_DIR, list_scenes; "
            "print(SCENES_DIR, [p.name for p in list_scenes()])")
    # the project as the test suite sees it (./dev's editable install: its user site)
    env = {"PATH": "/usr/bin:/bin", "STICKSLIP_SCENES": str(tmp_path),
           **{k: v for k, v in os.environ.items() if k == "PYTHONUSERBASE"}}
    out = subprocess.run(["python3", "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout
    assert out.split()[0] == str(tmp_path) and "only_here.toml" in out


def test_pyproject_installs_every_package_of_the_source_tree():
    """The image installs the project (not editable): a package that pyproject's package list
    or discovery misses is missing there, and only the commands importing it fail
    (docker/test-image.sh checks the installed image; this catches it without one)."""
    setuptools = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    # the design card's folders are installed as stickslip.<folder> (package-dir)
    found = {".".join(p.parent.relative_to(REPO).parts) for p in REPO.rglob("__init__.py")
             if p.parent.relative_to(REPO).parts[0] not in ("tests", "benchmarks", "build")
             and not any(part.startswith(".") for part in p.relative_to(REPO).parts)}
    found = {name if name.startswith("stickslip") else f"stickslip.{name}" for name in found}
    listed = set(setuptools["packages"])
    assert listed == found, f"missing: {sorted(found - listed)}, extra: {sorted(listed - found)}"
    for name in listed:  # each listed name is read from the folder that holds it
        assert (_source_folder(name) / "__init__.py").is_file(), name
