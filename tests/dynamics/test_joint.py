"""Clearance-joint laws: closed forms, Jacobians against finite differences, the FE film joint."""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.dynamics.joint import DryContactJoint, FilmJoint, ShortBearingJoint, hertz_line_stiffness

R, B, C, MU = 0.01, 0.0025, 10e-6, 0.01


def _outputs(f):
    return np.array([*f.force, f.journal_torque, f.bushing_torque])


@pytest.mark.parametrize("eps", [0.2, 0.5, 0.8])
def test_short_bearing_rotation_is_ocvirk(eps):
    """Pure rotation: |F| = mu U B^3 eps / (4 c^2 (1 - eps^2)^2) sqrt(pi^2 (1 - eps^2) + 16 eps^2),
    U = R omega, attitude tan(phi) = pi sqrt(1 - eps^2) / (4 eps) (Ocvirk 1952); the journal torque
    is Petroff's -mu R^3 B omega 2 pi / (c sqrt(1 - eps^2)) minus e x F / 2. The integrand has kinks
    where the film ends (g = 0), so the 1440-point midpoint rule is second order there:
    (2 pi / 1440)^2 ~ 2e-5, tolerance 2e-5 (the Petroff part is smooth and periodic: 1e-9)."""
    joint = ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=MU)
    omega = 300.0
    f = joint.forces(np.array([eps * C, 0.0]), np.zeros(2), omega, 0.0)
    U = R * omega
    load = (
        MU
        * U
        * B**3
        * eps
        / (4 * C**2 * (1 - eps**2) ** 2)
        * math.sqrt(math.pi**2 * (1 - eps**2) + 16 * eps**2)
    )
    assert math.hypot(*f.force) == pytest.approx(load, rel=2e-5)
    attitude = math.atan2(f.force[1], -f.force[0])  # load line opposite the film force
    assert abs(attitude) == pytest.approx(math.atan(math.pi * math.sqrt(1 - eps**2) / (4 * eps)), rel=2e-5)
    e_cross_F = eps * C * f.force[1]
    couette = MU * R**3 * B * omega * 2 * math.pi / (C * math.sqrt(1 - eps**2))
    assert f.bushing_torque - f.journal_torque == pytest.approx(2 * couette, rel=1e-9)
    assert f.journal_torque + f.bushing_torque == pytest.approx(-e_cross_F, rel=1e-9)


def test_short_bearing_pure_squeeze_closed_form():
    """Pure squeeze along the line of centres (half-Sommerfeld): the integral of cos^2/(1 - eps cos)^3
    over the compressed half gives |F| = mu B^3 R edot / c^3 * integral, checked against quadrature of
    that closed integrand with scipy (1e-8)."""
    from scipy.integrate import quad

    joint = ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=MU)
    eps, rate = 0.5, 1e-3  # m/s
    f = joint.forces(np.array([eps * C, 0.0]), np.array([rate, 0.0]), 0.0, 0.0)
    integral = quad(
        lambda th: math.cos(th) ** 2 / (1 - eps * math.cos(th)) ** 3,
        -math.pi / 2,
        math.pi / 2,
        epsabs=0,
        epsrel=1e-12,
    )[0]
    assert f.force[0] == pytest.approx(-MU * B**3 * R * rate / C**3 * integral, rel=1e-8)
    assert abs(f.force[1]) < 1e-9 * abs(f.force[0])


@pytest.mark.parametrize(
    "joint",
    [
        ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=MU),
        DryContactJoint(radius=R, clearance=C, stiffness=hertz_line_stiffness(R, C, 210e9, 0.3, 115e9, 0.33)),
    ],
    ids=["short-bearing", "dry"],
)
def test_jacobian_matches_finite_differences(joint):
    """Complex-step Jacobians against central differences (relative steps 1e-6): 1e-5 of each row."""
    ecc = np.array([0.6, -0.9]) * C if isinstance(joint, DryContactJoint) else np.array([0.3, -0.5]) * C
    z = np.array([*ecc, 0.2 * C * 300, -0.1 * C * 300, -150.0])
    J = joint.forces(z[:2], z[2:4], z[4], 0.0, jacobian=True).jacobian
    J_fd = np.zeros((4, 5))
    for k in range(5):
        h = 1e-6 * max(abs(z[k]), C * 300 if k >= 2 else C)
        zp, zm = z.copy(), z.copy()
        zp[k] += h
        zm[k] -= h
        J_fd[:, k] = (
            _outputs(joint.forces(zp[:2], zp[2:4], zp[4], 0.0))
            - _outputs(joint.forces(zm[:2], zm[2:4], zm[4], 0.0))
        ) / (2 * h)
    for row in range(4):
        assert np.abs(J[row] - J_fd[row]).max() <= 1e-5 * np.abs(J_fd[row]).max()


def test_dry_contact_law():
    """Inside the clearance no force; a static penetration delta gives K delta^1.5 along -n, and the
    friction force opposes the slip with mu F_n (regularisation 1e-9 m/s, far below the slip)."""
    K = hertz_line_stiffness(R, C, 210e9, 0.3, 115e9, 0.33)
    joint = DryContactJoint(radius=R, clearance=C, stiffness=K, friction=0.1, slip_regularisation=1e-9)
    assert np.all(_outputs(joint.forces(np.array([0.99 * C, 0.0]), np.array([1.0, 0.0]), 10.0, 0.0)) == 0)
    delta = 1e-7
    n = np.array([math.cos(0.4), math.sin(0.4)])
    f = joint.forces((C + delta) * n, np.zeros(2), 0.0, 0.0)
    assert f.force @ n == pytest.approx(-K * delta**1.5, rel=1e-12)
    f = joint.forces((C + delta) * n, np.zeros(2), 5.0, 0.0)  # journal turns counter-clockwise
    t = np.array([-n[1], n[0]])
    assert f.force @ t == pytest.approx(-0.1 * K * delta**1.5, rel=1e-9)
    assert f.journal_torque == pytest.approx(-R * 0.1 * K * delta**1.5, rel=1e-9)


@pytest.mark.serial
def test_film_joint_approaches_short_bearing():
    """B/D = 1/8: the finite-element film and Ocvirk's short bearing agree within 3 % in force and
    torque under combined rotation and squeeze (the finite-length correction at B/D = 1/8 is ~2.5 %);
    NaN forces outside the clearance (the integrator's signal to retry)."""
    from solver.film.bearing import Bearing, FilmModel

    short = ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=MU)
    with FilmModel(
        Bearing(radius=R, width=B, clearance=C, viscosity=MU, inlet="none"),
        MPI.COMM_SELF,
        omega_ref=300.0,
        mesh_size=B / R / 10,
    ) as model:
        film = FilmJoint(model)
        for z in [(0.5 * C, 0.0, 0.0, 0.0, 300.0), (0.3 * C, -0.4 * C, 0.2 * C * 300, 0.1 * C * 300, -200.0)]:
            a = short.forces(np.array(z[:2]), np.array(z[2:4]), z[4], 0.0)
            b = film.forces(np.array(z[:2]), np.array(z[2:4]), z[4], 0.0)
            assert np.linalg.norm(np.subtract(a.force, b.force)) <= 0.03 * np.linalg.norm(a.force)
            assert b.journal_torque == pytest.approx(a.journal_torque, rel=0.03)
        outside = film.forces(np.array([C, 0.0]), np.zeros(2), 10.0, 0.0)
        assert np.all(np.isnan(outside.force))


@pytest.mark.serial
def test_film_moment_balance():
    """The massless film carries no net moment: T_journal + T_bushing + e' x F' = 0 (angular momentum
    balance; it makes the joint's dissipation independent of the frame's rotation), with asperity
    contact and friction and squeeze too (smooth flow factors: Patir & Cheng's averaged shear stresses
    with Phi_fp != 1 do not satisfy it exactly, which the joint's energy bookkeeping allows for). The
    torques use the integration by parts
    of the pressure term (integral of H dP/dtheta against P dH/dtheta), exact in the continuum and
    O(h^2) for P1 with a non-polynomial H: 1e-4 of |T_journal| (measured <= 1e-5)."""
    from solver.film.bearing import Bearing, FilmModel
    from solver.film.surface import Surface

    surface = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
    with FilmModel(
        Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none"),
        MPI.COMM_SELF,
        omega_ref=300.0,
        mesh_size=0.1,
        contact=surface.contact(),
        slip_regularisation=1e-6,
    ) as model:
        film = FilmJoint(model)
        for z in [
            (0.5 * C, 0.0, 0.0, 0.0, 300.0),
            (0.6 * C, -0.75 * C, 0.2 * C * 300, 0.1 * C * 300, -200.0),
        ]:
            f = film.forces(np.array(z[:2]), np.array(z[2:4]), z[4], 0.0)
            assert film.last_result.asperity_load > 0 or z[0] == 0.5 * C
            e_cross_F = z[0] * f.force[1] - z[1] * f.force[0]
            assert abs(f.journal_torque + f.bushing_torque + e_cross_F) <= 1e-4 * abs(f.journal_torque)
