"""stickslip solver: Newmark time integration of plane-strain elastodynamics with a nodal
unilateral-contact / Coulomb-friction projection on the inner circle of a tube.

Kept import-light on purpose: nothing here imports dolfinx, so ``stickslip wave`` and the
semi-analytical tools start fast and run where FEniCSx is not installed.
"""

__version__ = "0.1.0"
