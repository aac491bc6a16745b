"""A new viscosity changes constants of the film's forms, not the forms (issue 30, item 3): on every film
kind, rigid and elastic."""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem

from solver.film.bushings import ModalCompliance, WinklerLayer
from solver.film.factory import make_film
from solver.film.spec import FilmSpec
from solver.film.surface import Surface
from solver.film.types import Bearing, Kinematics
from solver.film.viscosity import Barus

R, C, OMEGA = 0.01, 10e-6, 200.0
MU1, MU2 = 0.01, 0.023
ROUGH = Surface(sigma_journal=0.3e-6, sigma_bushing=0.4e-6)
GROOVE = {"groove": "circumferential", "groove_width": 0.003, "supply_pressure": 2e5}
WINKLER = WinklerLayer(thickness=1.5e-3, E=115e9, nu=0.33)

#: the kinds: (cavitation law, bushing: None, "winkler" or "fe", piezoviscosity)
KINDS = {
    "reynolds": ("reynolds", None, None),
    "jfo": ("jfo", None, None),
    "winkler": ("reynolds", "winkler", None),
    "winkler-piezo": ("reynolds", "winkler", Barus(2e-8)),
    "elastic-jfo": ("jfo", "winkler", None),
    "fe": ("reynolds", "fe", None),
}
#: a steady state in asperity contact, then the state a step later (squeeze, the pin moved)
STEADY = Kinematics(
    (0.97 * C * math.cos(-1.4), 0.97 * C * math.sin(-1.4)), (0.1 * C * OMEGA, 0.0), OMEGA, 0.0
)
LATER = Kinematics(
    (0.96 * C * math.cos(-1.38), 0.96 * C * math.sin(-1.38)), (-0.1 * C * OMEGA, 0.05 * C * OMEGA), OMEGA, 0.0
)


def _spec(viscosity: float, kind: str, eye) -> FilmSpec:
    cavitation, bushing, piezo = KINDS[kind]
    bearing = Bearing(
        radius=R,
        width=2 * R,
        clearance=C,
        viscosity=viscosity,
        cavitation_pressure=-0.5e5,
        inlet="none",
        **GROOVE,
    )
    bushings = {None: None, "winkler": WINKLER, "fe": eye and ModalCompliance(eye, 12)}
    return FilmSpec(
        bearing=bearing,
        omega_ref=OMEGA,
        mesh_size=0.12,
        roughness=ROUGH.roughness(),
        contact=ROUGH.contact(),
        cavitation=cavitation,
        bushing=bushings[bushing],
        piezoviscosity=piezo,
    )


def _answers(film, kin: Kinematics, time_s: float | None = None) -> np.ndarray:
    r = film.solve(kin, time_s)
    values = [
        *r.force,
        r.torque_journal,
        r.torque_bushing,
        r.p_max,
        r.h_min,
        r.max_deformation,
        r.side_flow,
        r.supply_flow,
        r.asperity_load,
    ]
    state = film.history_state()
    return np.concatenate([values, film.jacobian().matrix.ravel(), [] if state is None else state])


def _steady_then_later(film) -> np.ndarray:
    """The steady state's answers, its state committed at t = 0, then the answers a step later."""
    steady = _answers(film, STEADY)
    if film.has_history:
        film.commit_history(film.history_state(), 0.0)
    return np.concatenate([steady, _answers(film, LATER, 1e-4)])


@pytest.mark.serial
@pytest.mark.parametrize("kind", list(KINDS))
def test_set_viscosity_gives_the_film_built_at_that_viscosity(kind, request, monkeypatch):
    """A film built at mu1, solved (and its state committed), then set to mu2: the same forces, torques,
    p_max, h_min, deformation, flows, Jacobian and history state as a film built at mu2, in a steady
    solve and in a transient one after a commit, to 1e-10 of each value: the same discrete problem (a
    rigid film from another warm start, solved to its solvers' tolerances; a film with history from the
    same start as the new film's, since the coupled solves stop at 1e-8 of the film's source and from
    another start differ by ~1e-7); no form or expression is compiled for it."""
    eye = request.getfixturevalue("coarse_eye") if KINDS[kind][1] == "fe" else None
    with make_film(_spec(MU2, kind, eye), MPI.COMM_SELF) as film:
        cold = film.history_state()  # (None without history)
        reference = _steady_then_later(film)
    with make_film(_spec(MU1, kind, eye), MPI.COMM_SELF) as film:
        _answers(film, STEADY)  # (a warm start and a history at mu1)
        if film.has_history:
            film.commit_history(film.history_state(), 0.0)
        calls = []
        for name in ("form", "Expression"):
            real = getattr(fem, name)
            monkeypatch.setattr(fem, name, lambda *a, _real=real, **k: calls.append(1) or _real(*a, **k))
        film.set_viscosity(MU2)
        if cold is not None:  # the coupled solves converge to 1e-8 of the source: from the same start
            film.start_from(cold)
        answers = _steady_then_later(film)
    assert calls == []
    relative = np.abs(answers - reference) / np.maximum(np.abs(reference), 1e-300)
    assert np.all(relative <= 1e-10), (relative.max(), int(np.argmax(relative)))
