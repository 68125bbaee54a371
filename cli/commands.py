"""The commands of ``stickslip``: the module that adds each one's parser
(``register(subparsers)``) and the line ``stickslip --help`` lists it with.

``stickslip COMMAND ...`` imports the module of COMMAND alone, with the studies it runs at
that module's top; ``stickslip --help`` lists every command from here and imports none of
them (``cli.main.build_parser``).
"""

from __future__ import annotations

#: name -> (module, the one line of ``stickslip --help``), in the order the help lists them;
#: the commands of one module are adjacent, in the order its ``register`` adds them.
COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("stickslip.cli.run",
            "run a scene (TOML) with the explicit FE solver; writes a run directory"),
    "plot": ("stickslip.cli.run", "draw the figures of a run or sweep directory (PNG)"),
    "continue": ("stickslip.cli.continue_run",
                 "continue a run from its checkpoint to a later end time"),
    "wave": ("stickslip.cli.semianalytic",
             "travelling stick-slip(-separation) waves of the reduced model"),
    "flutter": ("stickslip.cli.semianalytic", "flutter modes of steady sliding (reduced model)"),
    "compare": ("stickslip.cli.compare",
                "FE wave of a run directory against the semi-analytical waves (table + JSON)"),
    "sweep": ("stickslip.cli.sweep",
              "run a grid/list of scene variants (mpirun: dynamic load balancing, resumable)"),
    "flutter-fe": ("stickslip.cli.flutter_fe",
                   "complex eigenvalue analysis (CEA) of FE steady sliding (SLEPc)"),
    "flutter-exact": ("stickslip.cli.continuum",
                      "exact continuum flutter of steady sliding (Bessel, every branch per "
                      "order n)"),
    "travel": ("stickslip.cli.travel",
               "compute a travelling wave on the FE mesh in the wave's frame (Newton)"),
    "attractors": ("stickslip.cli.attractors",
                   "census of a scene point: its attractors, their basin shares and values "
                   "per mesh"),
    "rpo": ("stickslip.cli.rpo",
            "solve a relative periodic orbit u(θ, t + T) = u(θ − s, t) from a run (Newton)"),
    "export": ("stickslip.cli.export",
               "a run's probe signals (every step) as CSV; --plot: spectrogram and spectrum"),
}


def command_help(name: str) -> str:
    """The line ``stickslip --help`` shows for the command ``name``."""
    return COMMANDS[name][1]
