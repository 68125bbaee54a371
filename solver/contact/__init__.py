"""Unilateral contact and Coulomb friction on the tube's inner circle.

* ``law``: ``ContactLaw`` (d, f, the cylinder's travel per step, kappa, the friction bound's
  typed parts ``SpatialFilter`` and ``Regularisation``) and the status codes, defined once;
* ``nodal``: the nodal projection as plain numpy functions (Coulomb, Prakash-Clifton, the
  1-2-1 filtered bound), independent of the mesh and of the time loop;
* ``projection``: the explicit contact step at the contact nodes of a tube
  (``make_projection``).
"""

from stickslip.solver.contact.law import (
    SEPARATION,
    SLIP,
    STATUS_NAMES,
    STICK,
    ConstantTime,
    ContactLaw,
    Instantaneous,
    PrakashClifton,
    Regularisation,
    SpatialFilter,
    forward_increment_factor,
)
from stickslip.solver.contact.nodal import (
    ContactArrays,
    EffectivePressure,
    NeighbourFilter,
    project_contact,
    project_contact_filtered,
    project_contact_regularized,
    project_normal,
    project_tangential,
    relax_effective_pressure,
    zone_fractions,
)
from stickslip.solver.contact.projection import (
    ContactProjection,
    FilteredContactProjection,
    NodalFrames,
    RegularizedContactProjection,
    make_projection,
)

__all__ = [
    "SEPARATION", "STICK", "SLIP", "STATUS_NAMES", "ContactLaw", "forward_increment_factor",
    "SpatialFilter", "Regularisation", "Instantaneous", "PrakashClifton", "ConstantTime",
    "ContactArrays", "EffectivePressure", "NeighbourFilter", "project_contact",
    "project_contact_filtered", "project_contact_regularized", "project_normal",
    "project_tangential", "relax_effective_pressure", "zone_fractions", "ContactProjection",
    "FilteredContactProjection", "NodalFrames", "RegularizedContactProjection",
    "make_projection",
]
