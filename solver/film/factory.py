"""The one place that turns a film specification into a film: ``make_film(spec, comm)``.

It checks the specification on the communicator (solver.film_rules: elastic and JFO films run on one
rank), builds the bushing (a WinklerLayer as it is; an FEEye's compliance, from its disk cache when
built before, in its basis), the shared discretisation (solver.film.space, solver.film.forms) and then
ONE film solver (solver.film.solvers) for the cavitation law and the bushing:

=================  ==================  ==========================================
cavitation         bushing             film solver
=================  ==================  ==========================================
reynolds           rigid               ReynoldsVI (SNES VI)
jfo                rigid               RigidJFO (semismooth Newton, no VI)
reynolds           Winkler or FE eye   CoupledFilm with ReynoldsRows (one coupled VI)
jfo                Winkler or FE eye   CoupledFilm with JFORows (one semismooth Newton)
=================  ==================  ==========================================

No other module asks what kind of film it holds. Adding a cavitation law or a bushing: see
docs/film-architecture.md.
"""

from __future__ import annotations

from solver.film.functionals import quiet_jit
from solver.film.spec import FilmSpec


def _bushing(spec: FilmSpec, comm):
    """The bushing object of the spec (solver.film.bushings): None (rigid), a WinklerLayer, or an FEEye's
    compliance built here in its basis (the layer basis: a Superposed layer and modes; the eigen basis: a
    ModalCompliance)."""
    bushing = spec.bushing
    build = getattr(bushing, "build", None)  # FEEye: data until here
    return build(comm) if build is not None else bushing


def make_film(spec: FilmSpec, comm):
    """The film of ``spec`` on ``comm`` (solver.film.model.Film)."""
    from solver.film.cavitation_jfo import JFORows
    from solver.film.coupled_reynolds import ReynoldsRows
    from solver.film.forms import FilmForms  # dolfinx, PETSc, gmsh
    from solver.film.model import Film
    from solver.film.solvers import CoupledFilm, ReynoldsVI, RigidJFO
    from solver.film.space import FilmSpace

    spec.check(ranks=comm.size)
    bushing = _bushing(spec, comm)
    with quiet_jit():
        space = FilmSpace(spec, comm, deformable=bushing is not None)
        forms = FilmForms(space)
        if bushing is not None:  # the cavitation law's rows in the coupled Newton
            rows = JFORows if spec.cavitation == "jfo" else ReynoldsRows
            block = rows(space, forms.operator, None if spec.cavitation == "jfo" else spec.options)
            solver = CoupledFilm(space, forms, bushing, block)
        elif spec.cavitation == "jfo":
            solver = RigidJFO(space, forms)
        else:
            solver = ReynoldsVI(space, forms)
    return Film(space, forms, solver)
