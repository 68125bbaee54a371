"""./dev's rootfs build: an interrupted or failed build is never mistaken for a good one,
and concurrent calls serialise on the lock.

A fake ``debootstrap`` on PATH stands in for the real one (no network, seconds instead of
minutes); the build recipe around it is the real ./dev.
"""

import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(
    os.geteuid() != 0 or shutil.which("unshare") is None or shutil.which("flock") is None,
    reason="./dev's rootfs path needs root, unshare and flock",
)


def fake_debootstrap(tmp_path: Path, body: str) -> Path:
    bindir = tmp_path / "bin"
    bindir.mkdir(exist_ok=True)
    script = bindir / "debootstrap"
    # the target exists before the call is logged: a test that kills the build as soon as
    # ``calls`` appears must find the leftover tree, however loaded the machine is
    script.write_text(f"#!/bin/sh\nmkdir -p \"$3/etc\"\necho \"$@\" >> {tmp_path}/calls\n{body}\n")
    script.chmod(0o755)
    return bindir


def dev_env(tmp_path: Path, bindir: Path) -> dict:
    env = dict(os.environ)
    env.update(
        PATH=f"{bindir}:{env['PATH']}",
        STICKSLIP_CACHE=str(tmp_path / "cache"),
        STICKSLIP_MIRROR="http://mirror.invalid/debian",
        STICKSLIP_FORCE_ROOTFS="1",
        STICKSLIP_MIN_FREE_KB="0",  # the fake build writes nothing: the host's disk is moot
    )
    return env


def start(env: dict) -> subprocess.Popen:
    return subprocess.Popen(
        [str(REPO / "dev"), "true"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, start_new_session=True,
    )


def wait_for(path: Path, timeout: float = 120.0,
             proc: subprocess.Popen | None = None) -> None:  # a hang guard only
    """Wait until ``path`` exists; fail at once, with its stderr, if ``proc`` has ended."""
    t0 = time.time()
    while not path.exists():
        if proc is not None and proc.poll() is not None:
            pytest.fail(f"./dev ended (exit {proc.returncode}) before {path.name} appeared: "
                        f"{proc.stderr.read().strip()}")
        assert time.time() - t0 < timeout, f"{path} never appeared"
        time.sleep(0.05)


def test_killed_build_is_discarded_and_the_next_call_rebuilds(tmp_path):
    cache = tmp_path / "cache"
    env = dev_env(tmp_path, fake_debootstrap(tmp_path, "sleep 60"))
    proc = start(env)
    wait_for(tmp_path / "calls", proc=proc)
    os.killpg(proc.pid, signal.SIGKILL)  # worst case: no trap, no cleanup at all
    proc.wait()
    leftovers = list(cache.glob(".build.*"))
    assert leftovers, "the killed build left its temporary tree (expected)"
    assert not (cache / "trixie").exists(), "a half-built rootfs must never be in place"

    # Next call: a debootstrap that fails. The leftover is discarded, nothing is installed,
    # and the error is reported clearly with a non-zero exit.
    env = dev_env(tmp_path, fake_debootstrap(tmp_path, "echo boom >&2; exit 1"))
    res = subprocess.run([str(REPO / "dev"), "true"], env=env, capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 2
    assert "debootstrap failed" in res.stderr
    assert len((tmp_path / "calls").read_text().splitlines()) == 2, "it must build again"
    assert not list(cache.glob(".build.*"))
    assert not (cache / "trixie").exists()


def test_concurrent_calls_wait_on_the_lock(tmp_path):
    env = dev_env(tmp_path, fake_debootstrap(tmp_path, "sleep 60"))
    first = start(env)
    wait_for(tmp_path / "calls", proc=first)
    log = tmp_path / "second.err"
    with open(log, "w") as err:
        second = subprocess.Popen([str(REPO / "dev"), "true"], env=env, stdout=subprocess.DEVNULL,
                                  stderr=err, start_new_session=True)
    t0 = time.time()
    while "waiting for it" not in log.read_text():
        assert time.time() - t0 < 120, "the second call must say that it waits for the lock"
        assert second.poll() is None, "the second call must wait while the first builds"
        time.sleep(0.05)
    assert len((tmp_path / "calls").read_text().splitlines()) == 1, "only one build at a time"
    os.killpg(first.pid, signal.SIGKILL)
    first.wait()
    # the second call now takes the lock and starts its own (fake, sleeping) build
    t0 = time.time()
    while len((tmp_path / "calls").read_text().splitlines()) < 2:
        assert time.time() - t0 < 120  # a hang guard only
        time.sleep(0.05)
    os.killpg(second.pid, signal.SIGKILL)
    second.wait()


@pytest.mark.parametrize("minimum, says", [
    (str(10**15), "MB free in"), ("5GB", "give a whole number of KB")])
def test_a_build_without_room_is_refused_in_one_line(tmp_path, minimum, says):
    """Before debootstrap runs: a disk with less free space than asked (here an impossible
    10^15 KB), or an asked amount that is no number, ends ./dev with exit 2 and one
    ``dev: error:`` line that names the problem; nothing is built."""
    env = dict(dev_env(tmp_path, fake_debootstrap(tmp_path, "sleep 60")),
               STICKSLIP_MIN_FREE_KB=minimum)
    res = subprocess.run([str(REPO / "dev"), "true"], env=env, capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 2
    assert res.stderr.startswith("dev: error:") and says in res.stderr
    assert not (tmp_path / "calls").exists()
    assert not (tmp_path / "cache" / "trixie").exists()
