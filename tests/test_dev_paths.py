"""./dev shows every path a command writes inside the rootfs, or refuses it.

``./dev --mounts CMD...`` prints the host directories that CMD would get bind-mounted. A fake
rootfs (a few directories and files under STICKSLIP_CACHE) stands in for the real one: the
rule is about which of its directories may be covered (missing or holding only directories)
and which may not (holding files, like /usr/lib), so no real rootfs is needed. Only paths
that do not exist on the host are named (nothing is created outside tmp_path).
"""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture()
def fake_cache(tmp_path: Path) -> Path:
    root = tmp_path / "cache" / "trixie"
    (root / "var" / "tmp").mkdir(parents=True)  # empty: may be covered
    (root / "var" / "lib").mkdir()
    (root / "var" / "lib" / "state").write_text("x")  # holds a file: must not be covered
    (root / "usr" / "lib").mkdir(parents=True)
    (root / "usr" / "lib" / "libc.so").write_text("x")
    (root / "usr" / "bin").mkdir()
    (root / "usr" / "bin" / "tool").write_text("x")
    return tmp_path / "cache"


def mounts(cache: Path, *args: str, cwd: str | Path = REPO, **env: str):
    e = {k: v for k, v in os.environ.items() if k != "STICKSLIP_OUTPUT"}
    e.update(STICKSLIP_CACHE=str(cache), **env)
    return subprocess.run([str(REPO / "dev"), "--mounts", *args], cwd=cwd, env=e,
                          capture_output=True, text=True, timeout=30)


def test_output_outside_the_repository_is_mounted_not_hidden(fake_cache):
    # `-o /var/tmp/x` used to land inside the rootfs: now /var/tmp is bind-mounted.
    res = mounts(fake_cache, "stickslip", "run", "scenes/smoke.toml", "-o", "/var/tmp/no-such-12/x")
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["/var/tmp"]
    res = mounts(fake_cache, "stickslip", "run", "--output=/var/tmp/no-such-12/y")
    assert res.stdout.split() == ["/var/tmp"]
    res = mounts(fake_cache, "true", STICKSLIP_OUTPUT="/var/tmp/no-such-12/runs")
    assert res.stdout.split() == ["/var/tmp"]


def test_repository_and_tmp_need_no_mount(fake_cache, tmp_path):
    res = mounts(fake_cache, "stickslip", "run", str(tmp_path / "a.toml"), "-o", "runs/x",
                 "./scenes/smoke.toml", "--set", "time.dt=1")
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == []


def test_a_path_that_would_hide_the_rootfs_is_refused_in_one_message(fake_cache):
    res = mounts(fake_cache, "stickslip", "run", "scenes/smoke.toml", "-o", "/usr/lib/no-such-12")
    assert res.returncode == 2
    assert "/usr/lib/no-such-12 cannot be shown inside the rootfs" in res.stderr
    assert "/tmp" in res.stderr  # the fix: where to write instead


def test_system_paths_of_the_rootfs_pass_and_the_root_cwd_is_refused(fake_cache):
    assert mounts(fake_cache, "/usr/bin/tool").returncode == 0
    res = mounts(fake_cache, "true", cwd="/")
    assert res.returncode == 2 and "working directory / cannot be shown" in res.stderr


SIGNAL_SCRIPT = """
import signal, sys, time
def handler(signum, frame):
    time.sleep(0.5)  # a final save in progress
    open(sys.argv[1], "w").write(str(signum))
    sys.exit(3)
signal.signal(signal.SIGINT, handler)
signal.signal(signal.SIGTERM, handler)
print("ready", flush=True)
time.sleep(60)
"""


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_signals_reach_the_command_and_dev_waits_for_it(tmp_path, signame):
    """Item 5: `./dev` forwards SIGINT/SIGTERM and returns only after the command ended.

    Through the rootfs path this needs the real rootfs (host only: inside it ./dev runs the
    command natively, also with exec, which is what is then checked).
    """
    import signal

    script = tmp_path / "sig.py"
    script.write_text(SIGNAL_SCRIPT)
    out = tmp_path / "got"
    proc = subprocess.Popen([str(REPO / "dev"), "python3", str(script), str(out)],
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    proc.send_signal(getattr(signal, signame))
    rc = proc.wait(timeout=30)
    assert out.exists(), "./dev returned before the command finished its handler"
    assert out.read_text() == str(int(getattr(signal, signame)))
    assert rc == 3


def test_the_rootfs_path_execs_the_command():
    """Static check of the rootfs path (the test above cannot reach it inside the rootfs)."""
    body = (REPO / "dev").read_text()
    run = body[body.index("run_in_rootfs() {"):body.index("main() {")]
    assert "exec unshare" in run and "exec chroot" in run


def test_paths_with_whitespace_are_mounted(fake_cache, tmp_path):
    """A -o path with whitespace outside /tmp and the repository got no bind mount."""
    res = mounts(fake_cache, "stickslip", "run", "smoke", "-o", "/var/tmp/no such 12/x y")
    assert res.returncode == 0 and res.stdout.split("\n")[:1] == ["/var/tmp"], res
    res = mounts(fake_cache, "bash", "-c", "/bin/echo a b; ls /var/tmp")  # a snippet
    assert res.returncode == 0 and res.stdout.strip() == "", res


def test_the_rootfs_path_carries_submounts():
    """Static check: /tmp and the repository are bound with their submounts (rbind)."""
    body = (REPO / "dev").read_text()
    run = body[body.index("run_in_rootfs() {"):body.index("main() {")]
    assert 'mount --rbind /tmp "$root/tmp"' in run and 'mount --rbind "$repo"' in run
    assert "mount --bind " not in run


@pytest.mark.skipif(os.environ.get("STICKSLIP_DEV_ROOTFS") == "1" or os.geteuid() != 0
                    or not (Path(os.environ.get("STICKSLIP_CACHE", "/var/cache/stickslip"))
                            / "trixie" / "etc" / "stickslip-stamp").exists(),
                    reason="needs the host side of ./dev (root, a built rootfs)")
def test_writes_reach_a_tmpfs_under_tmp_and_a_path_with_spaces(tmp_path):
    """On the host: a tmpfs mounted under /tmp, and a folder with spaces under /var/tmp,
    both see what a command inside the rootfs writes there."""
    import shutil
    import tempfile

    mnt = Path(tempfile.mkdtemp(prefix="devtmpfs-", dir="/tmp"))
    spaced = Path(tempfile.mkdtemp(prefix="dev paths ", dir="/var/tmp"))
    subprocess.run(["mount", "-t", "tmpfs", "none", str(mnt)], check=True)
    try:
        env = {k: v for k, v in os.environ.items() if k != "STICKSLIP_OUTPUT"}
        env["STICKSLIP_FORCE_ROOTFS"] = "1"
        for target in (mnt / "run1" / "f", spaced / "out dir" / "f"):
            res = subprocess.run([str(REPO / "dev"), "python3", "-c",
                                  "import sys, pathlib; p = pathlib.Path(sys.argv[1]); "
                                  "p.parent.mkdir(parents=True); p.write_text('seen')",
                                  str(target)], env=env, capture_output=True, text=True,
                                 timeout=120)
            assert res.returncode == 0, res.stderr
            assert target.read_text() == "seen"
    finally:
        subprocess.run(["umount", str(mnt)], check=False)
        shutil.rmtree(mnt, ignore_errors=True)
        shutil.rmtree(spaced, ignore_errors=True)


def test_each_tree_imports_its_own_code():
    """Static check: ./dev makes the tree importable through its own editable install
    (``.dev-site/``, named by PYTHONUSERBASE, natively and in the rootfs), never through the
    repository on PYTHONPATH (its ``stickslip/`` does not hold the subpackages) nor through an
    install into the rootfs that every clone shares; the install is neither tracked nor in the
    image."""
    body = (REPO / "dev").read_text()
    assert 'DEV_SITE="$REPO/.dev-site"' in body
    assert 'export PYTHONUSERBASE="$DEV_SITE"' in body  # native
    assert 'PYTHONUSERBASE="$repo/.dev-site"' in body  # rootfs
    assert "PYTHONPATH" not in body
    assert "pip install --user --editable" in body
    assert ".dev-site/" in (REPO / ".gitignore").read_text().split()
    assert ".dev-site" in (REPO / ".dockerignore").read_text().split()
    # inside ./dev: this tree's finder, pointing at this tree
    if os.environ.get("PYTHONUSERBASE"):
        assert Path(os.environ["PYTHONUSERBASE"]) == REPO / ".dev-site"
