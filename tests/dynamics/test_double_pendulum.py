"""A free double pendulum: energy conservation, constraint drift, and a very stiff clearance joint.

Two uniform bars (1.0 m, 1.0 kg and 0.8 m, 0.7 kg) in gravity, the upper pinned to the ground at its
end, the lower pinned to the upper's free end. Independent references: the total energy
``1/2 m v^2 + 1/2 J omega^2 + m g y`` written here (conserved exactly by the continuous system), and a
tightly integrated (DOP853, rtol 1e-12) ideal-joint solution for the stiff-joint test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.dynamics.integrate import Stepper, integrate
from solver.dynamics.multibody import (
    Body,
    ClearanceJointElement,
    Gravity,
    LinearClearanceJoint,
    Mechanism,
    Revolute,
)

G = 9.81
L1, L2, M1, M2 = 1.0, 0.8, 1.0, 0.7
ENERGY_SCALE = (M1 + M2) * G * (L1 + L2)  # J, largest potential-energy swing


def double_pendulum(stiff_joint: LinearClearanceJoint | None = None) -> Mechanism:
    bodies = (Body("upper", M1, M1 * L1**2 / 12.0), Body("lower", M2, M2 * L2**2 / 12.0))
    joints = [Revolute(0, (-L1 / 2, 0.0), None, (0.0, 0.0), name="shoulder")]
    forces = [Gravity((0.0, -G))]
    if stiff_joint is None:
        joints.append(Revolute(0, (L1 / 2, 0.0), 1, (-L2 / 2, 0.0), name="elbow"))
    else:  # journal on the lower bar's end, bushing in the upper bar's end
        forces.append(ClearanceJointElement(stiff_joint, 1, (-L2 / 2, 0.0), 0, (L1 / 2, 0.0), name="elbow"))
    return Mechanism(bodies, tuple(joints), tuple(forces))


def initial_state(angle_1: float, angle_2: float) -> tuple[np.ndarray, np.ndarray]:
    """Both bars at rest at the given angles from +x, assembled exactly."""
    end = L1 * np.array([math.cos(angle_1), math.sin(angle_1)])
    q = np.array(
        [
            L1 / 2 * math.cos(angle_1),
            L1 / 2 * math.sin(angle_1),
            angle_1,
            end[0] + L2 / 2 * math.cos(angle_2),
            end[1] + L2 / 2 * math.sin(angle_2),
            angle_2,
        ]
    )
    return q, np.zeros(6)


def energy(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Total mechanical energy (J) of each state, written out from the definitions."""
    kinetic = 0.5 * (
        M1 * (qd[:, 0] ** 2 + qd[:, 1] ** 2)
        + M1 * L1**2 / 12.0 * qd[:, 2] ** 2
        + M2 * (qd[:, 3] ** 2 + qd[:, 4] ** 2)
        + M2 * L2**2 / 12.0 * qd[:, 5] ** 2
    )
    return kinetic + G * (M1 * q[:, 1] + M2 * q[:, 4])


@pytest.mark.parametrize(
    "method, projection, rtols, t_end",
    [
        ("RK45", False, (1e-8, 1e-10), 3.0),
        ("DOP853", False, (1e-8, 1e-10), 3.0),
        ("Radau", False, (1e-6, 1e-8), 3.0),
        ("BDF", True, (1e-6, 1e-8), 3.0),
        ("ESDIRK32", False, (1e-5, 1e-7), 1.5),
    ],
)
def test_energy_of_the_free_double_pendulum_is_conserved_to_the_tolerance(method, projection, rtols, t_end):
    """From both bars horizontal-ish at rest (0 and 0.5 rad, a chaotic swing), |E(t) - E(0)| stays below
    10 rtol of the energy scale (m1 + m2) g (l1 + l2), and falls at least 10-fold when rtol falls
    100-fold: the energy error is the integrator's error, nothing else. Measured ratios |dE|/(E_s rtol):
    RK45 0.8/0.5, DOP853 0.3/0.6, Radau < 0.02, BDF with projection 1.0/3.5, ESDIRK32 ~5 (third order).
    (BDF without projection lets the drift feed the energy error: ~100 rtol; see the drift test.)
    """
    mechanism = double_pendulum()
    q0, qd0 = initial_state(0.0, 0.5)
    errors = []
    for rtol in rtols:
        run = integrate(
            mechanism,
            q0,
            qd0,
            (0.0, t_end),
            method=method,
            rtol=rtol,
            atol=1e-2 * rtol,
            projection=projection,
        )
        e = energy(run.q, run.qd)
        errors.append(np.max(np.abs(e - e[0])) / ENERGY_SCALE)
        assert errors[-1] < 10.0 * rtol, (rtol, errors[-1])
    assert errors[1] < errors[0] / 10.0


def test_constraint_drift_with_baumgarte_and_with_projection(record_property):
    """Drift max |Phi| over 10 s (RK45, rtol 1e-6; the pendulum swings chaotically), reported as test
    properties. Without stabilisation it wanders at the integration error (measured ~3e-5 m);
    Baumgarte (alpha = beta = 10/s) bounds it at least 10 times lower and it does not grow (second half
    <= 2 x first half; measured ~1.5e-7 m); projection after every step holds it at the projection
    tolerance 1e-12 m (positions) and round-off (velocities), also with BDF's projected history and
    with ESDIRK32."""
    mechanism = double_pendulum()
    q0, qd0 = initial_state(0.0, 0.5)

    def drift(**options):
        t_end = options.pop("t_end", 10.0)
        run = integrate(mechanism, q0, qd0, (0.0, t_end), rtol=1e-6, atol=1e-8, **options)
        halves = run.t <= t_end / 2
        violation = run.position_violation
        return violation[halves].max(), violation[~halves].max(), run.velocity_violation.max()

    free = drift(method="RK45")
    baumgarte = drift(method="RK45", alpha=10.0, beta=10.0)
    projected = {
        method: drift(method=method, projection=True, t_end=10.0 if method != "ESDIRK32" else 2.0)
        for method in ("RK45", "BDF", "ESDIRK32")
    }
    record_property("drift_none_m", max(free[:2]))
    record_property("drift_baumgarte_m", max(baumgarte[:2]))
    for method, values in projected.items():
        record_property(f"drift_projection_{method}_m", max(values[:2]))
    assert max(baumgarte[:2]) < max(free[:2]) / 10.0
    assert max(baumgarte[:2]) < 1e-6 and baumgarte[1] <= 2.0 * baumgarte[0]
    for method, (first, second, velocity) in projected.items():
        assert max(first, second) <= 1e-12, method
        assert velocity < 1e-12, method


@pytest.mark.parametrize("stiffness, damping", [(1e10, 1e6), (1e12, 1e7)])
def test_implicit_integrator_takes_accuracy_sized_steps_on_a_very_stiff_joint(stiffness, damping):
    """The elbow as a linear spring-damper of 1e10 N/m, 1e6 N s/m (and 1e12, 1e7): the fast mode decays at
    a rate of at least c / m_lower ~ 1.4e6 /s (1.4e7), so an explicit method (RK45's real stability limit
    h |lambda| < 3.3) would need at least T c / (3.3 m_lower) = 4.3e5 (4.3e6) steps in T = 1 s.

    ESDIRK32 with the joint's Jacobians must (a) take at most twice the steps it takes with an ideal
    elbow (measured ratio 1.3 and 1.75), i.e. < 1e-3 of the explicit bound; (b) evaluate the forces
    without Jacobian only at the start (every Newton iteration gets Q and the joint's exact Jacobian from
    one call; no finite differences of the joint); (c) follow the tight ideal
    solution within 100 rtol x (l1 + l2) (the joint deflection ~ F/k ~ 1e-9 m is negligible; measured
    6e-6 m).
    """
    q0, qd0 = initial_state(-math.pi / 2 + 0.6, -math.pi / 2 + 0.3)
    t_end, rtol = 1.0, 1e-6
    outputs = np.linspace(0.0, t_end, 11)
    reference = integrate(
        double_pendulum(), q0, qd0, (0.0, t_end), method="DOP853", rtol=1e-12, atol=1e-14, t_eval=outputs
    )
    ideal = integrate(
        double_pendulum(), q0, qd0, (0.0, t_end), method="ESDIRK32", rtol=rtol, atol=1e-2 * rtol
    )
    stiff = integrate(
        double_pendulum(LinearClearanceJoint(stiffness, damping)),
        q0,
        qd0,
        (0.0, t_end),
        method="ESDIRK32",
        rtol=rtol,
        atol=1e-2 * rtol,
        t_eval=outputs,
    )
    explicit_bound = t_end * damping / (3.3 * M2)
    assert stiff.n_steps <= 2.0 * ideal.n_steps
    assert stiff.n_steps < 1e-3 * explicit_bound
    assert stiff.n_jacobian_evaluations > 0 and stiff.n_force_evaluations <= 3
    assert np.max(np.abs(stiff.q - reference.q)) < 100.0 * rtol * (L1 + L2)


def test_simplified_newton_with_kept_jacobian_gives_the_same_solution_with_fewer_jacobians():
    """ESDIRK32 with ``jacobian_reuse`` (simplified Newton, Jacobian refreshed when Newton contracts
    slowly) on the elbow as a 1e8 N/m, 1e4 N s/m joint (stiff: fast mode ~1.4e4 /s against ~10 /s of
    the swing): (a) the accuracy bound of the test above against the tight DOP853 reference,
    100 rtol x (l1 + l2) (the Newton variant changes only how the stage equations are solved, to the
    same tolerance); (b) at most half the Jacobian evaluations of full Newton (measured 0.38);
    (c) at most 1.1 x its steps (measured 1.0). With 1e10 N/m and more, the stiff direction turns
    too fast with the links for a kept Jacobian (more steps): full Newton stays the default there; the
    engine's small end, between a slowly turning rod and the piston, is the case reuse is made for.
    """
    q0, qd0 = initial_state(-math.pi / 2 + 0.6, -math.pi / 2 + 0.3)
    t_end, rtol = 1.0, 1e-6
    outputs = np.linspace(0.0, t_end, 11)
    reference = integrate(
        double_pendulum(), q0, qd0, (0.0, t_end), method="DOP853", rtol=1e-12, atol=1e-14, t_eval=outputs
    )
    runs = {
        reuse: integrate(
            double_pendulum(LinearClearanceJoint(1e8, 1e4)),
            q0,
            qd0,
            (0.0, t_end),
            method="ESDIRK32",
            rtol=rtol,
            atol=1e-2 * rtol,
            t_eval=outputs,
            jacobian_reuse=reuse,
        )
        for reuse in (False, True)
    }
    full, kept = runs[False], runs[True]
    assert np.max(np.abs(kept.q - reference.q)) < 100.0 * rtol * (L1 + L2)
    assert kept.n_jacobian_evaluations <= full.n_jacobian_evaluations / 2
    assert kept.n_steps <= 1.1 * full.n_steps
    assert kept.jacobian is not None and kept.jacobian.shape == (2 * kept.q.shape[1],) * 2


def test_on_step_is_called_once_per_accepted_step_after_its_last_stage():
    """``integrate(on_step=...)``, where a joint with history commits its state: called once per
    accepted step (the Trajectory's n_steps, counted independently), never for a rejected one, at
    strictly increasing times ending at t_end, and each time right after a force evaluation at that very
    time (the step's last stage, c = 1), so that the joint's last evaluated state is the step's end.
    The stiff elbow (1e10 N/m) and a first step far too long make the integrator reject steps."""

    class Recording(LinearClearanceJoint):
        def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):  # noqa: D102
            evaluations.append(t)
            return super().forces(ecc, ecc_rate, omega_rel, t, jacobian)

    evaluations: list[float] = []
    calls: list[tuple[float, float]] = []  # (time of the call, time of the last force evaluation)
    q0, qd0 = initial_state(-math.pi / 2 + 0.6, -math.pi / 2 + 0.3)
    t_end = 0.2
    run = integrate(
        double_pendulum(Recording(1e10, 1e6)),
        q0,
        qd0,
        (0.0, t_end),
        method="ESDIRK32",
        rtol=1e-6,
        atol=1e-8,
        first_step=0.1,
        on_step=lambda t: calls.append((t, evaluations[-1])),
    )
    assert run.n_rejected > 0
    assert len(calls) == run.n_steps
    times = np.array([c[0] for c in calls])
    assert np.all(np.diff(times) > 0) and times[-1] == t_end
    assert all(t == last for t, last in calls)


def test_stage_values_are_integrated_by_the_methods_quadrature_over_accepted_steps_only():
    """``integrate(stage_values=...)`` sums ``h sum_j b_j v_j`` over the accepted steps. (a) The
    quadrature of ESDIRK32 is exact for polynomials of degree 2 in t (its order conditions
    ``b . c^k = 1/(k+1)``, k <= 2): the integrals of 1, t, t^2 over [0, T] to 1e-12 relative, on a run
    whose too long first step is rejected (a rejected attempt's stages must not count); t^3 is not
    exact (error > 1e-12: the test can fail). (b) The energy dissipated by a damped elbow
    (``c |de/dt|^2 + c_r omega_rel^2``, 1e5 N/m, 500 N s/m, 0.2 N m s) integrated along the stages,
    with the work of the shoulder's reaction on the velocity residual (``-lambda^T (Phi_q qd + Phi_t)``,
    no stabilisation here), closes the balance of mechanical plus spring energy to 10 rtol of the
    energy scale (the dissipated energy is at least 100 x that) and falls at least 5-fold when rtol
    falls 100-fold (measured 1.3e-7 and 1.3e-8 of the scale at rtol 1e-6 and 1e-8): the integrator's
    own error."""
    joint = LinearClearanceJoint(1e5, 500.0, 0.2)
    mechanism = double_pendulum(joint)
    element = mechanism.force_elements[1]
    q0, qd0 = initial_state(-math.pi / 2 + 0.6, -math.pi / 2 + 0.3)
    t_end = 0.5

    run = integrate(
        mechanism,
        q0,
        qd0,
        (0.0, t_end),
        method="ESDIRK32",
        rtol=1e-6,
        atol=1e-8,
        first_step=0.2,
        stage_values=lambda t, y, qdd, lam: np.array([1.0, t, t**2, t**3]),
    )
    assert run.n_rejected > 0
    exact = np.array([t_end, t_end**2 / 2, t_end**3 / 3, t_end**4 / 4])
    errors = np.abs(run.stage_integral - exact) / exact
    assert np.all(errors[:3] < 1e-12), errors
    assert errors[3] > 1e-12, errors

    def powers(t, y, qdd, lam):
        q, qd = y[:6], y[6:]
        kin = element.kinematics(q, qd)
        dissipated = (
            joint.damping * float(kin.ecc_rate @ kin.ecc_rate) + joint.rotational_damping * kin.omega_rel**2
        )
        drift = -float(lam @ (mechanism.jacobian(q, t) @ qd + mechanism.phi_t(q, t)))
        return np.array([dissipated, drift])

    def total_energy(q, qd):
        ecc = element.kinematics(q, qd).ecc
        return energy(q[None], qd[None])[0] + 0.5 * joint.stiffness * float(ecc @ ecc)

    errors = []
    for rtol in (1e-6, 1e-8):
        run = integrate(
            mechanism,
            q0,
            qd0,
            (0.0, t_end),
            method="ESDIRK32",
            rtol=rtol,
            atol=1e-2 * rtol,
            stage_values=powers,
        )
        dissipated, drift = run.stage_integral
        change = total_energy(run.q[-1], run.qd[-1]) - total_energy(run.q[0], run.qd[0])
        assert dissipated > 1000.0 * rtol * ENERGY_SCALE  # 100 x the bound below: not trivially small
        errors.append(abs(change + dissipated - drift) / ENERGY_SCALE)
        assert errors[-1] < 10.0 * rtol, (rtol, errors[-1])
    assert errors[1] < errors[0] / 5.0, errors


def test_the_stepper_ends_a_step_at_each_time_asked_and_keeps_its_state_between_them():
    """``Stepper.advance_to(t)`` ends a step exactly at t and keeps ESDIRK32's state (step size, kept
    Jacobian, interpolant) from one output time to the next, as the engine's cycle uses it (an output
    every 0.1 s, the stiff 1e8 N/m elbow with simplified Newton): (a) each time reached is the output
    exactly, and ``on_step`` is called once per accepted step (its counter, counted independently);
    (b) each advance's ``stage_integral`` is that interval's own: the integrals of 1, t, t^2 to 1e-12
    relative (the quadrature is exact for them); (c) the same accuracy bound as integrate() against the
    tight DOP853 reference, 100 rtol x (l1 + l2); (d) all of it also with a restart from the state
    reached at every output (as the engine's cycle does after projecting its velocities there)."""
    q0, qd0 = initial_state(-math.pi / 2 + 0.6, -math.pi / 2 + 0.3)
    outputs = np.linspace(0.0, 1.0, 11)
    reference = integrate(
        double_pendulum(), q0, qd0, (0.0, 1.0), method="DOP853", rtol=1e-12, atol=1e-14, t_eval=outputs
    )
    rtol = 1e-6
    states = {}
    for restart in (False, True):
        calls: list[float] = []
        stepper = Stepper(
            double_pendulum(LinearClearanceJoint(1e8, 1e4)),
            0.0,
            q0,
            qd0,
            rtol=rtol,
            atol=1e-2 * rtol,
            jacobian_reuse=True,
            on_step=calls.append,
            stage_values=lambda t, y, qdd, lam: np.array([1.0, t, t**2]),
        )
        q = [q0]
        for a, b in zip(outputs[:-1], outputs[1:]):
            q_b, qd_b = stepper.advance_to(b)
            assert stepper.t == b and calls[-1] == b
            exact = np.array([b - a, (b**2 - a**2) / 2, (b**3 - a**3) / 3])
            assert np.all(np.abs(stepper.stage_integral - exact) <= 1e-12 * exact)
            q.append(q_b)
            if restart:
                stepper.restart(q_b, qd_b)
        assert len(calls) == stepper.steps and stepper.jacobian_evaluations < stepper.force_evaluations
        states[restart] = np.array(q)
        assert np.max(np.abs(states[restart] - reference.q)) < 100.0 * rtol * (L1 + L2)
