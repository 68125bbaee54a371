"""Standard output that survives its reader going away.

``stickslip run scene | head -1`` closes the pipe after the first line; the next progress
line then raises BrokenPipeError (Python ignores SIGPIPE), which would stop the run and
leave it failed. The printed lines are a view of the run, not its result: once the reader
is gone they go to /dev/null and the run goes on to its own end (its files and exit status
are those of the run).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from typing import TextIO


class ReaderTolerantStream:
    """A text stream that forwards to ``stream`` until a write or flush meets a closed
    pipe; from then on the file descriptor points at /dev/null (so that the interpreter's
    final flush of ``stream`` succeeds too) and nothing more is written."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self.reader_gone = False

    def write(self, text: str) -> int:
        if not self.reader_gone:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._drop()
        return len(text)

    def flush(self) -> None:
        if not self.reader_gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._drop()

    def _drop(self) -> None:
        self.reader_gone = True
        with contextlib.suppress(OSError, ValueError, AttributeError):  # no descriptor
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._stream.fileno())
            os.close(null)

    def __getattr__(self, name: str) -> object:  # isatty, fileno, encoding, ...
        return getattr(self._stream, name)


@contextlib.contextmanager
def reader_tolerant_stdout() -> Iterator[ReaderTolerantStream]:
    """``sys.stdout`` as a ``ReaderTolerantStream`` for the block, restored after it."""
    original = sys.stdout
    sys.stdout = wrapped = ReaderTolerantStream(original)
    try:
        yield wrapped
    finally:
        sys.stdout = original
