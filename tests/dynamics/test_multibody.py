"""Unit tests of solver.dynamics.multibody: constraint derivatives, force elements, reactions, projection.

Derivatives are checked against central differences of the functions they differentiate (an
independent computation: only ``phi``/``Q`` values are used, never the analytic derivative), and
the physics against textbook closed forms.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from solver.dynamics.integrate import integrate
from solver.dynamics.multibody import (
    AppliedForce,
    AppliedTorque,
    Body,
    ClearanceJointElement,
    Driver,
    Gravity,
    LinearClearanceJoint,
    Mechanism,
    MechanismError,
    Revolute,
    Translational,
    accelerations,
    joint_reactions,
    project_positions,
    project_velocities,
)
from solver.errors import InputError

RNG = np.random.default_rng(20240611)
BODIES = (Body("a", 1.2, 0.11), Body("b", 0.8, 0.05), Body("c", 2.0, 0.3))


def _rotation(angle):
    return np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])


def _cross(r, f):
    return r[0] * f[1] - r[1] * f[0]


def _central(function, x, step):
    columns = []
    for k in range(x.size):
        e = np.zeros_like(x)
        e[k] = step
        columns.append((function(x + e) - function(x - e)) / (2.0 * step))
    return np.array(columns).T


CONSTRAINTS = {
    "revolute": Revolute(0, (0.3, -0.1), 1, (0.2, 0.4), name="r"),
    "ground revolute": Revolute(2, (0.1, 0.2), None, (0.5, 0.3), name="g"),
    "translational": Translational(1, (0.2, 0.1), (0.6, 0.8), 0, (0.3, -0.2), offset=0.05, angle=0.3),
    "ground translational": Translational(2, (0.2, 0.1), (1.0, 0.3), None, (0.3, -0.2), offset=0.05),
    "driver": Driver(1, "phi", lambda t: (math.sin(t), math.cos(t), -math.sin(t)), name="d"),
}


@pytest.mark.parametrize("kind", CONSTRAINTS)
def test_constraint_jacobian_matches_finite_differences(kind):
    """Phi_q against central differences of Phi (step 1e-6: error ~1e-12 + round-off 1e-10 -> tol 1e-8)."""
    constraint = CONSTRAINTS[kind]
    q, t = RNG.normal(size=9), 0.7
    reference = _central(lambda x: constraint.phi(x, t), q, 1e-6)
    assert np.max(np.abs(constraint.jacobian(q, t) - reference)) < 1e-8


@pytest.mark.parametrize("kind", CONSTRAINTS)
def test_gamma_is_the_acceleration_free_part_of_the_second_derivative(kind):
    """Along q(s) = q + qd s + qdd s^2/2, t = t0 + s: d^2 Phi/ds^2 = Phi_q qdd - gamma (Nikravesh eq. 3.33).

    The second derivative by central differences with step 1e-4 has truncation ~1e-8 and round-off
    ~1e-16/1e-8 = 1e-8 for O(1) data, so the tolerance is 1e-6.
    """
    constraint = CONSTRAINTS[kind]
    q, qd, qdd, t = RNG.normal(size=9), RNG.normal(size=9), RNG.normal(size=9), 0.7
    step = 1e-4

    def path(s):
        return constraint.phi(q + qd * s + 0.5 * qdd * s * s, t + s)

    second = (path(step) - 2.0 * path(0.0) + path(-step)) / step**2
    gamma = constraint.jacobian(q, t) @ qdd - second
    assert np.max(np.abs(constraint.gamma(q, qd, t) - gamma)) < 1e-6
    phi_t = (constraint.phi(q, t + 1e-6) - constraint.phi(q, t - 1e-6)) / 2e-6
    assert np.max(np.abs(constraint.phi_t(q, t) - phi_t)) < 1e-8


@pytest.mark.parametrize("bodies", [(0, 1), (None, 1), (0, None), (2, 0)])
def test_clearance_kinematics_follow_their_definition(bodies):
    """e' = A_b^T (r_J - r_B) written out here; de'/dt as the central difference of e' along q + qd s."""
    journal, bushing = bodies
    joint = LinearClearanceJoint(1.0, 1.0)
    element = ClearanceJointElement(joint, journal, (0.1, -0.2), bushing, (0.3, 0.05))
    q, qd = RNG.normal(size=9), RNG.normal(size=9)

    def centre(x, body, point):
        if body is None:
            return np.asarray(point)
        return x[3 * body : 3 * body + 2] + _rotation(x[3 * body + 2]) @ np.asarray(point)

    def eccentricity(x):
        angle = 0.0 if bushing is None else x[3 * bushing + 2]
        return _rotation(angle).T @ (centre(x, journal, (0.1, -0.2)) - centre(x, bushing, (0.3, 0.05)))

    kin = element.kinematics(q, qd)
    rate = (eccentricity(q + 1e-6 * qd) - eccentricity(q - 1e-6 * qd)) / 2e-6
    omega_journal = 0.0 if journal is None else qd[3 * journal + 2]
    omega = omega_journal - (0.0 if bushing is None else qd[3 * bushing + 2])
    assert np.allclose(kin.ecc, eccentricity(q), rtol=0.0, atol=1e-14)
    assert np.allclose(kin.ecc_rate, rate, rtol=0.0, atol=1e-8)
    assert kin.omega_rel == pytest.approx(omega, abs=1e-15)


@pytest.mark.parametrize("bodies", [(0, 1), (None, 1), (0, None), (2, 0)])
def test_clearance_element_jacobians_match_finite_differences(bodies):
    """dQ/dq and dQ/dqd (chain rule of the element) against central differences of Q (tol 1e-7 on O(10))."""
    joint = LinearClearanceJoint(stiffness=7.0, damping=0.9, rotational_damping=0.3)
    element = ClearanceJointElement(joint, bodies[0], (0.1, -0.2), bodies[1], (0.3, 0.05))
    q, qd, t = RNG.normal(size=9), RNG.normal(size=9), 0.2
    evaluation = element.evaluate(BODIES, q, qd, t, jacobian=True)
    dQ_dq = _central(lambda x: element.evaluate(BODIES, x, qd, t).Q, q, 1e-6)
    dQ_dqd = _central(lambda x: element.evaluate(BODIES, q, x, t).Q, qd, 1e-6)
    assert np.max(np.abs(evaluation.dQ_dq - dQ_dq)) < 1e-7
    assert np.max(np.abs(evaluation.dQ_dqd - dQ_dqd)) < 1e-7


def test_clearance_element_loads_act_at_the_centres_and_balance():
    """Journal gets F = A_b F' at r_J plus T_j; bushing gets -F at r_B plus T_b (moments by hand)."""
    joint = LinearClearanceJoint(stiffness=1e6, damping=0.0, rotational_damping=2.0)
    element = ClearanceJointElement(joint, 0, (0.1, -0.2), 1, (0.3, 0.05))
    q, qd = RNG.normal(size=9) * 0.1, RNG.normal(size=9)
    kin = element.kinematics(q, qd)
    F_local = -1e6 * kin.ecc
    F = _rotation(q[5]) @ F_local
    torque = -2.0 * kin.omega_rel
    Q = element.evaluate(BODIES, q, qd, 0.0).Q
    lever_j = _rotation(q[2]) @ np.array([0.1, -0.2])
    lever_b = _rotation(q[5]) @ np.array([0.3, 0.05])
    assert np.allclose(Q[0:2], F, rtol=1e-14, atol=1e-9)
    assert np.allclose(Q[3:5], -F, rtol=1e-14, atol=1e-9)
    assert Q[2] == pytest.approx(_cross(lever_j, F) + torque, rel=1e-12)
    assert Q[5] == pytest.approx(_cross(lever_b, -F) - torque, rel=1e-12)
    assert np.all(Q[6:] == 0.0)
    journal, bushing = element.loads(q, qd, 0.0)
    assert np.allclose(journal, [F[0], F[1], torque]) and np.allclose(bushing, [-F[0], -F[1], -torque])


def test_linear_joint_jacobian_matches_finite_differences():
    """The 4 x 5 Jacobian of LinearClearanceJoint against central differences (linear: exact to round-off)."""
    joint = LinearClearanceJoint(3.0, 0.5, 0.25)
    z = RNG.normal(size=5)

    def values(x):
        result = joint.forces(x[0:2], x[2:4], x[4], 0.0)
        return np.concatenate([result.force, [result.journal_torque, result.bushing_torque]])

    reference = _central(values, z, 1e-3)
    assert np.allclose(joint.forces(z[0:2], z[2:4], z[4], 0.0, jacobian=True).jacobian, reference, atol=1e-12)


def test_applied_force_and_torque_generalized_forces_and_jacobians():
    """Q_phi = (A s') x F by hand; dQ/dq, dQ/dqd against central differences."""

    def force(t, q, qd):
        return np.array([q[0] ** 2 * qd[5], math.sin(q[5])])

    def force_jacobian(t, q, qd):
        dq, dqd = np.zeros((2, 9)), np.zeros((2, 9))
        dq[0, 0], dq[1, 5], dqd[0, 5] = 2.0 * q[0] * qd[5], math.cos(q[5]), q[0] ** 2
        return dq, dqd

    load = AppliedForce(1, (0.2, 0.3), force, force_jacobian)
    torque = AppliedTorque(
        2, lambda t, q, qd: 3.0 * q[8] + qd[1], lambda t, q, qd: (3.0 * np.eye(9)[8], np.eye(9)[1])
    )
    q, qd = RNG.normal(size=9), RNG.normal(size=9)
    Q = load.evaluate(BODIES, q, qd, 0.0).Q
    F = force(0.0, q, qd)
    assert np.allclose(Q[3:5], F)
    assert Q[5] == pytest.approx(_cross(_rotation(q[5]) @ [0.2, 0.3], F), rel=1e-13)
    for element in (load, torque):
        evaluation = element.evaluate(BODIES, q, qd, 0.0, jacobian=True)
        dQ_dq = _central(lambda x: element.evaluate(BODIES, x, qd, 0.0).Q, q, 1e-6)
        dQ_dqd = _central(lambda x: element.evaluate(BODIES, q, x, 0.0).Q, qd, 1e-6)
        assert np.max(np.abs(evaluation.dQ_dq - dQ_dq)) < 1e-8
        assert np.max(np.abs(evaluation.dQ_dqd - dQ_dqd)) < 1e-8


@pytest.mark.parametrize("angle, speed", [(0.0, 0.0), (0.4, 2.5), (-1.2, -1.0)])
def test_pendulum_acceleration_and_pin_reaction_from_the_multipliers(angle, speed):
    """Uniform bar (m, L) pinned at one end: theta_dd = -3 g cos(theta) / (2 L) (J_pivot = m L^2/3), and
    the pin force on the bar R = m a_G - m g (Newton's second law), a_G = L/2 (theta_dd n - theta_d^2 u).

    Both are textbook closed forms; the solve is direct, so the tolerance is round-off (1e-12 relative).
    """
    m, L, g = 1.7, 0.9, 9.81
    mechanism = Mechanism(
        (Body("bar", m, m * L**2 / 12.0),),
        (Revolute(0, (-L / 2, 0.0), None, (0.0, 0.0), name="pin"),),
        (Gravity((0.0, -g)),),
    )
    u = np.array([math.cos(angle), math.sin(angle)])
    n = np.array([-u[1], u[0]])
    q = np.array([*(L / 2 * u), angle])
    qd = np.array([*(L / 2 * speed * n), speed])
    Q = mechanism.forces(q, qd, 0.0).Q
    qdd, lam = accelerations(mechanism, q, qd, 0.0, Q)
    theta_dd = -3.0 * g * math.cos(angle) / (2.0 * L)
    a_G = L / 2 * (theta_dd * n - speed**2 * u)
    assert qdd[2] == pytest.approx(theta_dd, rel=1e-12)
    assert np.allclose(qdd[:2], a_G, rtol=1e-12, atol=1e-12)
    reaction = joint_reactions(mechanism, q, 0.0, lam)["pin"][0]
    assert np.allclose(reaction[:2], m * a_G - m * np.array([0.0, -g]), rtol=1e-12, atol=1e-12)
    # the pin force acts at the pin: its moment about the centre of mass is (-L/2 u) x R
    assert reaction[2] == pytest.approx(_cross(-L / 2 * u, reaction[:2]), abs=1e-12)


def test_projection_lands_on_the_manifold_with_a_minimal_correction():
    """Gauss-Newton projection: Phi(q) ~ 0 and the correction has no first-order component in the null
    space of Phi_q (least-norm; each iterate's correction is orthogonal to its own null space, so a
    second-order part ~ |offset|^2 remains: bound 10 |offset|^2, against ~|offset| = 1e-3 if it were
    not least-norm). Then Phi_q qd + Phi_t = 0 with an exactly orthogonal velocity correction."""
    mechanism = Mechanism(
        BODIES[:2],
        (
            Revolute(0, (-0.5, 0.0), None, (0.0, 0.0), name="g"),
            Revolute(0, (0.5, 0.0), 1, (-0.4, 0.0), name="r"),
        ),
    )
    exact = np.array([0.5, 0.0, 0.0, 1.4, 0.0, 0.0])
    q0 = exact + 1e-3 * RNG.normal(size=6)
    q = project_positions(mechanism, q0, 0.0)
    assert np.max(np.abs(mechanism.phi(q, 0.0))) <= 1e-12
    null = scipy.linalg.null_space(mechanism.jacobian(q, 0.0))
    assert np.max(np.abs(null.T @ (q - q0))) < 10.0 * np.max(np.abs(q0 - exact)) ** 2
    qd0 = RNG.normal(size=6)
    qd = project_velocities(mechanism, q, qd0, 0.0)
    assert np.max(np.abs(mechanism.jacobian(q, 0.0) @ qd)) < 1e-13
    assert np.max(np.abs(null.T @ (qd - qd0))) < 1e-13


def test_projection_of_an_impossible_configuration_raises():
    """Two ground pins 2 m apart on a 1 m bar cannot be assembled."""
    mechanism = Mechanism(
        (BODIES[0],),
        (
            Revolute(0, (-0.5, 0.0), None, (0.0, 0.0), name="left"),
            Revolute(0, (0.5, 0.0), None, (2.0, 0.0), name="right"),
        ),
    )
    with pytest.raises(MechanismError, match="did not converge"):
        project_positions(mechanism, np.zeros(3), 0.0)


def test_massless_free_body_is_reported():
    """A body without mass and without joints has no acceleration: singular augmented matrix."""
    mechanism = Mechanism((Body("ghost", 0.0, 0.0),))
    with pytest.raises(MechanismError, match="singular"):
        accelerations(mechanism, np.zeros(3), np.zeros(3), 0.0, np.zeros(3))


@pytest.mark.parametrize(
    "mass, inertia, field", [(-1.0, 1.0, "mass"), (1.0, -0.1, "inertia"), (math.nan, 1.0, "mass")]
)
def test_body_rejects_negative_or_nan_mass_and_inertia(mass, inertia, field):
    """A body needs mass >= 0 and inertia >= 0 (finite); the message names the body and the quantity."""
    with pytest.raises(InputError, match=f"body 'rod' {field} = .* is out of range"):
        Body("rod", mass, inertia)


def test_mechanism_rejects_a_joint_on_a_missing_body():
    """Joint body indices are checked when the mechanism is assembled."""
    with pytest.raises(InputError, match="refers to body 3"):
        Mechanism(BODIES, (Revolute(3, (0.0, 0.0), name="bad"),))


@pytest.mark.parametrize("method", ["RK45", "ESDIRK32"])
def test_error_controlled_integrators_converge_on_a_harmonic_oscillator(method):
    """Mass on a linear spring (a LinearClearanceJoint to the ground): x = x0 cos(omega t) exactly.

    With error-per-step control the global error of RK45 (5th order) and ESDIRK32 (3rd order, step from
    its 2nd-order embedded estimate) falls at least in proportion to rtol; a factor 1000 tighter rtol
    must reduce the error at least 100 times, and the error at rtol = 1e-8 is below 1e-6 x amplitude
    (global error = a modest multiple of rtol over 3 periods).
    """
    m, k = 2.0, 800.0
    omega = math.sqrt(k / m)
    spring = ClearanceJointElement(LinearClearanceJoint(k, 0.0), 0, (0, 0), None, (0, 0))
    mechanism = Mechanism((Body("mass", m, 1.0),), (), (spring,))
    t_end = 3 * 2 * math.pi / omega
    errors = []
    for rtol in (1e-5, 1e-8):
        run = integrate(
            mechanism,
            np.array([0.01, 0.0, 0.0]),
            np.zeros(3),
            (0.0, t_end),
            method=method,
            rtol=rtol,
            atol=1e-3 * rtol * 0.01,
        )
        errors.append(np.max(np.abs(run.q[:, 0] - 0.01 * np.cos(omega * run.t))))
    assert errors[1] < errors[0] / 100.0
    assert errors[1] < 1e-6 * 0.01
