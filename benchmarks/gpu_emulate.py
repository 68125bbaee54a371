"""A CPU stand-in for the part of CuPy that the batched ensemble uses, so that the GPU code
paths (``BatchedExplicit(..., kernel="cuda")`` and ``BatchRecorder`` on a non-numpy
namespace) run on a machine without a GPU: the benchmark suite's rehearsal
(``benchmarks/gpu_suite.sh --emulate``) and tests/test_gpu.py.

The CUDA kernel (``solver.ensemble.CUDA_SOURCE``) is compiled as C++ for the CPU, with
``-ffp-contract=off`` (no fused multiply-add, as nvcc ``--fmad=false``), and launched thread
by thread: the threads of one step are independent (each writes only its own node), so the
serial order gives the GPU's result. Arrays are numpy arrays; everything the module does not
define is numpy's. It is a plumbing and logic check, not a model of the GPU's speed.
"""

from __future__ import annotations

import ctypes
import hashlib
import re
import shutil
import subprocess
import sys
import tempfile
import types
from pathlib import Path

import numpy as np

_WRAPPER = r"""
#include <cmath>
#include <cstddef>
struct Dim { unsigned int x; };
static Dim blockIdx, blockDim, threadIdx;
#define __global__
using std::copysign;
using std::fabs;
%(source)s
extern "C" void emulate(int blocks, int threads, %(params)s) {
    blockDim.x = threads;
    for (int b = 0; b < blocks; ++b) {
        blockIdx.x = b;
        for (int t = 0; t < threads; ++t) {
            threadIdx.x = t;
            %(kernel)s(%(names)s);
        }
    }
}
"""


def compile_kernel(source: str, name: str, build_dir: Path | None = None):
    """The ``__global__`` function ``name`` of ``source``, compiled for the CPU: a ctypes
    function ``emulate(blocks, threads, *args)`` that runs every thread of a launch.
    Raises RuntimeError when no C++ compiler is found."""
    cxx = shutil.which("g++") or shutil.which("c++")
    if cxx is None:
        raise RuntimeError("no C++ compiler (g++) to emulate the CUDA kernel on the CPU")
    head = source[source.index(f"{name}(") + len(name) + 1:]
    params = head[: head.index(")")]
    names = ", ".join(re.findall(r"(\w+)\s*(?:,|$)", params.replace("\n", " ")))
    text = _WRAPPER % {"source": source, "params": params, "names": names, "kernel": name}
    build_dir = Path(build_dir or tempfile.gettempdir()) / "stickslip-cuda-emulation"
    build_dir.mkdir(parents=True, exist_ok=True)
    key = hashlib.sha256(text.encode()).hexdigest()[:16]
    lib = build_dir / f"{name}-{key}.so"
    if not lib.exists():  # compiled once per source text; the rename keeps it whole
        src = build_dir / f"{name}-{key}.cpp"
        src.write_text(text)
        tmp = lib.with_suffix(f".{id(text)}.tmp")
        subprocess.run([cxx, "-O2", "-ffp-contract=off", "-shared", "-fPIC", "-o", str(tmp),
                        str(src)], check=True)
        tmp.replace(lib)
    return ctypes.CDLL(str(lib)).emulate


def _c_arg(x):
    """A launch argument as ctypes: an array by its data pointer, a scalar by its type."""
    if isinstance(x, np.ndarray):
        if not x.flags.c_contiguous:
            raise ValueError("a kernel argument must be C-contiguous")
        return ctypes.c_void_p(x.ctypes.data)
    if isinstance(x, (np.floating, float)):
        return ctypes.c_double(float(x))
    if isinstance(x, (np.integer, int, bool)):
        return ctypes.c_int(int(x))
    raise TypeError(f"kernel argument of type {type(x).__name__}")


class RawModule:
    """``cupy.RawModule(code=..., options=...)``: ``get_function(name)`` is a launcher
    ``f(grid, block, args)`` as CuPy's (1-D grids and blocks)."""

    def __init__(self, code: str, options: tuple = (), **_) -> None:
        if "--fmad=false" not in options:  # the emulation is compiled without FMA
            raise ValueError("the CPU emulation models --fmad=false only")
        self.code = code

    def get_function(self, name: str):
        emulate = compile_kernel(self.code, name)

        def launch(grid, block, args) -> None:
            emulate(ctypes.c_int(grid[0]), ctypes.c_int(block[0]), *map(_c_arg, args))

        return launch


class Stream:
    """``cupy.cuda.Stream``: the null stream (the compute stream) runs each operation at
    once; another stream queues its operations (the emulated asynchronous copies) and runs
    them only when the host waits for it or for one of its events (``Event.synchronize``,
    an ``Event.done`` that answers True, ``wait_event``, ``synchronize``). A host that reads
    a copy's target too early, or a device buffer rewritten before its copy ran, therefore
    gives wrong data here, as on a GPU."""

    _streams: list = []  # every stream made, for ``Device.synchronize``

    def __init__(self, null: bool = False, non_blocking: bool = False) -> None:
        self.is_null = null
        self._queue: list = []
        self._ran = 0  # operations run
        Stream._streams.append(self)

    def submit(self, op) -> None:
        if self.is_null:
            op()
        else:
            self._queue.append(op)

    def run(self, upto: int | None = None) -> None:
        """Run the queued operations, through the ``upto``-th one."""
        upto = len(self._queue) if upto is None else upto
        while self._ran < upto:
            op, self._queue[self._ran] = self._queue[self._ran], None
            self._ran += 1
            op()

    def record(self, event: Event | None = None) -> Event:
        event = event or Event()
        event.record(self)
        return event

    def wait_event(self, event: Event) -> None:
        event.synchronize()  # the null stream runs at once: it must see the event's work

    def synchronize(self) -> None:
        self.run()

    @property
    def done(self) -> bool:
        self.run()
        return True


Stream.null = Stream(null=True)


class Event:
    """``cupy.cuda.Event``: the operations queued on its stream before ``record``. ``done``
    answers False at its first ``LAG`` queries (a copy still under way), then runs them and
    answers True, so that both branches of a poll run and a copy can still be pending when
    the loop has moved on by a few rows."""

    LAG = 2

    def __init__(self, block: bool = False, disable_timing: bool = False,
                 interprocess: bool = False) -> None:
        self._stream, self._upto, self._queries = None, 0, 0

    def record(self, stream: Stream | None = None) -> None:
        self._stream = stream or Stream.null
        self._upto = len(self._stream._queue)

    def synchronize(self) -> None:
        if self._stream is not None:
            self._stream.run(self._upto)

    @property
    def done(self) -> bool:
        if self._queries < self.LAG and self._stream is not None and \
                self._stream._ran < self._upto:
            self._queries += 1
            return False
        self.synchronize()
        return True


def asnumpy(a, stream: Stream | None = None, order: str = "C", out=None, *,
            blocking: bool = True) -> np.ndarray:
    """``cupy.asnumpy``: a copy on ``stream`` (the null stream by default), queued there
    when ``blocking`` is False."""
    if out is None:
        return np.array(a, order=order)
    stream = stream or Stream.null

    def copy() -> None:
        out[...] = a

    stream.submit(copy)
    if blocking:
        stream.synchronize()
    return out


class _Device:
    def __init__(self, index: int = 0) -> None:
        self.id = index

    def synchronize(self) -> None:
        for stream in Stream._streams:
            stream.run()


def _device_properties(index: int) -> dict:
    return {"name": b"CPU emulation of the CUDA kernel (no GPU)", "totalGlobalMem": 0}


def cupy_module() -> types.ModuleType:
    """A module named ``cupy``: numpy's namespace plus ``RawModule``, ``asnumpy`` (with
    ``stream``, ``out``, ``blocking``), ``cuda.{Device, Stream, Event, get_current_stream,
    alloc_pinned_memory}`` and ``cuda.runtime.{getDeviceCount, getDeviceProperties,
    deviceGetAttribute}``."""
    mod = types.ModuleType("cupy", __doc__)
    mod.__getattr__ = lambda name: getattr(np, name)  # type: ignore[attr-defined]
    mod.RawModule = RawModule
    mod.asnumpy = asnumpy
    mod.EMULATED = True
    mod.__version__ = "emulated"
    runtime = types.SimpleNamespace(getDeviceCount=lambda: 1,
                                    getDeviceProperties=_device_properties,
                                    deviceGetAttribute=lambda attr, dev: 0)
    mod.cuda = types.SimpleNamespace(
        Device=_Device, runtime=runtime, Stream=Stream, Event=Event,
        get_current_stream=lambda: Stream.null,
        alloc_pinned_memory=bytearray)  # page-locked memory: plain host memory here
    return mod


def install() -> types.ModuleType:
    """Make ``import cupy`` give the emulation in this process (returns it)."""
    mod = cupy_module()
    sys.modules["cupy"] = mod
    return mod
