"""The energy audit of a coupled cycle: the joints' powers, the mechanical energy and the work columns.

Per output state: input power (crank + gas + gravity), mechanical energy, and the power dissipated in the
joint ``D = -(F' . de'/dt + T_j omega_rel + omega_b (T_j + T_b + e' x F'))`` (the last term vanishes when the
film's moment balance holds), summed over the clearance joints (small end, big end, a floating pin's bosses).
The audit (``ENERGY_COLUMNS``, cumulative over the cycle) closes ``input_work - change of mechanical energy =
dissipated_energy - drift_work`` to the integration's accuracy (measured 5e-5 to 1.5e-3 of the dissipated
energy at the default resolutions, 7e-3 on a coarse JFO run): the dissipation and the drift's work integrated
along the integrator's stages (:meth:`EnergyAudit.stage_powers`), the driver's work from the crank's
generalized momentum (:func:`input_work`).
"""

from __future__ import annotations

import math

import numpy as np

from solver.dynamics.engine import CRANK, PIN, ROD

#: The energy audit of a cycle (results.nc, J, cumulative from its start): the input work (crank driver
#: from its generalized momentum, and gas), and, integrated along the integrator's stages, the energy
#: dissipated in the joint and the drift's work (solver.study.cycles)
ENERGY_COLUMNS = ("input_work", "dissipated_energy", "drift_work")
STAGE_COLUMNS = ENERGY_COLUMNS[1:]

#: private columns of a cycle's states that input_work is computed from (and removes)
MOMENTUM_COLUMNS = ("_crank_momentum", "_crank_momentum_arrival", "_crank_momentum_source", "_crank_speed")


def input_work(columns: dict[str, np.ndarray]) -> np.ndarray:
    """Work of the crank driver and the gas since the cycle's start [J], at the outputs; pops the
    private columns of the crank's generalized momentum that it is computed from
    (:meth:`EnergyAudit.crank_momentum`).

    The driver's torque carries the stiff joint's force, which varies within a degree where the pin
    crosses its clearance. Its power (kW, against a joint dissipating a few W) is then undersampled on
    the outputs: Simpson's rule on the same JFO run sampled every 0.5, 1 or 2 deg put its energy balance
    at -0.6, +1.4 and -2.0 % (the dissipated energy moved by 0.01 %). Its impulse is therefore taken
    from the momentum theorem, ``int tau dt = p(t) - p(0) - int s dt``, whose integrand s (the gas,
    gravity and joint loads on a crank rotation at fixed eccentricity, and the rate of that direction)
    is smooth; then ``int omega dI`` (exact at constant speed), and the gas power (smooth) by the
    trapezoidal rule. The same run's audit then moved by less than 0.03 % between those samplings.
    """
    p, arrival, rate, omega = (columns.pop(k) for k in MOMENTUM_COLUMNS)
    t = columns["time"]
    dt = np.diff(t)
    # each output interval from the projected state to the integrator's arrival: the projection of the
    # velocities at the outputs is no impulse of the driver (its energy is in drift_work)
    impulse = np.concatenate([[0.0], np.cumsum(arrival[1:] - p[:-1] - 0.5 * dt * (rate[1:] + rate[:-1]))])
    driver = np.concatenate([[0.0], np.cumsum(0.5 * (omega[1:] + omega[:-1]) * np.diff(impulse))])
    gas_power = -columns["F_gas"] * columns["v_piston"]
    gas = np.concatenate([[0.0], np.cumsum(0.5 * dt * (gas_power[1:] + gas_power[:-1]))])
    return driver + gas


def joint_powers(kin, forces, qd, bushing_body: int | None = ROD) -> tuple[float, float, float]:
    """(squeeze, friction, dissipated) power of a clearance joint's forces at a state [W]; its bushing in
    ``bushing_body`` (the rod: the small end's or the big end's; the piston: the floating pin's bosses)."""
    F_b = np.asarray(forces.force)  # bushing on pin, bushing frame
    omega_b = 0.0 if bushing_body is None else float(qd[3 * bushing_body + 2])
    squeeze = -float(F_b @ kin.ecc_rate)
    friction = -forces.journal_torque * kin.omega_rel
    moment = forces.journal_torque + forces.bushing_torque + float(kin.ecc[0] * F_b[1] - kin.ecc[1] * F_b[0])
    return squeeze, friction, squeeze + friction - omega_b * moment


def kept_motion(em, q, t: float) -> np.ndarray:
    """The rows whose velocity a projection prescribes: ``Phi_q`` and, for each clearance joint (small
    end, big end, the floating pin's bosses), ``d(de'/dt)/dqd`` (its eccentricity rate, kept), and with a
    floating pin its angular speed (kept), shape (n_coordinates, n_coordinates)."""
    rows = [em.mechanism.jacobian(q, t)]
    for element in em.clearance_joints.values():
        rows.append(element.kinematics(q, np.zeros_like(q)).dz_dqd[2:4])
    if em.floating_pin:
        row = np.zeros((1, q.size))
        row[0, 3 * PIN + 2] = 1.0
        rows.append(row)
    return np.vstack(rows)


class EnergyAudit:
    """The energy terms of one engine mechanism (``em``, solver.dynamics.engine.build_mechanism) at its
    states: mechanical energies, the crank's generalized momentum, and the powers along the stages."""

    #: s, time step of the central difference of the crank direction along the motion (crank_momentum)
    DIRECTION_STEP = 1e-7

    def __init__(self, em, gravity: float):
        self.em, self.gravity = em, gravity

    def energies(self, q, qd) -> tuple[float, float]:
        """(kinetic, gravitational potential) energy of the mechanism [J]."""
        mech = self.em.mechanism
        masses = mech.mass_matrix.diagonal()
        x_cm = np.array([q[3 * i] for i in range(len(mech.bodies))])
        m = np.array([b.mass for b in mech.bodies])
        return 0.5 * float(np.sum(masses * qd**2)), float(np.sum(m * self.gravity * x_cm))

    def _crank_direction(self, q, t: float) -> np.ndarray:
        """V: the velocities of a unit crank speed that keep the clearance joints' eccentricities (and
        every constraint but the driver's), ``Phi_q V = e_driver``, ``de/dt(V) = 0``."""
        A = kept_motion(self.em, q, t)
        rhs = np.zeros(len(A))
        rhs[self.em.mechanism.rows["crank_driver"]] = 1.0
        return np.linalg.solve(A, rhs)

    def crank_momentum(self, t: float, q, velocities: tuple, Q) -> tuple[tuple[float, ...], float]:
        """((p for each of ``velocities``), s) with p = V . M qd the crank's generalized momentum at fixed
        eccentricity [N m s] and s = dV/dt . M qd + V . Q [N m] at the last velocities (_crank_direction):
        since V . (M qdd - Q) is the driver's torque tau (V does no virtual work against the other
        constraints), ``tau = dp/dt - s``. s holds the gas, gravity and joint loads on the crank rotation
        (the joint's only through e x F and its torques) and no accelerations, so it is smooth where tau
        is not (input_work)."""
        masses = self.em.mechanism.mass_matrix.diagonal()
        V = self._crank_direction(q, t)
        qd = velocities[-1]
        eps = self.DIRECTION_STEP
        V_dot = (
            self._crank_direction(q + eps * qd, t + eps) - self._crank_direction(q - eps * qd, t - eps)
        ) / (2 * eps)
        momentum = masses * qd
        return tuple(float(V @ (masses * v)) for v in velocities), float(V_dot @ momentum + V @ Q)

    def momentum_columns(self, t: float, q, arrival, qd, Q) -> dict[str, float]:
        """The private columns (MOMENTUM_COLUMNS) of a state reached with velocities ``arrival`` and
        moved to ``qd`` (the consistent ones) that :func:`input_work` takes the driver's work from."""
        (at_arrival, momentum), source = self.crank_momentum(t, q, (arrival, qd), Q)
        return {
            "_crank_momentum_arrival": at_arrival,
            "_crank_momentum": momentum,
            "_crank_momentum_source": source,
            "_crank_speed": qd[3 * CRANK + 2],
        }

    def stage_powers(self, t: float, y: np.ndarray, qdd: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """[dissipated, drift] power [W] at a force evaluation of the integrator (a stage state).

        dissipated: the clearance joints' (small end and big end), as ``dissipated_power`` (their forces from
        the joint's cache: this is the state it was just evaluated at); drift: ``-lambda^T (Phi_q qd +
        Phi_t)``, the power of the constraints' reactions on the integrator's velocity residual (~rtol |qd|),
        which vanishes on the velocity constraint: the ideal joints' whole power, and the driver's beyond
        ``tau omega`` (the driver's work in input_work is taken at the prescribed speed). NaN after a failed
        evaluation (its step is rejected; the joint is not asked again).

        Integrated along the stages (STAGE_COLUMNS): the drift exists only there (the outputs'
        velocities are consistent). The input power is not integrated this way: it carries the
        mechanism's reversible exchange of ~50 J of kinetic energy with the driver, and its stage
        quadrature (at the stages' last Newton iterates, where the stiff joint's force is off by its
        slope times the last Newton correction) missed the change of mechanical energy by up to 7e-3 J
        in a degree, where the joint dissipates ~0.2 J in a cycle (input_work instead).
        """
        mech = self.em.mechanism
        n = mech.n_coordinates
        q, qd = y[:n], y[n:]
        if not np.all(np.isfinite(qdd)):
            return np.full(len(STAGE_COLUMNS), math.nan)
        dissipated = 0.0
        for element in self.em.clearance_joints.values():
            kin = element.kinematics(q, qd)
            forces = element.joint.forces(kin.ecc, kin.ecc_rate, kin.omega_rel, t)
            dissipated += joint_powers(kin, forces, qd, element.bushing_body)[2]
        residual = mech.jacobian(q, t) @ qd + mech.phi_t(q, t)
        return np.array([dissipated, -float(lam @ residual)])

    def projection_energy(self, q, arrival, qd) -> float:
        """J, the kinetic energy the projection of the velocities from ``arrival`` to ``qd`` adds (its
        share of drift_work)."""
        return self.energies(q, qd)[0] - self.energies(q, arrival)[0]
