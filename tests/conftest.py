"""Shared pytest configuration.

Parallel tests are marked ``@pytest.mark.parallel``; ``tests/run.sh`` runs them once serially
and once under ``mpirun -n 2``. Under mpirun only rank 0 writes the JUnit report, so the
summary counts each parallel test once.
"""

import os

import pytest

MPI_RANK = int(os.environ.get("OMPI_COMM_WORLD_RANK", os.environ.get("PMI_RANK", "0")))


@pytest.hookimpl(tryfirst=True)
def pytest_configure(config: pytest.Config) -> None:
    if MPI_RANK > 0:
        config.option.xmlpath = None
