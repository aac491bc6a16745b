"""Fixtures of the film tests: the central differences that the film's exact Jacobians are checked against."""

from __future__ import annotations

import numpy as np
import pytest


def _outputs(result) -> np.ndarray:
    return np.array([*result.force, result.torque_journal, result.torque_bushing])


def central_differences(model, base, steps, time_s=None) -> np.ndarray:
    """d(force_x, force_y, torque_journal, torque_bushing)/d(ecc, ecc_rate, omega_rel) by central
    differences of full film solves (``time_s`` passed on to an elastic film's solve)."""
    from solver.film.bearing import Kinematics

    J_fd = np.zeros((4, 5))
    for j in range(5):
        d = np.zeros(5)
        d[j] = steps[j]
        plus, minus = (
            Kinematics(
                (base.ecc[0] + s * d[0], base.ecc[1] + s * d[1]),
                (base.ecc_rate[0] + s * d[2], base.ecc_rate[1] + s * d[3]),
                base.omega_journal + s * d[4],
                base.omega_bushing,
            )
            for s in (1, -1)
        )
        J_fd[:, j] = (_outputs(model.solve(plus, time_s)) - _outputs(model.solve(minus, time_s))) / (
            2 * steps[j]
        )
    return J_fd


@pytest.fixture(scope="session")
def coarse_eye(tmp_path_factory):
    """A coarse finite-element compliance of the reference eye (36 x 3 loads, 0.6 R elements: seconds)."""
    from solver.film.compliance import EyeGeometry, eye_compliance

    R = 0.01
    geometry = EyeGeometry(
        bore_radius=R, width=2 * R, bushing_thickness=1.5e-3, eye_outer_radius=1.7 * R, shank_angle_deg=90.0
    )
    return eye_compliance(
        geometry, n_theta=36, n_z=3, element_size=0.6 * R, cache_dir=tmp_path_factory.mktemp("compliance")
    )


@pytest.fixture
def film_differences():
    """``central_differences(model, base, steps, time_s=None)`` as a fixture."""
    return central_differences


#: the film kinds of the parametrised fixture: (bearing keywords, FilmSpec keywords)
def _kinds(eye=None):
    from solver.film.bushings import FEEye, ModalCompliance, WinklerLayer
    from solver.film.surface import Surface

    rough = Surface(sigma_journal=0.3e-6, sigma_bushing=0.4e-6)
    rough_keys = {"roughness": rough.roughness(), "contact": rough.contact()}
    winkler = WinklerLayer(thickness=1.5e-3, E=115e9, nu=0.33)
    flooded = {"inlet": "none", "cavitation_pressure": -0.5e5}
    return {
        "rigid-smooth": ({"inlet": "max-gap"}, {"quasi_static": True}),
        "rigid-rough": ({"inlet": "none"}, rough_keys),
        "winkler": ({"inlet": "none"}, {"bushing": winkler}),
        "jfo": (flooded, {"cavitation": "jfo"}),
        "elastic-jfo": (flooded, {"cavitation": "jfo", "bushing": winkler}),
        # the coarse eye (coarse_eye), a few modes: the coupled Newton's dense borders and SchurLU
        "fe-eye": ({"inlet": "none"}, {"bushing": eye and ModalCompliance(eye, 12), **rough_keys}),
        # the coarse eye in the layer basis (the layer node by node + 12 modes): SchurLU eliminating the layer
        "fe-layer": (
            {"inlet": "none"},
            {"bushing": eye and FEEye(eye.geometry, 12, basis="layer").reduce(eye), **rough_keys},
        ),
        "fe-layer-jfo": (
            flooded,
            {"cavitation": "jfo", "bushing": eye and FEEye(eye.geometry, 12, basis="layer").reduce(eye)},
        ),
    }


FILM_KINDS = [
    "rigid-smooth",
    "rigid-rough",
    "winkler",
    "jfo",
    "elastic-jfo",
    "fe-eye",
    "fe-layer",
    "fe-layer-jfo",
]


@pytest.fixture(params=FILM_KINDS)
def film(request):
    """One film of each kind (the factory's choices), on a coarse mesh of a B/D = 1 bearing (R 10 mm,
    c 10 um, mu 0.01 Pa s, omega_ref 200 rad/s); closed after the test."""
    from mpi4py import MPI

    from solver.film.factory import make_film
    from solver.film.spec import FilmSpec
    from solver.film.types import Bearing

    eye = request.getfixturevalue("coarse_eye") if request.param.startswith("fe-") else None
    bearing_keys, spec_keys = _kinds(eye)[request.param]
    bearing = Bearing(radius=0.01, width=0.02, clearance=10e-6, viscosity=0.01, **bearing_keys)
    spec = FilmSpec(bearing=bearing, omega_ref=200.0, mesh_size=0.12, **spec_keys)
    with make_film(spec, MPI.COMM_SELF) as model:
        yield model
