"""The answer of a scene point: its attractors and their basins (``stickslip attractors``).

``starts`` (the start distribution), ``features`` (travelling components of an end state,
the one matching rule), ``classify`` (end states, members), ``statistics``
(Wilson intervals, ladder, Fisher's test), ``certify`` (the direct solver, through one
adapter), ``census`` (the driver on the sweep machinery, outputs), ``bundle`` (the census of
a GPU node without dolfinx, ``--bundle``), ``report`` (the printed summary), ``plots``
(``--plot``). docs/attractors.md.
"""

from stickslip.studies.attractors.census import Census, CensusError, collect, run_census
from stickslip.studies.attractors.classify import CELERITY_TOL, SPREAD_TOL, classify, frame_spread
from stickslip.studies.attractors.features import Features, describe, match, window_features
from stickslip.studies.attractors.starts import StartDistribution
from stickslip.studies.attractors.statistics import (
           fisher_consistent,
           ladder,
           observed_order,
           wilson,
)

__all__ = ["CELERITY_TOL", "SPREAD_TOL", "Census", "CensusError", "Features",
           "StartDistribution", "classify", "collect", "describe", "fisher_consistent",
           "frame_spread", "ladder", "match", "observed_order", "run_census",
           "window_features", "wilson"]
