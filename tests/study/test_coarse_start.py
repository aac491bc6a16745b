"""The start's cycles on a coarser film (solver.study.start, ``solver.start_mesh_size``).

References:

1. Interpolation (solver.film.model.Film.state_from): a field linear in z is carried exactly (linear
   interpolation reproduces it: round-off); a smooth field periodic in theta, f = cos(theta) (1 - (2 z /
   B)^2) + 0.2 sin(2 theta), carried from meshes of 0.2 R and 0.1 R onto one of 0.05 R converges at the
   interpolant's second order (the error's ratio >= 3 where h^2 gives 4; measured 0.0129 and 0.0038, 3.4:
   these meshes are not nested); the modes' coordinates (the
   entries after the nodal parts) are copied as they are; the layer basis's second nodal part (Winkler)
   is interpolated as the first.
2. The coupled run (tests/study/test_periodic.py, beside the extrapolation's test: one plain run for both):
   the coarse JFO engine from its start on a 0.4 R film reaches the plain run's periodic state.
3. Bad input: one line naming the key and its allowed range.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.case import load_case
from solver.errors import InputError
from solver.film.bearing import Bearing, FilmModel
from solver.film.bushings import WinklerLayer
from tests.study.test_periodic import coarse_jfo_case

R, B, C, MU = 0.01, 0.02, 1e-5, 0.01
OMEGA = 2 * math.pi * 3000 / 60


def _film(mesh_size: float, bushing=None):
    # the edges flooded 0.9 bar above the cavitation pressure
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU, inlet="none", cavitation_pressure=-0.9e5)
    return FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=mesh_size,
        cavitation="jfo",
        elastic=bushing,
    )


def _theta_z(film) -> tuple[np.ndarray, np.ndarray]:
    coords = film.space.owned_coords
    return np.arctan2(coords[:, 1], coords[:, 0]), coords[:, 2]


def _smooth(theta, z, width):
    return np.cos(theta) * (1 - (2 * z / width) ** 2) + 0.2 * np.sin(2 * theta)


@pytest.mark.serial
def test_a_film_state_is_carried_to_a_finer_mesh_at_second_order():
    with _film(0.05) as fine, _film(0.1) as middle, _film(0.2) as coarse:
        theta_f, z_f = _theta_z(fine)
        width = 2 * float(np.max(np.abs(z_f)))  # the film's width in its own coordinates
        # linear in z, with two modal coordinates after the nodal part: exact and copied
        theta_c, z_c = _theta_z(coarse)
        state = np.concatenate([0.3 - 1.7 * z_c, [1.5, -2.5]])
        mapped = fine.state_from(coarse, state)
        assert len(mapped) == fine.space.n + 2
        np.testing.assert_allclose(mapped[:-2], 0.3 - 1.7 * z_f, atol=1e-12)
        assert mapped[-2:].tolist() == [1.5, -2.5]
        # smooth and periodic in theta: second order in the source's element size
        errors = []
        for source in (coarse, middle):
            theta_s, z_s = _theta_z(source)
            carried = fine.state_from(source, _smooth(theta_s, z_s, width))
            errors.append(float(np.max(np.abs(carried - _smooth(theta_f, z_f, width)))))
        assert errors[0] / errors[1] >= 3.0, errors
        assert errors[1] < 0.02, errors  # (0.1 R elements: h^2 / 8 |f''| ~ 0.01 R^2 / 8 x 5)


@pytest.mark.serial
def test_the_layer_deformation_is_carried_as_a_second_nodal_part():
    layer = WinklerLayer(thickness=1.5e-3, E=115e9, nu=0.33)
    with _film(0.1, layer) as fine, _film(0.2, layer) as coarse:
        assert fine.solver.nodal_parts == coarse.solver.nodal_parts == 2
        theta_c, z_c = _theta_z(coarse)
        theta_f, z_f = _theta_z(fine)
        state = np.concatenate([1.0 + 0.5 * z_c, -0.25 + 2.0 * z_c])
        mapped = fine.state_from(coarse, state)
        n = fine.space.n
        np.testing.assert_allclose(mapped[:n], 1.0 + 0.5 * z_f, atol=1e-12)
        np.testing.assert_allclose(mapped[n:], -0.25 + 2.0 * z_f, atol=1e-12)


@pytest.mark.serial
def test_bad_start_mesh_sizes_are_one_line_errors(tmp_path):
    case = coarse_jfo_case(tmp_path / "finer", "start_mesh_size = 0.1\n")
    with pytest.raises(InputError, match=r"solver.start_mesh_size = 0.1 .*\(solver.mesh_size = 0.2, 1\)"):
        load_case(case)
    case = coarse_jfo_case(tmp_path / "short", 'start_mesh_size = 0.4\njoint = "short-bearing"\n')
    with pytest.raises(InputError, match=r"solver.start_mesh_size is for the finite-element film"):
        load_case(case)
