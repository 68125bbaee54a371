"""The ``stickslip`` command line: ``main`` holds the parser and the registry of command
modules; each module adds its subcommands with ``register(subparsers)``."""
