"""Friction in a cavitated film: the mass-conserving (JFO) film's Couette shear weighted by the film
fraction theta, ``tau = theta mu (U1 - U2)/h -/+ h/2 dp/dx`` (solver.film.forms; Elrod's model).

References, each independent of the film's forms:

1. A grooved bearing with mass-conserving cavitation (ruptured area ~0.4): the film's friction torques on
   journal and bushing against a numpy quadrature written here from the mesh's nodes and the film's
   nodal theta and pressure, with the thickness from the eccentricity (closed form), the SI
   shear stresses above and the rules the film states it uses (midpoint for the Couette part, the
   three-point degree-2 rule for the pressure part). With ``cavitated_shear = "full"`` the same
   quadrature with theta = 1 (the friction before the change; the pressure and theta do not depend on
   the choice).
2. Petroff with a forced film fraction: a concentric film with flooded edges has no pressure, so its
   torque is Petroff's ``2 pi mu Omega R^3 B / c`` times the mean of theta over the bearing; with theta
   = 1 on half of the circumference and 1 - 0.6 sin^2(angle) on the other half the mean is 0.85.
3. The Jacobian's torque rows (the film fraction's sensitivities included) against central
   differences, row by row.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.errors import InputError
from solver.film.bearing import Bearing, FilmModel, Kinematics

pytestmark = pytest.mark.serial

R, B, C, MU = 0.01, 0.02, 1e-5, 0.01
OMEGA = 2 * math.pi * 3000 / 60
GROOVE = dict(
    groove="axial",
    groove_angle=math.pi / 2,
    groove_arc=math.radians(20),
    groove_length=0.012,
    supply_pressure=2e5,
)


def _grooved(shear: str, mesh_size: float = 0.1):
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU, inlet="none", **GROOVE)
    return FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=mesh_size,
        cavitation="jfo",
        cavitated_shear=shear,
    )


def _quadrature_torques(model, kin: Kinematics, theta: np.ndarray, p: np.ndarray) -> tuple[float, float]:
    """(journal, bushing) friction torques [N m] from the nodal theta and p [Pa] on the film's mesh (the
    unit cylinder, z / R axially), in numpy: ``T = R integral(tau dA)`` with
    ``tau_journal = theta mu (U1 - U2)/h - h/2 dp/dx``, ``tau_bushing = -theta mu (U1 - U2)/h - h/2 dp/dx``,
    U1 = 0 (bushing), U2 = R Omega, h = c (1 - e.(cos, sin)/c), x = R angle, dA = R^2 dA_mesh; the
    Couette part by the midpoint rule (theta at the centroid: the mean of its vertices; cos, sin of the
    centroid's angle), the pressure part by the three-point degree-2 rule (dp/dx from the P1 gradient
    of the flat triangle along the tangent at each point). Doubled when the mesh is the half z >= 0."""
    V = model.V
    n_cells = V.mesh.topology.index_map(2).size_local
    cells = V.dofmap.list.array.reshape(-1, 3)[:n_cells]
    X = V.tabulate_dof_coordinates()[cells]  # (cell, vertex, xyz)
    E = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]], axis=2)  # (cell, xyz, 2)
    EtE = np.einsum("cki,ckj->cij", E, E)
    area = 0.5 * np.sqrt(np.linalg.det(EtE))
    dp = np.stack([p[cells[:, 1]] - p[cells[:, 0]], p[cells[:, 2]] - p[cells[:, 0]]], axis=1)
    grad_p = np.einsum("cki,cij,cj->ck", E, np.linalg.inv(EtE), dp)  # tangential gradient, Pa per unit
    ex, ey = kin.ecc[0] / C, kin.ecc[1] / C
    U_rel = -R * (kin.omega_journal - kin.omega_bushing)  # U1 - U2

    def thickness(x):
        r = np.hypot(x[..., 0], x[..., 1])
        return C * (1.0 - ex * x[..., 0] / r - ey * x[..., 1] / r)

    centroid = X.mean(axis=1)
    couette = np.sum(area * theta[cells].mean(axis=1) * MU * U_rel / thickness(centroid)) * R**3
    pressure = 0.0
    for xi in ((1 / 6, 1 / 6), (2 / 3, 1 / 6), (1 / 6, 2 / 3)):
        x = X[:, 0] + np.einsum("cki,i->ck", E, np.array(xi))
        r = np.hypot(x[:, 0], x[:, 1])
        dp_dx = (-x[:, 1] / r * grad_p[:, 0] + x[:, 0] / r * grad_p[:, 1]) / R  # along +angle, per m
        pressure += np.sum(area / 3.0 * (-thickness(x) / 2.0 * dp_dx)) * R**3
    z = X[..., 2]
    whole = 2.0 if z.min() > -1e-12 else 1.0
    return whole * (couette + pressure), whole * (-couette + pressure)


@pytest.mark.parametrize("shear", ["film-fraction", "full"])
def test_grooved_bearing_torques_match_a_quadrature_of_the_nodal_fields(shear):
    """Steady grooved JFO bearing at eps = 0.6 (3000 rpm, 2 bar in a 20 deg axial groove): journal and
    bushing torques equal the numpy quadrature (module docstring) to 1e-9 relative: the same rules on
    the same nodal values, so only round-off in sums over ~2000 cells separates them (measured ~1e-14).
    With the film fraction the cavitated zone's shear is weighted by theta (< 1 there) and the torque
    is 5 % to 30 % below the full film's (measured 13 %)."""
    kin = Kinematics((0.0, -0.6 * C), (0.0, 0.0), OMEGA, 0.0)
    with _grooved(shear) as model:
        result = model.solve(kin)
        assert 0.2 < result.cavitated_area_ratio < 0.7  # the film ruptures: theta < 1 matters
        fields = model.fields_si()
        n = model.V.dofmap.index_map.size_local
        theta = fields["film_fraction"].x.array[:n]
        p = fields["pressure"].x.array[:n]
        assert theta.min() < 0.5
        weights = theta if shear == "film-fraction" else np.ones(n)
        journal, bushing = _quadrature_torques(model, kin, weights, p)
        assert result.torque_journal == pytest.approx(journal, rel=1e-9)
        assert result.torque_bushing == pytest.approx(bushing, rel=1e-9)
        full_journal, _ = _quadrature_torques(model, kin, np.ones(n), p)
    if shear == "film-fraction":
        assert 0.05 < 1.0 - journal / full_journal < 0.3


def test_forced_film_fraction_gives_petroff_times_its_mean():
    """Concentric film (no pressure: edges flooded at p_cav = -0.5 bar, nothing drives a flow; the JFO
    film's theta is then 1 everywhere), the film
    fraction set by hand to theta = 1 on angles (0, pi) and 1 - 0.6 sin^2 on (pi, 2 pi): the journal
    torque is -Petroff x mean(theta) = -0.85 Petroff. Petroff's torque of the faceted film (theta = 1)
    is within 1e-3 of 2 pi mu Omega R^3 B / c (the polygon's area, 1 - h^2/6 with h = 0.05, and the
    thickness at the flat cells' centroids); the ratio of the two torques is 0.85 to the midpoint rule's
    error in theta (0.6 h^2 / 8 ~ 2e-4 at most; tolerance 1e-3)."""
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU, inlet="none", cavitation_pressure=-0.5e5)
    kin = Kinematics((0.0, 0.0), (0.0, 0.0), OMEGA, 0.0)
    petroff = 2 * math.pi * MU * OMEGA * R**3 * B / C
    with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.05, cavitation="jfo") as model:
        result = model.solve(kin)
        assert result.cavitated_area_ratio == 0.0
        # no pressure but the faceted mesh's: the Couette flux's discrete divergence on flat cells leaves
        # |P| ~ 2e-6 p_ref (measured), a pressure torque ~1e-5 of the Couette one
        assert np.max(np.abs(model.pressure.x.array)) < 1e-5
        assert result.torque_journal == pytest.approx(-petroff, rel=1e-3)
        n = model.V.dofmap.index_map.size_local
        x = model.V.tabulate_dof_coordinates()[:n]
        angle = np.arctan2(x[:, 1], x[:, 0]) % (2 * math.pi)
        theta = np.where(angle <= math.pi, 1.0, 1.0 - 0.6 * np.sin(angle) ** 2)
        model.forms.set_film_fraction(theta)
        forced = model.forms.values(model.forms.contact_cells())
    assert forced["torque_journal"] / result.torque_journal == pytest.approx(0.85, abs=1e-3)
    assert forced["torque_bushing"] / result.torque_bushing == pytest.approx(0.85, abs=1e-3)


def test_reynolds_film_and_full_shear_are_unweighted():
    """The Reynolds VI film has no film fraction (its forms weight nothing); a JFO film with
    cavitated_shear 'full' neither; an unknown choice is a one-line InputError naming key and flag."""
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU, inlet="none", **GROOVE)
    for options in (dict(cavitation="reynolds"), dict(cavitation="jfo", cavitated_shear="full")):
        with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.2, **options) as model:
            assert model.forms.film_fraction is None
    with pytest.raises(InputError, match=r"oil.cavitated_shear = 'half' \(--cavitated-shear half\)"):
        FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, cavitation="jfo", cavitated_shear="half")


def test_torque_rows_of_the_jacobian_match_finite_differences():
    """A transient, cavitated state of the grooved film (a step from a committed steady state, bushing
    turning): the torque rows against central differences row by row, to 1e-5 of the row's largest
    entry (the steps keep the partition: the differences' truncation error is ~1e-8). Without the film
    fraction's sensitivities the rows are off by ~3e-2 of it (measured)."""
    with _grooved("film-fraction") as model:
        model.solve(Kinematics((0.0, -0.6 * C), (0.0, 0.0), OMEGA, 0.0), 0.0)
        model.commit_history(model.history_state(), 0.0)
        t, omega_b = 5e-5, 30.0
        x0 = np.array([0.3e-6, -6.2e-6, 0.01, -0.004, OMEGA - omega_b])

        def torques(x):
            r = model.solve(Kinematics((x[0], x[1]), (x[2], x[3]), x[4] + omega_b, omega_b), t)
            return np.array([r.torque_journal, r.torque_bushing])

        result = model.solve(Kinematics(tuple(x0[:2]), tuple(x0[2:4]), OMEGA, omega_b), t)
        assert 0.2 < result.cavitated_area_ratio < 0.7
        J = model.jacobian().matrix[2:]
        columns = []
        for k, step in enumerate((1e-10, 1e-10, 1e-5, 1e-5, 1e-3)):
            e = np.zeros(5)
            e[k] = step
            columns.append((torques(x0 + e) - torques(x0 - e)) / (2 * step))
    J_fd = np.column_stack(columns)
    for row in range(2):
        assert np.max(np.abs(J[row] - J_fd[row])) <= 1e-5 * np.max(np.abs(J_fd[row])), (J[row], J_fd[row])
