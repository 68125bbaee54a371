"""stickslip solver: Newmark time integration of plane-strain elastodynamics with a nodal
unilateral-contact / Coulomb-friction projection on the inner circle of a tube.

Kept import-light on purpose: nothing here imports dolfinx, so ``stickslip wave`` and the
semi-analytical tools start fast and run where FEniCSx is not installed.

The signals stay Python's: every entry point imports this package before the FE stack (the
CLI imports it first; ``solver.run``, ``solver.problem`` ... live under it), and it asks the
stack's C libraries, through the environment they read when they load, to install no signal
handlers of their own (:func:`keep_signals_for_python`).
"""

import os

__version__ = "0.1.0"


def keep_signals_for_python(environ: dict = os.environ) -> None:  # noqa: B006
    """Ask PETSc and UCX, through ``environ`` (the process's environment, read by each library
    when it loads), to leave the signals to Python.

    Both load lazily (mpi4py and petsc4py are first imported by dolfinx during a run's setup),
    after the CLI and ``RunSignals`` have installed their handlers, and left alone they
    replace them at the C level (``signal.getsignal`` still reports Python's):

    * PETSc (``PetscInitialize``) turns SIGHUP, SIGPIPE, SIGSEGV ... into a stack dump and
      ``MPI_Abort`` (exit 59, nothing saved); built with Open MPI it leaves SIGTERM and
      SIGINT alone, which is why those two stopped a run cleanly and SIGHUP did not.
    * UCX (linked into Open MPI's libmpi, so loaded with mpi4py) takes SIGHUP as its "debug
      signal" (``UCX_DEBUG_SIGNO``): a hang-up then only raises UCX's log level.

    With both off, SIGHUP stops a run as SIGTERM does (saved ``interrupted``, exit 130) and
    SIGPIPE stays ignored (Python's default: a closed pipe is a BrokenPipeError). What the
    user set stays: options already in ``PETSC_OPTIONS`` are kept (``-no_signal_handler`` is
    added), a ``UCX_DEBUG_SIGNO`` already set is not changed. Without effect on a library
    already loaded: its handlers then came before ours, which replaced them.
    """
    options = environ.get("PETSC_OPTIONS", "")
    if "-no_signal_handler" not in options.split():
        environ["PETSC_OPTIONS"] = f"{options} -no_signal_handler".strip()
    if not environ.get("UCX_DEBUG_SIGNO"):
        environ["UCX_DEBUG_SIGNO"] = "0"


keep_signals_for_python()
