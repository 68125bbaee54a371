"""SIGINT/SIGTERM during a run, by phase, with a watchdog for compiled-code hangs and a
rescue writer under mpirun."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from collections.abc import Iterator

from stickslip.solver import keep_signals_for_python
from stickslip.studies.output import output_root, process_alive  # noqa: F401  (re-exported)


class RunSignals:
    """SIGINT/SIGTERM/SIGHUP during a run, by phase.

    * ``raise`` (setup: meshing, assembly, steady state): KeyboardInterrupt at once;
    * ``flag`` (time loop): ``sim.stop_requested``; every rank stops at the same sample
      (:meth:`solver.run.Simulation._stop_now`) and the run is saved as ``interrupted``;
    * ``defer`` (final save): remembered, honoured once the files are written.

    Under mpirun (``rescue`` given, rank 0 of a multi-rank run) the first signal also forks a
    rescue writer, in a session of its own, that saves what rank 0 holds at once: the final
    summary first (a small file), then the inner-circle samples. Open MPI 5 sends SIGKILL
    0.25 s after SIGTERM, often before the collective save is done, and mpirun returns then:
    the status must be on disk by that time. The normal save waits for the writer and then
    writes the full run.

    Python runs signal handlers only between bytecodes, so a process inside one long compiled
    call (gmsh meshing, SLEPc's eigensolver for omega_max: minutes on a big mesh, with the GIL
    held) would ignore SIGTERM. A watchdog process (forked at entry) reads the signal numbers
    from ``signal.set_wakeup_fd``, written by the C-level handler at once; if the Python
    handler has not acknowledged a signal ``grace`` seconds later (in ``raise``/``flag``
    mode), the watchdog calls ``on_hard_stop(signum, phase)`` (mark it ``interrupted``, or drop
    the replacement) and ends the run with SIGKILL (exit status 137). Only in the main thread;
    elsewhere (a test's thread) nothing is installed.
    """

    #: Ctrl-C, a batch system's stop, a closed terminal. The FE stack loads during setup,
    #: after these handlers are in: PETSc and UCX would put their own in for SIGHUP (a stack
    #: dump and MPI_Abort, nothing saved; a log level raised) unless told not to, which
    #: :func:`solver.keep_signals_for_python` does (called again in ``__enter__``).
    SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

    def __init__(self, on_hard_stop, grace: float = 2.0, rescue=None,  # noqa: ANN001
                 on_death=None, on_setup_signal=None) -> None:  # noqa: ANN001
        """``on_setup_signal(signum)``: called in the watchdog at once when a signal comes
        during setup (which it ends, ``interrupted``, whatever follows): under mpirun the
        SIGKILL 0.25 s later can come before Python's handler, held up in compiled code
        (meshing, SLEPc), has run, and mpirun returns then."""
        self.on_hard_stop, self.grace, self.rescue = on_hard_stop, grace, rescue
        self.on_death, self.on_setup_signal = on_death, on_setup_signal
        self.rescue_pid = 0
        self._mode = "start"  # until the run's try block: record, do not raise yet
        self.sim = None
        self.requested = 0
        self.previous: dict = {}
        self.active = threading.current_thread() is threading.main_thread()
        self.watchdog = 0
        self.sig_w = self.ack_w = -1
        self.read_ends: tuple[int, ...] = ()
        self.old_wakeup = -1

    @property
    def mode(self) -> str:
        return self._mode

    @mode.setter
    def mode(self, value: str) -> None:
        self._mode = value
        if value == "flag":
            self._tell(b"f")  # the watchdog's phase name: the time loop
        if value in ("defer", "done"):
            self._tell(b"d")  # the watchdog stands down: the run saves or has saved

    def _tell(self, byte: bytes) -> None:
        if self.ack_w >= 0:
            try:
                os.write(self.ack_w, byte)
            except OSError:
                pass

    def __enter__(self) -> RunSignals:
        if not self.active:
            return self
        keep_signals_for_python()  # before the stack loads: our handlers stay ours
        # Blocked while forking and installing: a signal now waits, then reaches our handler
        # (mode "start": recorded; the run raises it at its first line), never a caller's
        # handler inside fork's at-fork hooks, where an exception is lost.
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, self.SIGNALS)
        try:
            sig_r, sig_w = os.pipe()
            ack_r, ack_w = os.pipe()
            os.set_blocking(sig_w, False)
            os.set_blocking(ack_w, False)
            parent = os.getpid()
            # in a session of its own: mpirun's SIGKILL of the rank's process group must not
            # take the watchdog too, or a killed run would stay `running`
            pid = _fork(lambda: self._watch(sig_r, ack_r, parent), close=(sig_w, ack_w))
            # The read ends stay open here too: if the watchdog dies (SIGKILL), a write to a
            # pipe without a reader would raise SIGPIPE, which PETSc's handler turns into
            # MPI_ABORT; with them open, the writes just fill the pipe (and fail quietly).
            self.read_ends = (sig_r, ack_r)
            self.watchdog, self.sig_w, self.ack_w = pid, sig_w, ack_w
            for sig in self.SIGNALS:
                self.previous[sig] = signal.signal(sig, self._handler)
            self.old_wakeup = signal.set_wakeup_fd(sig_w, warn_on_full_buffer=False)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        return self

    def start(self) -> None:
        """Enter the setup phase: signals raise KeyboardInterrupt from now on."""
        self.mode = "raise"
        if self.requested:
            raise KeyboardInterrupt

    def __exit__(self, *exc) -> None:  # noqa: ANN002
        if not self.active:
            return
        signal.set_wakeup_fd(self.old_wakeup)
        for sig, handler in self.previous.items():
            signal.signal(sig, handler)
        self._tell(b"x")  # a clean end: the watchdog has nothing to tidy
        for fd in (self.sig_w, self.ack_w, *self.read_ends):
            os.close(fd)
        self.sig_w = self.ack_w = -1
        self.read_ends = ()
        if self.watchdog > 0:  # it reads EOF and ends
            try:
                os.waitpid(self.watchdog, 0)
            except ChildProcessError:
                pass

    def _handler(self, signum: int, frame) -> None:  # noqa: ANN001, ARG002
        self._tell(b"a")
        self.requested = self.requested or signum
        if self.rescue is not None and not self.rescue_pid and self.mode != "done":
            self.rescue_pid = -2  # a second signal during the fork must not fork again
            self._tell(b"r")  # the rescue writer owns the status from now on
            self.rescue_pid = _fork(self.rescue)
        if self.mode == "flag" and self.sim is not None:
            self.sim.stop_requested = True
        elif self.mode == "raise":
            raise KeyboardInterrupt

    def wait_rescue(self) -> None:
        """Wait for the rescue writer (if any) before touching the run's files."""
        if self.rescue_pid > 0:
            try:
                os.waitpid(self.rescue_pid, 0)
            except ChildProcessError:
                pass
            self.rescue_pid = -1

    def _watch(self, sig_r: int, ack_r: int, parent: int) -> None:
        """The watchdog process: signals in, acknowledgements in; hard stop if none comes.

        Ends when the acknowledgement pipe closes: after b"x" the run ended cleanly; without
        it the process was killed outright and ``on_death(parent, rescued, phase, signum)``
        tidies (``signum``: the last SIGINT/SIGTERM received before the death, or 0).
        """
        import select

        received = acked = 0
        since = None
        last = 0
        standing_down = clean = rescued = False
        phase = "setup"
        first = 0  # the first signal's number, until the setup callback has it
        fds = [sig_r, ack_r]
        while True:
            timeout = None
            if since is not None and not standing_down:
                timeout = max(0.0, since + self.grace - time.monotonic())
            ready, _, _ = select.select(fds, [], [], timeout)
            if not ready:
                self.on_hard_stop(last, phase)
                os.kill(parent, signal.SIGKILL)
                return
            if sig_r in ready:
                data = os.read(sig_r, 64)
                if data:
                    if not received and self.on_setup_signal is not None:
                        first = data[0]  # told below, once this round's phase is read
                    received += len(data)
                    last = data[-1]
                    since = since or time.monotonic()
                else:
                    fds.remove(sig_r)
            if ack_r in ready:
                data = os.read(ack_r, 64)
                if not data:
                    if not clean and self.on_death is not None:
                        self.on_death(parent, rescued, phase, last)
                    return
                clean = clean or b"x" in data
                rescued = rescued or b"r" in data
                if b"f" in data:
                    phase = "the time loop"
                if b"d" in data:
                    phase = "the final save"
                acked += data.count(b"a")
                standing_down = standing_down or b"d" in data
            if first and phase == "setup" and not rescued:  # else the writer owns it
                self.on_setup_signal(first)
            first = 0
            if acked >= received:
                since = None


def _signame(signum: int) -> str:
    """SIGINT, SIGTERM, ...; "a signal on another rank" for 0 (this rank saw none)."""
    try:
        return signal.Signals(signum).name if signum else "a signal on another rank"
    except ValueError:
        return f"signal {signum}"


def _fork(fn, new_session: bool = True, close: tuple[int, ...] = ()) -> int:  # noqa: ANN001
    """Run ``fn()`` in a forked child (by default in a session of its own, out of reach of
    mpirun's kill, with SIGINT/SIGTERM ignored); returns its pid (0 if fork failed)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # fork with threads: child uses none
        try:
            pid = os.fork()
        except OSError:
            return 0
    if pid:
        return pid
    code = 1
    try:
        signal.set_wakeup_fd(-1)
        for fd in close:
            os.close(fd)
        if new_session:
            os.setsid()
        for sig in RunSignals.SIGNALS:
            signal.signal(sig, signal.SIG_IGN)
        fn()
        code = 0
    finally:
        os._exit(code)


@contextlib.contextmanager
def deferred_signals() -> Iterator[list[int]]:
    """SIGINT, SIGTERM and SIGHUP inside the block: recorded in the yielded list, not raised,
    so that work which must not stop midway ends whole: a batch's member files (a signal
    midway would leave the later members ``running``, their samples lost), or two ranks
    stepping a paired twin (one rank leaving the pair would leave the other waiting); the
    caller honours them after the block. Outside the main thread nothing is recorded (no
    handler can be set there)."""
    came: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield came
        return
    names = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    previous = {s: signal.signal(s, lambda signum, frame: came.append(signum)) for s in names}
    try:
        yield came
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
