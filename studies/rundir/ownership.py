"""Which directories stickslip may write, replace or delete: one rule for every command.

A directory is stickslip's when it holds the marker ``.stickslip`` that stickslip wrote, a
JSON object with the directory's ``kind`` (run, sweep, travel, attractors, ...) and a random
``id``. A ``summary.json`` alone, or any other file a user can write, is not enough.

* **Claiming** (:func:`claim`) a directory for a command:

  - a new directory is created atomically: the lock file is made beside it under a temporary
    name, locked, and hard-linked into place (``link`` fails if the name exists), so of two
    commands started together on the same new ``-o`` exactly one gets it and the other
    refuses in one line;
  - an existing empty directory is claimed the same way;
  - a live directory (its ``.stickslip.lock`` is held with ``fcntl.flock`` by a running
    command, whose pid and host the lock file names) is never touched: refused;
  - a finished directory of the same kind is refused unless ``force`` (replace) or
    ``reuse`` (resume a sweep);
  - anything else (no marker, another kind, foreign files inside) is refused, even with
    ``force``, in one line that names the foreign files.

* **Replacing** (``force``): by default the new content is written into a hidden sibling
  ``.NAME.new.PID`` (claimed like a new directory) and swapped in by :meth:`Claim.commit`;
  :meth:`Claim.discard` drops it and the earlier directory stays as it was. So an
  interrupted or failed ``--force`` rerun keeps the old run. ``in_place=True`` (a command
  that writes into the final path itself) deletes only the files that the kind's writer
  makes (:data:`KINDS`) before it starts.

* **Naming** (:func:`normal_path`): every path is first made absolute with its ``.``, ``..``
  and repeated or trailing ``/`` resolved, so ``R/../R``, ``R/.``, ``R//``, ``./R`` and ``.``
  inside ``R`` all name ``R`` itself. The hidden siblings and the swap work on that name: a
  path that passes through the directory being replaced (``R/../R``) would lose its way
  once ``R`` is renamed. The CLI applies the same rule to every ``-o`` and run argument.

* The lock is held by the :class:`Claim` (rank 0's process) until :meth:`Claim.release` or
  the end of the process; a process killed outright drops it, so its directory is no longer
  live.

For a new command that writes a directory (for example ``stickslip attractors``)::

    from stickslip.studies.rundir.ownership import OwnershipError, claim, register_kind

    register_kind("attractors", ("attractors.json", "attractors.csv", "starts", "*.png"))
    try:
        owned = claim(out_dir, "attractors", force=args.force)
    except OwnershipError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    try:
        ...  # write into owned.work (atomic writes: solver.atomic)
        owned.commit()  # a replacement is swapped in; a new directory is already in place
    except BaseException:
        owned.discard()  # a replacement is dropped and the earlier directory is kept
        raise
    finally:
        owned.release()

Standard library only: every command may import it without the FE stack.
"""

from __future__ import annotations

import errno
import fcntl
import fnmatch
import json
import os
import shutil
import socket
import stat
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from stickslip.solver.atomic import atomic_write_text
from stickslip.studies.output import process_alive

__all__ = ["KINDS", "LOCK", "MARKER", "Claim", "OwnershipError", "claim", "foreign_entries",
           "holder", "marker", "normal_path", "open_regular", "owned", "recover", "refusal",
           "register_kind", "user_entries"]

MARKER = ".stickslip"
LOCK = ".stickslip.lock"

#: The entries (file or folder names, fnmatch patterns, top level) that each kind's writer
#: makes. ``--force`` deletes only these; any other entry is a user's and is never touched.
KINDS: dict[str, tuple[str, ...]] = {
    "run": ("scene.toml", "summary.json", "samples.npz", "final_field.npz", "fields.xdmf",
            "fields.h5", "fields.bp", "stress.bp", "spacetime.png", "profile.png", "phase.png",
            "energy.png", "uvpq.png", "isomap.png", "stress.png", "compare.json",
            "checkpoint.npz", "surface.npz", "surface.png"),
    "sweep": ("sweep.toml", "sweep.json", "sweep.csv", "runs", "logs", ".lock",
              "regime_map*.png", "semianalytic.json"),
    "travel": ("scene.toml", "summary.json", "profiles.npz", "branch.json", "branch.csv",
               "travel_profiles.png", "branch.png"),
}
#: Written by every kind: the marker, the lock, atomic writes' temporaries.
_ALWAYS = (MARKER, LOCK, f"{LOCK}.*", ".*.tmp", ".*.tmp.png", ".*.tmp.npz")


class OwnershipError(FileExistsError):
    """A directory that this command may not use: a one-line message with the fix."""


def normal_path(path: str | os.PathLike) -> Path:
    """``path`` made absolute (against the current directory) with ``.``, ``..`` and empty
    components resolved as the kernel would resolve them, its symbolic links kept.

    Lexical, except that a ``..`` after a symbolic link leads to the parent of the link's
    target (where the kernel goes), not back to the link's own folder. The last component is
    never resolved: a symlinked ``-o`` stays a link, and is refused as one by
    :func:`refusal`. One rule for every directory a command is given, so that the claim, the
    hidden siblings ``.NAME.new.PID``/``.NAME.old.PID`` and the swap all use the directory's
    own name and parent, never a route through the directory itself.
    """
    full = os.path.join(os.getcwd(), os.fspath(path))
    out = "/"
    for part in full.split("/"):
        if part in ("", "."):
            continue
        if part == "..":
            if os.path.islink(out):
                out = os.path.realpath(out)
            out = os.path.dirname(out)
        else:
            out = os.path.join(out, part)
    return Path(out)


def register_kind(kind: str, entries: tuple[str, ...]) -> None:
    """Declare a new directory kind and the entries its writer makes (fnmatch patterns)."""
    KINDS[kind] = tuple(entries)


def _ours(name: str, kind: str) -> bool:
    return any(fnmatch.fnmatchcase(name, p) for p in (*_ALWAYS, *KINDS.get(kind, ())))


def open_regular(path: str | Path) -> int:
    """A read-only descriptor of ``path`` if it is a regular file (the caller closes it),
    opened without following a symbolic link (stickslip writes its files itself) and without
    waiting (a FIFO's open would wait for a writer forever); OSError otherwise."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise OSError(errno.EINVAL, "not a regular file (a FIFO or a device?)", str(path))
    return fd


def _small_json(path: Path, most: int) -> object | None:
    """The JSON of ``path`` if it is a regular file (``open_regular``) of at most ``most``
    bytes, else None: a link, a FIFO, a device or a huge file is not one of stickslip's."""
    try:
        fd = open_regular(path)
    except OSError:
        return None
    try:
        data = os.read(fd, most + 1)
    except OSError:
        return None
    finally:
        os.close(fd)
    if len(data) > most:
        return None
    try:
        return json.loads(data)
    except (ValueError, UnicodeDecodeError):
        return None


def marker(path: str | Path) -> dict | None:
    """The marker of ``path`` (kind, id, ...), or None if it has no valid one."""
    m = _small_json(Path(path) / MARKER, 65536)
    if not isinstance(m, dict) or not isinstance(m.get("kind"), str) \
            or not isinstance(m.get("id"), str):
        return None
    return m


def owned(path: str | Path, kind: str | None = None) -> bool:
    """True if ``path`` carries stickslip's marker (of ``kind``, if given)."""
    m = marker(path)
    return m is not None and (kind is None or m["kind"] == kind)


def user_entries(path: str | Path) -> list[str]:
    """Entries of ``path`` other than the marker, the lock and their temporaries (those of
    a command killed while claiming): a directory without any is empty for a new claim."""
    try:
        names = os.listdir(path)
    except OSError:
        return []
    return sorted(n for n in names if not any(fnmatch.fnmatchcase(n, p) for p in _ALWAYS))


def foreign_entries(path: str | Path, kind: str) -> list[str]:
    """Entries of ``path`` that a ``kind`` writer does not make (a user's), sorted."""
    try:
        names = os.listdir(path)
    except OSError:
        return []
    return sorted(n + ("/" if (Path(path) / n).is_dir() else "") for n in names
                  if not _ours(n, kind))


def holder(path: str | Path) -> dict | None:
    """The pid/host of the live command holding ``path``'s lock, or None if none holds it."""
    lock = Path(path) / LOCK
    try:
        fd = open_regular(lock)
    except OSError:  # none, a symbolic link or a FIFO (refused by refusal(), never opened)
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            try:
                info = json.loads(os.read(fd, 4096) or b"{}")
            except ValueError:
                info = {}
            return info if isinstance(info, dict) else {}
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def running_writer(path: str | Path) -> dict | None:
    """The pid/host of another live process whose ``running`` summary.json is in ``path``, or
    None. A batch member's directory is claimed and its lock let go at once (a batch of B
    would hold B open files), so its batch's process is known by its summary alone
    (``studies.output.process_alive``: on this host; another host's cannot be told)."""
    summary = _small_json(Path(path) / "summary.json", 1 << 20)
    if not isinstance(summary, dict) or summary.get("status") != "running" \
            or summary.get("pid") == os.getpid():
        return None
    return summary if process_alive(summary) else None


def _special_files(path: Path, depth: int = 4) -> list[Path]:
    """FIFOs, sockets and devices in ``path``, down to ``depth`` levels (a census's
    ``starts/runs/ID/summary.json``), links not followed: stickslip writes regular files
    only, and a FIFO in their place makes every reader's open wait for a writer."""
    found, level = [], [path]
    for _ in range(depth):
        below = []
        for folder in level:
            try:
                entries = list(os.scandir(folder))
            except OSError:
                continue
            for entry in entries:
                if entry.is_dir(follow_symlinks=False):
                    below.append(Path(entry.path))
                elif not entry.is_symlink() and not entry.is_file(follow_symlinks=False):
                    found.append(Path(entry.path))
        level = below
    return found


def _names(entries: list[str], most: int = 5) -> str:
    more = f" and {len(entries) - most} more" if len(entries) > most else ""
    return ", ".join(entries[:most]) + more


def refusal(path: str | Path, kind: str, *, force: bool = False, reuse: bool = False,
            flag: str = "-o") -> str | None:
    """Why ``path`` cannot be claimed for ``kind`` (one line with the fix), or None.

    No side effects; :func:`claim` asks again under the lock (the answer may change between).
    ``path`` is taken as :func:`normal_path` names it.
    """
    fix = f"choose another {flag}"
    if str(path) == "":
        return f"{flag} is empty: give the directory to write, or leave {flag} out"
    p = normal_path(path)
    links = [q for q in (p, p / LOCK, p / MARKER) if q.is_symlink()]
    if links:
        what = ("is a symbolic link" if links[0] == p else
                f"holds {links[0].name} as a symbolic link, which stickslip never makes")
        return (f"{flag} {p} {what} (to {os.readlink(links[0])}); stickslip does not write "
                f"through links: give the real directory, or {fix}")
    if p.exists() and not p.is_dir():
        return f"{flag} {p} is not a directory (a file or device); {fix}"
    m = marker(p) if p.is_dir() else None
    odd = [q for q in (p / LOCK, p / MARKER) if q.exists() and not q.is_file()]
    odd = odd or ([] if m is None else _special_files(p))
    if odd:
        return (f"{flag} {p} holds {odd[0]} as something other than a file (a FIFO, a "
                f"device or a folder), which stickslip never makes and cannot read without "
                f"waiting forever: remove it, or {fix}")
    if p.is_dir():
        live = holder(p) or running_writer(p)
        if live is not None:
            who = f"pid {live.get('pid', '?')} on {live.get('host', '?')}"
            return f"{p} is in use by a running stickslip command ({who}); wait for it, or {fix}"
        try:
            os.listdir(p)
        except OSError as err:
            return f"cannot read {p}: {err.strerror}; {fix}"
        if user_entries(p):
            if m is None:
                return (f"{p} is not a stickslip {kind} directory (no {MARKER} marker) and is not "
                        f"empty; stickslip never writes into it: {fix}, or empty it yourself")
            if m["kind"] != kind:
                return f"{p} is a stickslip {m['kind']} directory, not a {kind} one; {fix}"
            if not (force or reuse):
                return (f"{kind} directory {p} exists; use --force to replace it (the new "
                        f"one is built beside it and swapped in when done), or {fix}")
            foreign = foreign_entries(p, kind)
            if foreign and not reuse:
                return (f"{p} holds files stickslip did not write ({_names(foreign)}); "
                        f"--force replaces only its own: move them out, or {fix}")
    parent = p.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK) \
            or str(parent.resolve()).startswith(("/proc", "/sys")):
        return f"cannot create {p}: {parent} is not a writable directory; {fix}"
    return None


@dataclass
class Claim:
    """A directory claimed by this process: ``final`` is where it ends up, ``work`` where it
    is written meanwhile (a hidden sibling when replacing, else ``final``)."""

    final: Path
    work: Path
    kind: str
    created: bool = False
    locks: list[int] = field(default_factory=list)

    @property
    def replacing(self) -> bool:
        return self.work != self.final

    def commit(self) -> None:
        """Swap a replacement in: ``final`` -> ``.NAME.old.PID``, ``work`` -> ``final``; then
        the entries a user added to the old directory meanwhile move across and the rest of it
        (stickslip's files only) is deleted."""
        if not self.replacing or not self.work.exists():
            return
        old = self.final.parent / f".{self.final.name}.old.{os.getpid()}"
        os.rename(self.final, old)
        os.rename(self.work, self.final)
        for name in foreign_entries(old, self.kind):
            name = name.rstrip("/")
            if not (self.final / name).exists():
                os.rename(old / name, self.final / name)
        _remove_ours(old, self.kind)
        self.work = self.final

    def discard(self) -> None:
        """Drop an unfinished replacement; the earlier directory stays as it was."""
        if self.replacing and self.work.exists():
            shutil.rmtree(self.work, ignore_errors=True)

    def release(self) -> None:
        """Let go of the locks (the directory is no longer live)."""
        for fd in self.locks:
            try:
                os.close(fd)
            except OSError:
                pass
        self.locks.clear()


def _remove_ours(path: Path, kind: str, keep: tuple[str, ...] = ()) -> None:
    """Delete ``path`` if it holds only stickslip's entries, else only those entries
    (except ``keep``: the marker and lock of a directory emptied in place)."""
    if not foreign_entries(path, kind) and not keep:
        shutil.rmtree(path, ignore_errors=True)
        return
    for name in os.listdir(path):
        if _ours(name, kind) and name not in keep:
            target = path / name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target, ignore_errors=True)
            else:
                target.unlink(missing_ok=True)


def _lock_into(path: Path, kind: str) -> int | None:
    """Make ``path/.stickslip.lock`` atomically, locked by us, and write the marker.

    Returns the locked descriptor, or None if the lock file exists already (another claim).
    """
    tmp = path / f"{LOCK}.{os.getpid()}.{uuid.uuid4().hex[:8]}"
    fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.write(fd, json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                 "since": time.strftime("%Y-%m-%dT%H:%M:%S%z")}).encode())
        try:
            os.link(tmp, path / LOCK)
            linked = True
        except FileExistsError:
            linked = False
    finally:
        os.unlink(tmp)
    if not linked:
        os.close(fd)
        return None
    return fd


def _write_marker(path: Path, kind: str) -> None:
    atomic_write_text(path / MARKER, json.dumps({
        "kind": kind, "id": uuid.uuid4().hex, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "host": socket.gethostname()}, indent=1) + "\n")


def _take_existing(path: Path) -> int | None:
    """Lock an existing ``.stickslip.lock`` (None if a live command holds it)."""
    try:  # never through a symbolic link: it would write a user's file
        fd = os.open(path / LOCK, os.O_RDWR | os.O_NOFOLLOW)
    except FileNotFoundError:
        return None
    except OSError as err:
        raise OwnershipError(f"{path / LOCK} cannot be opened as stickslip's lock file "
                             f"({err.strerror}); remove it, or choose another -o") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    os.ftruncate(fd, 0)
    os.pwrite(fd, json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                              "since": time.strftime("%Y-%m-%dT%H:%M:%S%z")}).encode(), 0)
    return fd


def _fresh(path: Path, kind: str, parents: bool) -> int | None:
    """Create (or take an empty) ``path`` and lock it; None if another command got it first."""
    path.mkdir(parents=parents, exist_ok=True)
    fd = _lock_into(path, kind)
    if fd is None:  # a lock file exists: a live claim (refused), or a killed one's (taken)
        fd = _take_existing(path)
        if fd is None:
            return None
    if user_entries(path) and not owned(path):
        os.close(fd)  # a user's file appeared meanwhile: not ours after all
        return None
    try:
        _write_marker(path, kind)
    except BaseException:  # a full disk: the lock goes with the failed claim
        os.close(fd)
        raise
    return fd


def recover(path: Path, kind: str) -> None:
    """Tidy after a command killed while replacing ``path``: a lone ``.NAME.old.PID`` (killed
    between the two renames of :meth:`Claim.commit`) goes back in place; a
    ``.NAME.new.PID`` whose lock nobody holds is an unfinished replacement and is dropped."""
    path = normal_path(path)
    for old in sorted(path.parent.glob(f".{path.name}.old.*")):
        if owned(old, kind) and holder(old) is None:
            if not path.exists():
                os.rename(old, path)
            else:
                _remove_ours(old, kind)
    for new in sorted(path.parent.glob(f".{path.name}.new.*")):
        if owned(new, kind) and holder(new) is None:
            shutil.rmtree(new, ignore_errors=True)


def _claim_taken(p: Path, kind: str, fd: int, *, reuse: bool, in_place: bool,
                 flag: str) -> Claim:
    """The claim of a finished directory ``p`` whose lock ``fd`` this process holds: reuse
    it, empty it of the kind's entries, or prepare its replacement beside it."""
    if reuse:
        return Claim(p, p, kind, locks=[fd])
    if in_place:
        _remove_ours(p, kind, keep=(LOCK, MARKER))
        return Claim(p, p, kind, locks=[fd])
    work = p.parent / f".{p.name}.new.{os.getpid()}"
    if work.exists():
        shutil.rmtree(work)
    work.mkdir()
    new_fd = _fresh(work, kind, parents=False)
    if new_fd is None:  # pragma: no cover - our own pid-named folder
        raise OwnershipError(f"cannot prepare {work}; choose another {flag}")
    return Claim(p, work, kind, created=True, locks=[fd, new_fd])


def claim(path: str | Path, kind: str, *, force: bool = False, reuse: bool = False,
          in_place: bool = False, flag: str = "-o") -> Claim:
    """Claim ``path`` for a ``kind`` command, or raise :class:`OwnershipError` (one line).

    ``force``: replace a finished directory of the same kind (see the module docstring);
    ``reuse``: write into a finished directory of the same kind (a sweep's resume);
    ``in_place``: replace by deleting the kind's own entries first instead of the swap.
    ``path`` is taken as :func:`normal_path` names it (``Claim.final``).
    """
    p = path
    try:
        p = normal_path(path)
        recover(p, kind)
        why = refusal(path, kind, force=force, reuse=reuse, flag=flag)
        if why:
            raise OwnershipError(why)
        if not p.is_dir() or not owned(p):
            fd = _fresh(p, kind, parents=True)
            if fd is None:
                raise OwnershipError(refusal(p, kind, force=force, reuse=reuse, flag=flag)
                                     or f"{p} was taken by another command; choose another "
                                        f"{flag}")
            return Claim(p, p, kind, created=True, locks=[fd])
        fd = _take_existing(p)
        if fd is None:
            raise OwnershipError(refusal(p, kind, force=force, reuse=reuse, flag=flag)
                                 or f"{p} is in use by another command; choose another {flag}")
        try:
            return _claim_taken(p, kind, fd, reuse=reuse, in_place=in_place, flag=flag)
        except BaseException:  # a failed claim holds no lock: a retry is not "in use"
            os.close(fd)
            raise
    except OSError as err:
        if isinstance(err, OwnershipError):
            raise
        raise OwnershipError(f"cannot create {p}: {err.strerror or err}; choose another "
                             f"{flag}") from None
