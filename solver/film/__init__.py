"""The lubricated film of one journal bearing: mesh, scaling, Reynolds forms, flow factors,
asperity contact, surface, cavitation (SNES VI) and the bearing model that ties them together.

Depends on the case description and the errors only; knows nothing of engines or studies. Importing
this package is cheap: the dolfinx/PETSc/gmsh modules (mesh, reynolds, cavitation, bearing) are
imported only by who needs them.
"""
