"""Meshes of the tube cross-section (paper section 2), of the finite-length tube in 3D
(``tube3d``), and dolfinx version shims."""

from stickslip.meshes.annulus import (
    INNER_TAG,
    OUTER_TAG,
    TUBE_TAG,
    TubeMesh,
    annulus_mesh,
    auto_n_radial,
)

__all__ = ["INNER_TAG", "OUTER_TAG", "TUBE_TAG", "TubeMesh", "annulus_mesh", "auto_n_radial"]
