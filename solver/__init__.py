"""Engine tribo-dynamics: mixed-lubricated clearance joints in planar multibody engines.

The film is the (averaged) Reynolds equation solved by finite elements (dolfinx) with cavitation as
a variational inequality (PETSc SNES VI); the mechanism is a planar multibody system with Lagrange
multipliers and Baumgarte stabilisation.
"""

__version__ = "0.1.0"
