"""UFL forms (plane-strain elasticity, polar projections) and the discrete steady sliding state."""

from stickslip.forms.elasticity import Material, lumped_mass, mass, stiffness, strain, stress
from stickslip.forms.polar import (
    ContactNodes,
    boundary_measure,
    contact_nodes,
    radial_component,
    radial_unit,
    tangential_component,
    tangential_unit,
)

__all__ = [
    "ContactNodes",
    "Material",
    "boundary_measure",
    "contact_nodes",
    "lumped_mass",
    "mass",
    "radial_component",
    "radial_unit",
    "stiffness",
    "strain",
    "stress",
    "tangential_component",
    "tangential_unit",
]
