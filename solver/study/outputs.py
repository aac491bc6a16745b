"""The variables of a coupled run at its output states (solver.study.results.STATE_VARIABLES).

At each output crank angle (step ``solver.step_deg``): the mechanism's (piston motion, rod angle, gas force
and cylinder pressure, crank torque, the big end's force on the rod), each clearance joint's kinematics,
forces and powers (pin force on the rod, eccentricity in the rod frame, friction torque and power, squeeze and
dissipated power; the big end's prefixed ``big_end_``, a floating pin's bosses' ``pin_boss_``; the floating
pin's angle, speed and the torques on it), the joint's own variables (each joint reports them:
``joint.outputs``, the names in its ``OUTPUTS``; e.g. a film's h_min, p_max, film and asperity loads, flows),
and the energy bookkeeping (solver.study.energy). A variable no one reports stays NaN, the default of every
STATE_VARIABLES entry.
"""

from __future__ import annotations

import math

import numpy as np

from solver.dynamics.engine import CRANK, PIN, PISTON, ROD
from solver.dynamics.multibody import accelerations, joint_reactions, rotation
from solver.study.energy import EnergyAudit, joint_powers, kept_motion
from solver.study.results import STATE_VARIABLES


class StateOutputs:
    """The STATE_VARIABLES of one engine mechanism (``em``) at its states.

    Args:
        em: the engine mechanism (solver.dynamics.engine.build_mechanism).
        engine: its engine model (gas force, cylinder pressure).
        clearance: m, the small end's radial clearance.
        big_end_clearance: m, the big end's (a clearance big end only).
        pin_boss_clearance: m, the floating pin's bosses' (a floating pin only).
        baumgarte: 1/s, the integration's Baumgarte gains (alpha = beta) for the accelerations.
        audit: the energy terms of the same mechanism.
    """

    def __init__(
        self,
        em,
        engine,
        clearance: float,
        baumgarte: float,
        audit: EnergyAudit,
        big_end_clearance: float = math.nan,
        pin_boss_clearance: float = math.nan,
    ):
        self.em, self.engine, self.clearance, self.baumgarte, self.audit = (
            em,
            engine,
            clearance,
            baumgarte,
            audit,
        )
        self.big_end_clearance = big_end_clearance
        self.pin_boss_clearance = pin_boss_clearance

    def at(self, t: float, q, qd) -> tuple[dict[str, float], np.ndarray]:
        """Outputs at a state reached with velocities qd, evaluated at consistent velocities (and the
        crank momentum's private columns of solver.study.energy); returns (outputs, those velocities)."""
        arrival, qd = qd, self.consistent(t, q, qd)
        mech = self.em.mechanism
        Q = mech.forces(q, qd, t).Q
        qdd, lam = accelerations(mech, q, qd, t, Q, alpha=self.baumgarte, beta=self.baumgarte)
        out = self.variables(t, q, qd, qdd, lam)
        # the crank's momentum on arrival (the integrator's velocities) and after the projection
        out.update(self.audit.momentum_columns(t, q, arrival, qd, Q))
        return out, qd

    def consistent(self, t: float, q, qd) -> np.ndarray:
        """Velocities on the constraint manifold that keep the joint's relative motion (outputs).

        The integrator leaves velocity-constraint residuals of order rtol |qd| (~1e-4 m/s), whose
        constraint forces do ~1 W of spurious work: as much as the joint dissipates. The outputs are
        therefore evaluated at the velocities with ``Phi_q qd = -Phi_t`` that keep de'/dt (the two
        free coordinates, in which the joint is stiff). The next output interval starts from them too
        (a projection of the velocities at every output time), so the film solve of the outputs is
        also the first one of the next interval.
        """
        mech = self.em.mechanism
        if not self.em.clearance_joints:
            return qd
        A = kept_motion(self.em, q, t)
        residual = np.concatenate(
            [-mech.phi_t(q, t) - A[: mech.n_constraints] @ qd, np.zeros(len(A) - mech.n_constraints)]
        )
        return qd + A.T @ np.linalg.lstsq(A @ A.T, residual, rcond=None)[0]

    def variables(self, t: float, q, qd, qdd, lam) -> dict[str, float]:
        """The STATE_VARIABLES at one state (consistent velocities); the energy columns integrated over
        the cycle (solver.study.energy.ENERGY_COLUMNS) are left NaN here."""
        em, engine, mech = self.em, self.engine, self.em.mechanism
        theta = float(q[3 * CRANK + 2])
        reactions = joint_reactions(mech, q, t, lam)
        out: dict[str, float] = dict.fromkeys(STATE_VARIABLES, math.nan)
        out.update(
            time=t,
            x_piston=q[3 * PISTON],
            v_piston=qd[3 * PISTON],
            a_piston=qdd[3 * PISTON],
            rod_angle=q[3 * ROD + 2],
            F_gas=float(engine.gas_force(theta)),
            p_cyl=float(engine.cylinder_pressure.pressure(theta)),
            crank_torque=reactions["crank_driver"][CRANK, 2],
        )
        if em.small_end is None:
            out["pin_force_x"], out["pin_force_y"] = reactions["small_end"][ROD, :2]
        else:
            out.update(self._clearance_joint(t, q, qd))
        if em.big_end is None:  # force of the crankpin on the rod
            out["big_end_force_x"], out["big_end_force_y"] = reactions["big_end"][ROD, :2]
        else:
            out.update(self._clearance_joint(t, q, qd, "big_end"))
        if em.floating_pin:
            out.update(self._clearance_joint(t, q, qd, "pin_boss"))
            out.update(
                pin_angle=q[3 * PIN + 2],
                pin_speed=qd[3 * PIN + 2],
                pin_torque_small_end=out["friction_torque"],
                pin_torque_boss=out["pin_boss_friction_torque"],
            )
            out["pin_torque_net"] = out["pin_torque_small_end"] + out["pin_torque_boss"]
        # energy: input power of the driver, the gas and gravity; mechanical energy
        out["kinetic_energy"], out["potential_energy"] = self.audit.energies(q, qd)
        out["input_power"] = out["crank_torque"] * qd[3 * CRANK + 2] - out["F_gas"] * qd[3 * PISTON]
        return out

    def _clearance_joint(self, t: float, q, qd, name: str = "small_end") -> dict[str, float]:
        """A clearance joint's kinematics, forces and powers, then the variables it reports itself: the
        small end's under their own names, the big end's prefixed ``big_end_`` (its force on the rod as
        ``big_end_force``), the floating pin's bosses' prefixed ``pin_boss_`` (the pin's force on the
        piston as ``pin_boss_force``); those without a place in STATE_VARIABLES are left out."""
        element = self.em.clearance_joints[name]
        clearance = {
            "small_end": self.clearance,
            "big_end": self.big_end_clearance,
            "pin_boss": self.pin_boss_clearance,
        }[name]
        kin = element.kinematics(q, qd)
        forces = element.joint.forces(kin.ecc, kin.ecc_rate, kin.omega_rel, t)
        F_b = np.asarray(forces.force)  # bushing on pin, bushing frame
        body = element.bushing_body  # the rod (small end, big end) or the piston (bosses)
        A_b = rotation(float(q[3 * body + 2]))
        pin_on_rod = -(A_b @ F_b)  # of the journal on the bushing, global frame
        squeeze, friction, dissipated = joint_powers(kin, forces, qd, body)
        values = dict(
            ecc_x=kin.ecc[0],
            ecc_y=kin.ecc[1],
            ecc_rate_x=kin.ecc_rate[0],
            ecc_rate_y=kin.ecc_rate[1],
            omega_rel=kin.omega_rel,
            pin_force_x=pin_on_rod[0],
            pin_force_y=pin_on_rod[1],
            h_min=clearance - math.hypot(*kin.ecc),
            h_min_angle=math.degrees(math.atan2(kin.ecc[1], kin.ecc[0])) % 360.0,  # rigid: along e'
            friction_torque=forces.journal_torque,
            friction_power=friction,
            squeeze_power=squeeze,
            dissipated_power=dissipated,
        )
        values.update(element.joint.outputs(kin.ecc, kin.ecc_rate, kin.omega_rel, t, forces))
        if name == "small_end":
            return values
        renamed = {"pin_force_x": f"{name}_force_x", "pin_force_y": f"{name}_force_y"}
        values = {renamed.get(key, f"{name}_{key}"): value for key, value in values.items()}
        return {key: value for key, value in values.items() if key in STATE_VARIABLES}


def ideal_cycle_columns(ideal) -> dict[str, np.ndarray]:
    """The ideal-joint cycle (solver.dynamics.engine.simulate_ideal) as the columns of a coupled cycle:
    the mechanism's variables, NaN for the joint's and the energy audit's."""
    n = len(ideal.crank_angle)
    columns = {name: np.full(n, np.nan) for name in STATE_VARIABLES}
    columns.update(
        crank_angle=ideal.crank_angle,
        time=ideal.time,
        x_piston=ideal.piston_position,
        v_piston=ideal.piston_velocity,
        a_piston=ideal.piston_acceleration,
        rod_angle=ideal.rod_angle,
        F_gas=ideal.gas_force,
        p_cyl=ideal.cylinder_pressure,
        crank_torque=ideal.crank_torque,
        pin_force_x=ideal.pin_force_x,
        pin_force_y=ideal.pin_force_y,
        big_end_force_x=ideal.big_end_force[:, 0],
        big_end_force_y=ideal.big_end_force[:, 1],
        input_power=ideal.crank_torque * ideal.crank_speed - ideal.gas_force * ideal.piston_velocity,
    )
    return columns
