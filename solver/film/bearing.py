"""Compatibility names of the film before it became a composition (issue 30).

The film is now specified by solver.film.spec.FilmSpec and built by solver.film.factory.make_film;
the value types are in solver.film.types, the equilibrium search in solver.film.equilibrium.
``FilmModel(bearing, comm, **options)`` builds the same film as before from the old keywords
(``elastic=`` is the spec's ``bushing``).
"""

from __future__ import annotations

from solver.film.equilibrium import equilibrium
from solver.film.factory import make_film
from solver.film.frame import FrameTurn
from solver.film.spec import FilmSpec
from solver.film.types import (
    AXIAL_ELEMENTS,
    CAVITATION_MODELS,
    DEFAULT_MESH_SIZE,
    ELASTIC_MAX_ECCENTRICITY,
    GROOVES,
    INLETS,
    MAX_ECCENTRICITY,
    STALL_TOLERANCE,
    TRANSPORT_SCHEMES,
    Bearing,
    Equilibrium,
    FilmJacobian,
    FilmResult,
    FilmStats,
    Kinematics,
    default_mesh_size,
)


def FilmModel(bearing: Bearing, comm, *, elastic=None, **options):  # noqa: N802 - the old class name
    """The film of ``bearing`` with the old FilmModel keywords (solver.film.spec.FilmSpec's, with
    ``elastic`` for ``bushing``): ``make_film(FilmSpec(...), comm)``."""
    return make_film(FilmSpec(bearing=bearing, bushing=elastic, **options), comm)


__all__ = [
    "AXIAL_ELEMENTS",
    "CAVITATION_MODELS",
    "DEFAULT_MESH_SIZE",
    "ELASTIC_MAX_ECCENTRICITY",
    "GROOVES",
    "INLETS",
    "MAX_ECCENTRICITY",
    "STALL_TOLERANCE",
    "TRANSPORT_SCHEMES",
    "Bearing",
    "Equilibrium",
    "FilmJacobian",
    "FilmModel",
    "FilmResult",
    "FilmSpec",
    "FilmStats",
    "FrameTurn",
    "Kinematics",
    "default_mesh_size",
    "equilibrium",
    "make_film",
]
