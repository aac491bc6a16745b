"""One engine operating point with the lubricated small end: cycles until periodic, then results.

The case's engine (solver.dynamics.engine) is built with the small end as a clearance joint whose law is one
of solver.joint (``mixed-fem``: the finite-element mixed-lubrication film; ``short-bearing``;
``dry``) or as an ideal revolute (``ideal``). The equations of motion are integrated with the
L-stable ESDIRK32 method (solver.dynamics.integrate), whose Newton iterations use the joint's exact Jacobian,
so that the step is set by accuracy and not by the film's stiffness (DESIGN 3.8).

The run starts from the ideal-joint configuration at 0 deg with the pin centred in its bushing and
integrates whole 720 deg cycles until the cycle minimum of the film thickness changes by less than
``solver.periodic_tolerance`` x clearance from one cycle to the next (at least two cycles, at most
``solver.max_cycles``) and, when ``solver.periodic_friction_tolerance`` is set, the cycle-mean friction
power by less than that fraction of itself (a mass-conserving film can hold min h_min to 2 nm while
its friction still grows by a few per cent a cycle); the last cycle is reported. The state is
checkpointed at every cycle end (``results/checkpoint.npz``), so an interrupted run resumes from the
last finished cycle.

With ``oil.thermal = "effective"`` the film's temperature is iterated with the cycles too
(solver.study.thermal): cycle k runs at T_k, its heat balance (cycle means of ``dissipated_power`` and
``side_flow``) gives T_(k+1), and the joint's viscosity is set to the oil's at T_(k+1) before the next
cycle (``_Run.set_film_temperature``). The run stops when the cycle is periodic and its heat balance
closes within ``oil.thermal_tolerance`` (``periodic`` in the results means both); the checkpoint keeps
the balances of the cycles, so a resumed run goes on with the same temperatures.

Per output crank angle (step ``solver.step_deg``) the results hold the DESIGN 4 variables (pin force
on the rod, eccentricity in the rod frame, h_min, p_max, film and asperity forces, friction torque and
power, crank torque, ...) and the ideal-joint pin force for comparison. Energy bookkeeping per output:
input power (crank + gas + gravity), mechanical energy, and the power dissipated in the joint
``D = -(F' . de'/dt + T_j omega_rel + omega_b (T_j + T_b + e' x F'))`` (the last term vanishes when the
film's moment balance holds). The energy audit (ENERGY_COLUMNS, cumulative over the cycle) closes
``input_work - change of mechanical energy = dissipated_energy - drift_work`` to the integration's
accuracy (measured 5e-5 to 1.5e-3 of the dissipated energy at the default resolutions, 7e-3 on a
coarse JFO run): the dissipation and the drift's work integrated along the integrator's stages, the
driver's work from the crank's generalized momentum (``_input_work``).

A failed film solve returns NaN forces and the integrator retries with a shorter step; when the step
size collapses the run stops with a ``SimulationError`` naming the crank angle. Everything runs on the
given communicator: the film mesh is distributed over it and every rank integrates the (small)
multibody system with the same, reduced film forces.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import math
import sys
import time
from contextlib import contextmanager, nullcontext
from pathlib import Path

from mpi4py import MPI

import numpy as np
from tqdm import tqdm

from solver import __version__
from solver.case import Case, case_attributes, load_case
from solver.dynamics.engine import CRANK, PISTON, ROD, build_mechanism, engine_from_case, simulate_ideal
from solver.dynamics.integrate import IntegrationError, integrate
from solver.dynamics.joint import JOINTS, FilmJoint, joint_from_case
from solver.dynamics.multibody import accelerations, joint_reactions, rotation
from solver.errors import FilmNotConverged, InputError
from solver.study import io
from solver.study import results as results_io
from solver.study.results import TIMING, RunSummary
from solver.study.thermal import EffectiveTemperature, HeatBalance, ThermalError, ThermalModel, cycle_mean

log = logging.getLogger(__name__)

CHUNK_DEG = 10.0  # crank angle between progress updates
S = np.array([[0.0, -1.0], [1.0, 0.0]])


class SimulationError(RuntimeError):
    """The coupled run failed (the message names the crank angle and cycle)."""


@dataclasses.dataclass
class CycleOutput:
    """Arrays over the output crank angles of one cycle (SI)."""

    columns: dict[str, np.ndarray]
    h_min_min: float
    timing: dict[str, float] = dataclasses.field(default_factory=dict)  # see TIMING

    @property
    def friction_power_mean(self) -> float:
        """W, the cycle mean of the friction power over the crank angle (as results.nc's summary)."""
        return cycle_mean(self.columns["friction_power"], self.columns["crank_angle"])


def _relative_change(values: list[float]) -> float:
    """|last - previous| / |last| of a per-cycle history; inf with fewer than two cycles."""
    if len(values) < 2:
        return math.inf
    change = abs(values[-1] - values[-2])
    return change / abs(values[-1]) if values[-1] != 0 else (0.0 if change == 0 else math.inf)


def _case_fingerprint(case: Case, joint: str) -> str:
    text = repr(sorted((k, str(v)) for k, v in case_attributes(case).items())) + joint + __version__
    return hashlib.sha256(text.encode()).hexdigest()[:16]


#: The energy audit of a cycle (results.nc, J, cumulative from its start): the input work (crank driver
#: from its generalized momentum, and gas), and, integrated along the integrator's stages, the energy
#: dissipated in the joint and the drift's work (_Run.integrate_cycle)
ENERGY_COLUMNS = ("input_work", "dissipated_energy", "drift_work")
STAGE_COLUMNS = ENERGY_COLUMNS[1:]


def _input_work(columns: dict[str, np.ndarray]) -> np.ndarray:
    """Work of the crank driver and the gas since the cycle's start [J], at the outputs; pops the
    private columns of the crank's generalized momentum that it is computed from (_Run._crank_momentum).

    The driver's torque carries the stiff joint's force, which varies within a degree where the pin
    crosses its clearance. Its power (kW, against a joint dissipating a few W) is then undersampled on
    the outputs: Simpson's rule on the same JFO run sampled every 0.5, 1 or 2 deg put its energy balance
    at -0.6, +1.4 and -2.0 % (the dissipated energy moved by 0.01 %). Its impulse is therefore taken
    from the momentum theorem, ``int tau dt = p(t) - p(0) - int s dt``, whose integrand s (the gas,
    gravity and joint loads on a crank rotation at fixed eccentricity, and the rate of that direction)
    is smooth; then ``int omega dI`` (exact at constant speed), and the gas power (smooth) by the
    trapezoidal rule. The same run's audit then moved by less than 0.03 % between those samplings.
    """
    p, arrival, rate, omega = (
        columns.pop(k)
        for k in ("_crank_momentum", "_crank_momentum_arrival", "_crank_momentum_source", "_crank_speed")
    )
    t = columns["time"]
    dt = np.diff(t)
    # each output interval from the projected state to the integrator's arrival: the projection of the
    # velocities at the outputs is no impulse of the driver (its energy is in drift_work)
    impulse = np.concatenate([[0.0], np.cumsum(arrival[1:] - p[:-1] - 0.5 * dt * (rate[1:] + rate[:-1]))])
    driver = np.concatenate([[0.0], np.cumsum(0.5 * (omega[1:] + omega[:-1]) * np.diff(impulse))])
    gas_power = -columns["F_gas"] * columns["v_piston"]
    gas = np.concatenate([[0.0], np.cumsum(0.5 * dt * (gas_power[1:] + gas_power[:-1]))])
    return driver + gas


def _joint_powers(kin, forces, qd) -> tuple[float, float, float]:
    """(squeeze, friction, dissipated) power of the small end's forces at a state [W]."""
    F_b = np.asarray(forces.force)  # bushing on pin, rod frame
    omega_b = float(qd[3 * ROD + 2])
    squeeze = -float(F_b @ kin.ecc_rate)
    friction = -forces.journal_torque * kin.omega_rel
    moment = forces.journal_torque + forces.bushing_torque + float(kin.ecc[0] * F_b[1] - kin.ecc[1] * F_b[0])
    return squeeze, friction, squeeze + friction - omega_b * moment


class _Run:
    """State of one coupled run (kept small: the heavy objects are the mechanism and the film)."""

    def __init__(self, case: Case, comm: MPI.Comm, joint_name: str):
        self.case, self.comm, self.joint_name = case, comm, joint_name
        self.engine = engine_from_case(case)
        self.omega = self.engine.crank_motion.speed
        self.joint, self.model = joint_from_case(case, self.engine, comm, joint_name)
        self.em = build_mechanism(self.engine, self.joint)
        c = case.small_end.clearance
        n = self.em.mechanism.n_coordinates
        position = np.tile([1e-4 * c, 1e-4 * c, 1e-6], n // 3)
        self.atol = np.concatenate([position, position * self.omega])
        self.step_deg = math.degrees(case.solver.step)
        self.steps = 0  # accepted integrator steps so far
        self.timings: list[dict[str, float]] = []  # TIMING of each computed cycle (resumed ones included)
        self.cycle_history: dict[str, list[float]] = {}  # per cycle (resumed ones too): min h_min, friction
        self.fields_seconds = 0.0  # writing the ParaView fields after the cycles
        # per output state of the last integrated cycle, the committed states (time, elastic unknowns) its
        # deformation's rate was taken from (None: rigid, or quasi-static), for write_fields to solve the
        # film again as the run did
        self.committed: list[list[tuple[float, np.ndarray]] | None] = []
        # the film's oil in the cycles run now: temperature [C] (NaN when the case gives a fixed
        # viscosity) and viscosity [Pa s]; with oil.thermal = "effective" the iteration sets them
        oil, data = case.oil, case.oil.data()
        self.film_temperature = oil.temperature if data is not None else math.nan
        self.film_viscosity = oil.viscosity
        self.thermal: EffectiveTemperature | None = None
        if oil.thermal == "effective":
            model = ThermalModel(data, oil.specific_heat, oil.heat_to_solids, oil.temperature)
            self.thermal = EffectiveTemperature(model, oil.thermal_tolerance)

    # -- integration ------------------------------------------------------------------------------
    def integrate_cycle(self, cycle: int, t0: float, q0, qd0, progress=None):
        """One 720 deg cycle from (t0, q0, qd0) in chunks; returns (outputs per angle, end state).

        The outputs carry the cycle's ``timing`` (TIMING, without the checkpoint's I/O).
        """
        start = time.perf_counter()
        film_before = self.model.stats.copy() if self.model is not None else None
        steps_before, rejected = self.steps, 0
        motion = self.engine.crank_motion
        theta0 = 4 * math.pi * cycle
        n_out = int(round(720.0 / self.step_deg))
        angles = np.linspace(0.0, 720.0, n_out + 1)
        times = np.asarray(motion.time(np.radians(angles) + theta0), dtype=float)
        times[0] = t0
        # Every output angle is a step end: the cubic dense output is fine for positions but not for the
        # relative velocity of a stiff joint, and the film force depends on that velocity.
        q, t = q0, t0
        self.committed = []
        row, qd = self._state_outputs(t0, q0, qd0)
        self._commit(t0)
        rows = [row]
        work = np.zeros(len(STAGE_COLUMNS))  # STAGE_COLUMNS since the cycle's start
        energies = [work.copy()]
        step = jacobian = interpolant = None
        for k in range(1, n_out + 1):
            t_end = float(times[k])
            try:
                tr = integrate(
                    self.em.mechanism,
                    q,
                    qd,
                    (t, t_end),
                    method="ESDIRK32",
                    rtol=self.case.solver.rtol,
                    atol=self.atol,
                    alpha=self.omega,
                    beta=self.omega,
                    t_eval=np.array([t_end]),
                    first_step=step,
                    assemble_initial_state=False,
                    jacobian_reuse=True,
                    jacobian=jacobian,
                    interpolant=interpolant,
                    accelerations=False,
                    on_step=self._step_accepted,
                    stage_values=self._stage_powers,
                )
            except IntegrationError as err:
                raise SimulationError(
                    f"the {self.joint_name} run failed at crank angle {angles[k - 1]:.2f}-"
                    f"{angles[k]:.2f} deg of cycle {cycle + 1}: {err}"
                ) from None
            q, t = tr.q[-1], t_end
            jacobian, interpolant = tr.jacobian, tr.interpolant
            step = (
                min(tr.next_step, 4 * (t_end - float(times[k - 1]))) if math.isfinite(tr.next_step) else None
            )
            row, qd = self._state_outputs(t, q, tr.qd[-1])  # the next interval starts from these velocities
            self._commit(t)
            rows.append(row)
            # the work along the stages, and the kinetic energy the velocities' projection adds (drift)
            work += tr.stage_integral
            work[1] += self._energies(q, qd)[0] - self._energies(q, tr.qd[-1])[0]
            energies.append(work.copy())
            self.steps += tr.n_steps
            rejected += tr.n_rejected
            if progress is not None and (angles[k] % CHUNK_DEG < 1e-9 or k == n_out):
                progress(cycle, angles[k], rows[-1]["h_min"])
        columns = {k: np.array([r[k] for r in rows]) for k in rows[0]}
        columns.update(zip(STAGE_COLUMNS, np.array(energies).T))
        columns["input_work"] = _input_work(columns)
        columns["crank_angle"] = angles
        h_min = columns["h_min"]
        wall = time.perf_counter() - start
        timing = dict.fromkeys(TIMING, 0.0)
        timing.update(wall_s=wall, steps=self.steps - steps_before, rejected_steps=rejected, multibody_s=wall)
        if film_before is not None:
            now = self.model.stats
            timing.update(
                film_solves=now.solves - film_before.solves,
                vi_iterations=now.vi_iterations - film_before.vi_iterations,
                film_jacobians=now.jacobians - film_before.jacobians,
                transport_fallbacks=now.transport_fallbacks - film_before.transport_fallbacks,
                film_solve_s=now.solve_seconds - film_before.solve_seconds,
                film_jacobian_s=now.jacobian_seconds - film_before.jacobian_seconds,
            )
            timing["multibody_s"] = wall - timing["film_solve_s"] - timing["film_jacobian_s"]
        return CycleOutput(columns, float(np.nanmin(h_min)), timing), (t, q, qd)

    def _step_accepted(self, t: float) -> None:
        """An accepted integrator step: an elastic bushing's deformation at its end starts the rate of
        the next step (implicit Euler over the step, not over the output interval)."""
        if self.model is not None and hasattr(self.joint, "commit"):
            self.joint.commit(t)

    def _commit(self, t: float) -> None:
        """An accepted output state: an elastic bushing's deformation there starts the next rate (it
        replaces the commit of the step that ended there: the output's velocities are the consistent ones)."""
        if self.model is not None and hasattr(self.joint, "commit"):
            self.committed.append(self.model.rate_history(t) or None)
            self.joint.commit(t)

    def _state_outputs(self, t: float, q, qd) -> tuple[dict[str, float], np.ndarray]:
        """Outputs at a state, evaluated at consistent velocities; returns (outputs, those velocities)."""
        arrival, qd = qd, self._consistent(t, q, qd)
        Q = self.em.mechanism.forces(q, qd, t).Q
        qdd, lam = accelerations(self.em.mechanism, q, qd, t, Q, alpha=self.omega, beta=self.omega)
        out = self._outputs(t, q, qd, qdd, lam)
        # the crank's momentum on arrival (the integrator's velocities) and after the projection
        (out["_crank_momentum_arrival"], out["_crank_momentum"]), out["_crank_momentum_source"] = (
            self._crank_momentum(t, q, (arrival, qd), Q)
        )
        out["_crank_speed"] = qd[3 * CRANK + 2]
        return out, qd

    #: s, time step of the central difference of the crank direction along the motion (_crank_momentum)
    DIRECTION_STEP = 1e-7

    def _crank_direction(self, q, t: float) -> np.ndarray:
        """V: the velocities of a unit crank speed that keep the small end's eccentricity (and every
        constraint but the driver's), ``Phi_q V = e_driver``, ``de/dt(V) = 0``."""
        A = self._kept_motion(q, t)
        rhs = np.zeros(len(A))
        rhs[self.em.mechanism.rows["crank_driver"]] = 1.0
        return np.linalg.solve(A, rhs)

    def _crank_momentum(self, t: float, q, velocities: tuple, Q) -> tuple[tuple[float, ...], float]:
        """((p for each of ``velocities``), s) with p = V . M qd the crank's generalized momentum at fixed
        eccentricity [N m s] and s = dV/dt . M qd + V . Q [N m] at the last velocities (_crank_direction):
        since V . (M qdd - Q) is the driver's torque tau (V does no virtual work against the other
        constraints), ``tau = dp/dt - s``. s holds the gas, gravity and joint loads on the crank rotation
        (the joint's only through e x F and its torques) and no accelerations, so it is smooth where tau
        is not (_input_work)."""
        masses = self.em.mechanism.mass_matrix.diagonal()
        V = self._crank_direction(q, t)
        qd = velocities[-1]
        eps = self.DIRECTION_STEP
        V_dot = (
            self._crank_direction(q + eps * qd, t + eps) - self._crank_direction(q - eps * qd, t - eps)
        ) / (2 * eps)
        momentum = masses * qd
        return tuple(float(V @ (masses * v)) for v in velocities), float(V_dot @ momentum + V @ Q)

    def _consistent(self, t: float, q, qd) -> np.ndarray:
        """Velocities on the constraint manifold that keep the joint's relative motion (outputs).

        The integrator leaves velocity-constraint residuals of order rtol |qd| (~1e-4 m/s), whose
        constraint forces do ~1 W of spurious work: as much as the joint dissipates. The outputs are
        therefore evaluated at the velocities with ``Phi_q qd = -Phi_t`` that keep de'/dt (the two
        free coordinates, in which the joint is stiff). The next output interval starts from them too
        (a projection of the velocities at every output time), so the film solve of the outputs is
        also the first one of the next interval.
        """
        mech = self.em.mechanism
        if self.em.small_end is None:
            return qd
        A = self._kept_motion(q, t)
        residual = np.concatenate([-mech.phi_t(q, t) - A[: mech.n_constraints] @ qd, np.zeros(2)])
        return qd + A.T @ np.linalg.lstsq(A @ A.T, residual, rcond=None)[0]

    def _kept_motion(self, q, t: float) -> np.ndarray:
        """The rows whose velocity a projection prescribes: ``Phi_q`` and, with a clearance small end,
        ``d(de'/dt)/dqd`` (its eccentricity rate, kept), shape (n_constraints [+ 2], n_coordinates)."""
        rows = [self.em.mechanism.jacobian(q, t)]
        if self.em.small_end is not None:
            rows.append(self.em.small_end.kinematics(q, np.zeros_like(q)).dz_dqd[2:4])
        return np.vstack(rows)

    def _outputs(self, t: float, q, qd, qdd, lam) -> dict[str, float]:
        """The DESIGN 4 variables and the energy bookkeeping at one state (consistent velocities)."""
        em, engine, mech = self.em, self.engine, self.em.mechanism
        theta = float(q[3 * CRANK + 2])
        reactions = joint_reactions(mech, q, t, lam)
        out: dict[str, float] = {
            "time": t,
            "x_piston": q[3 * PISTON],
            "v_piston": qd[3 * PISTON],
            "a_piston": qdd[3 * PISTON],
            "rod_angle": q[3 * ROD + 2],
            "F_gas": float(engine.gas_force(theta)),
            "p_cyl": float(engine.cylinder_pressure.pressure(theta)),
            "crank_torque": reactions["crank_driver"][CRANK, 2],
        }
        c = self.case.small_end.clearance
        nan = math.nan
        values = dict(
            ecc_x=nan,
            ecc_y=nan,
            ecc_rate_x=nan,
            ecc_rate_y=nan,
            omega_rel=nan,
            pin_force_x=nan,
            pin_force_y=nan,
            h_min=nan,
            p_max=nan,
            F_hydro=nan,
            F_asperity=nan,
            friction_torque=nan,
            friction_power=nan,
            squeeze_power=nan,
            dissipated_power=nan,
            contact_area_ratio=nan,
            deformation_max=nan,
            deformation_max_angle=nan,
        )
        values.update(side_flow=nan, supply_flow=nan, cavitated_area_ratio=nan, oil_volume=nan)
        if em.small_end is None:
            values["pin_force_x"], values["pin_force_y"] = reactions["small_end"][ROD, :2]
        else:
            kin = em.small_end.kinematics(q, qd)
            forces = em.small_end.joint.forces(kin.ecc, kin.ecc_rate, kin.omega_rel, t)
            F_b = np.asarray(forces.force)  # bushing on pin, rod frame
            A_b = rotation(float(q[3 * ROD + 2]))
            pin_on_rod = -(A_b @ F_b)
            squeeze, friction, dissipated = _joint_powers(kin, forces, qd)
            values.update(
                ecc_x=kin.ecc[0],
                ecc_y=kin.ecc[1],
                ecc_rate_x=kin.ecc_rate[0],
                ecc_rate_y=kin.ecc_rate[1],
                omega_rel=kin.omega_rel,
                pin_force_x=pin_on_rod[0],
                pin_force_y=pin_on_rod[1],
                h_min=c - math.hypot(*kin.ecc),
                friction_torque=forces.journal_torque,
                friction_power=friction,
                squeeze_power=squeeze,
                dissipated_power=dissipated,
            )
            result = (
                self.joint.result_at(kin.ecc, kin.ecc_rate, kin.omega_rel, t)
                if self.model is not None
                else None
            )
            if result is not None:
                values.update(
                    p_max=result.p_max,
                    F_hydro=result.hydro_load,
                    F_asperity=result.asperity_load,
                    contact_area_ratio=result.contact_area_ratio,
                    h_min=result.h_min,
                    deformation_max=result.max_deformation,
                    deformation_max_angle=result.max_deformation_theta,
                    side_flow=result.side_flow,
                    supply_flow=result.supply_flow,
                    cavitated_area_ratio=result.cavitated_area_ratio,
                    oil_volume=result.oil_volume,
                )
            elif self.joint_name == "short-bearing":
                values.update(
                    F_hydro=float(np.hypot(*F_b)),
                    F_asperity=0.0,
                    side_flow=self.joint.side_flow(kin.ecc, kin.ecc_rate, kin.omega_rel),
                )
            elif self.joint_name == "dry":
                values.update(F_hydro=0.0, F_asperity=float(np.hypot(*F_b)))
        out.update(values)
        # energy: input power of the driver, the gas and gravity; mechanical energy
        out["kinetic_energy"], out["potential_energy"] = self._energies(q, qd)
        out["input_power"] = out["crank_torque"] * qd[3 * CRANK + 2] - out["F_gas"] * qd[3 * PISTON]
        return out

    def _energies(self, q, qd) -> tuple[float, float]:
        """(kinetic, gravitational potential) energy of the mechanism [J]."""
        mech = self.em.mechanism
        masses = mech.mass_matrix.diagonal()
        x_cm = np.array([q[3 * i] for i in range(len(mech.bodies))])
        m = np.array([b.mass for b in mech.bodies])
        return 0.5 * float(np.sum(masses * qd**2)), float(np.sum(m * self.engine.gravity * x_cm))

    def _stage_powers(self, t: float, y: np.ndarray, qdd: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """[dissipated, drift] power [W] at a force evaluation of the integrator (a stage state).

        dissipated: the joint's, as ``dissipated_power`` (its forces from the joint's cache: this is
        the state it was just evaluated at); drift: ``-lambda^T (Phi_q qd + Phi_t)``, the power of the
        constraints' reactions on the integrator's velocity residual (~rtol |qd|), which vanishes on the
        velocity constraint: the ideal joints' whole power, and the driver's beyond ``tau omega`` (the
        driver's work in input_work is taken at the prescribed speed). NaN after a failed evaluation
        (its step is rejected; the joint is not asked again).

        Integrated along the stages (STAGE_COLUMNS): the drift exists only there (the outputs'
        velocities are consistent). The input power is not integrated this way: it carries the
        mechanism's reversible exchange of ~50 J of kinetic energy with the driver, and its stage
        quadrature (at the stages' last Newton iterates, where the stiff joint's force is off by its
        slope times the last Newton correction) missed the change of mechanical energy by up to 7e-3 J
        in a degree, where the joint dissipates ~0.2 J in a cycle (_input_work instead).
        """
        mech, element = self.em.mechanism, self.em.small_end
        n = mech.n_coordinates
        q, qd = y[:n], y[n:]
        if not np.all(np.isfinite(qdd)):
            return np.full(len(STAGE_COLUMNS), math.nan)
        dissipated = 0.0
        if element is not None:
            kin = element.kinematics(q, qd)
            dissipated = _joint_powers(
                kin, element.joint.forces(kin.ecc, kin.ecc_rate, kin.omega_rel, t), qd
            )[2]
        residual = mech.jacobian(q, t) @ qd + mech.phi_t(q, t)
        return np.array([dissipated, -float(lam @ residual)])

    # -- film temperature ---------------------------------------------------------------------------
    def set_film_temperature(self, temperature: float, t: float) -> None:
        """The film's oil at ``temperature`` [C] from time t [s] on (a cycle end): the joint's viscosity
        becomes the oil's there (oil.thermal = "effective"; the density enters the heat balance only).

        A finite-element film with ``set_viscosity(mu)`` is updated in place and gets a new FilmJoint
        (its cache holds results at the old viscosity). Without it, the joint and its film model are
        built again from the case at the new temperature (mixed-fem: ~0.4 s with the compiled forms
        cached, ~1.5 s for a new viscosity, whose forms are compiled anew; the warm start is lost). An
        elastic bushing's last committed deformation is committed to the new model at t, so a solve at t
        takes its deformation rate as quasi-static where the run would have used the state before t.
        """
        oil = dataclasses.replace(self.case.oil, temperature=temperature)
        if self.model is not None and hasattr(self.model, "set_viscosity"):
            self.model.set_viscosity(oil.viscosity)
            self.joint = FilmJoint(self.model)
        else:
            deformation = self.joint.commit(t) if self.model is not None else None
            if self.model is not None:
                self.model.close()
            case = dataclasses.replace(self.case, oil=oil)
            self.joint, self.model = joint_from_case(case, self.engine, self.comm, self.joint_name)
            if deformation is not None:
                self.model.commit_history(deformation, t)
        self.em = build_mechanism(self.engine, self.joint)
        self.film_temperature, self.film_viscosity = temperature, oil.viscosity

    def heat_balance(self, cycle: CycleOutput) -> HeatBalance:
        """The heat balance of a cycle at the film temperature it ran at (oil.thermal = "effective")."""
        cols = cycle.columns
        heat, flow = (cycle_mean(cols[name], cols["time"]) for name in ("dissipated_power", "side_flow"))
        return self.thermal.model.balance(self.film_temperature, heat, flow)

    def film_record(self, cycle: CycleOutput) -> dict[str, float]:
        """The film's oil and heat balance in the last cycle (solver.study.results.FILM_VARIABLES).

        Isothermal: the case's temperature (NaN with a fixed viscosity) and viscosity, the heat
        generated, and NaN for the balance's other terms and its closure.
        """
        cols, nan, data = cycle.columns, math.nan, self.case.oil.data()
        record = {
            "film_temperature": self.film_temperature,
            "film_viscosity": self.film_viscosity,
            "film_density": float(data.density(self.film_temperature)) if data is not None else nan,
            "heat_generated": cycle_mean(cols["dissipated_power"], cols["time"]),
            "side_flow_mean": cycle_mean(cols["side_flow"], cols["time"]),
            "heat_to_oil": nan,
            "heat_carried": nan,
            "thermal_closure": nan,
        }
        if self.thermal is not None and self.thermal.history:
            balance = self.thermal.history[-1]
            record.update(
                heat_to_oil=balance.heat_to_oil,
                heat_carried=balance.heat_carried,
                thermal_closure=balance.closure,
            )
        return record

    # -- film fields --------------------------------------------------------------------------------
    def write_fields(self, directory: Path, cycle: CycleOutput) -> list[Path]:
        """ParaView fields of the last cycle (mixed-fem only): the time series ``film_series.xdmf``
        every ``solver.field_step_deg`` and single snapshots at ``solver.field_angles_deg``; the
        seconds it took go to ``fields_seconds``. A state whose film cannot be solved again is left
        out with a warning (the results do not depend on the fields)."""
        if self.model is None:
            return []
        begin = time.perf_counter()
        from solver.film.bearing import Kinematics  # dolfinx: only for a finite-element joint

        cols = cycle.columns
        angles = cols["crank_angle"]

        committed = self.committed

        def solve_at(k: int) -> bool:
            """The film at output k as in the run; False (with a warning) if it cannot be solved again."""
            kin = Kinematics(
                (float(cols["ecc_x"][k]), float(cols["ecc_y"][k])),
                (float(cols["ecc_rate_x"][k]), float(cols["ecc_rate_y"][k])),
                float(cols["omega_rel"][k]),
                0.0,
            )
            try:
                if k < len(committed) and committed[k] is not None:
                    # elastic bushing: the deformation's rate from the states it was taken from in the run;
                    # the last of them is also the warm start (one integrator step away)
                    for time_s, state in committed[k]:
                        self.model.commit_history(state, time_s)
                    self.model.start_from(committed[k][-1][1])
                    self.model.solve(kin, float(cols["time"][k]))
                else:
                    self.model.solve(kin)
            except FilmNotConverged as err:
                log.warning("ParaView fields at %.1f deg left out: %s", angles[k], err)
                return False
            return True

        paths = []
        field_step = math.degrees(self.case.solver.field_step)
        if field_step > 0:
            every = max(1, int(round(field_step / self.step_deg)))  # a multiple of the output step
            series = io.FilmSeries(directory, "film_series", self.model)
            try:
                for k in range(0, len(angles), every):
                    if solve_at(k):
                        series.write(angles[k])
                paths.append(series.close())
            except BaseException:
                series.abort()
                raise
        for angle in self.case.solver.field_angles:
            k = int(np.argmin(np.abs(angles - math.degrees(angle))))
            if solve_at(k):
                paths.append(io.write_film_fields(directory, f"film_{angles[k]:05.1f}deg", self.model))
        self.fields_seconds = time.perf_counter() - begin
        return paths


class _AboveTheBar:
    """A stream for log handlers that prints through ``tqdm.write``: above the progress bar."""

    def write(self, text: str) -> None:
        if text.strip():
            tqdm.write(text.rstrip("\n"), file=sys.stderr)

    def flush(self) -> None:
        pass


@contextmanager
def _logs_above_the_bar():
    """The terminal's log handlers (stderr) write above the progress bar meanwhile; their filters and
    formats stay as they are (tqdm's own redirect drops the filters)."""
    swapped = []
    for handler in logging.getLogger().handlers:
        if type(handler) is logging.StreamHandler and handler.stream is sys.stderr:
            swapped.append((handler, handler.setStream(_AboveTheBar())))
    try:
        yield
    finally:
        for handler, stream in swapped:
            handler.setStream(stream)


def describe_timing(timing: dict[str, float]) -> str:
    """One line: the counts and where the seconds went (TIMING)."""
    t = timing
    return (
        f"{t['wall_s']:.1f} s; {t['film_solves']:.0f} film solves ({t['vi_iterations']:.0f} VI iterations) "
        f"{t['film_solve_s']:.1f} s, {t['film_jacobians']:.0f} film Jacobians {t['film_jacobian_s']:.1f} s, "
        f"{t['steps']:.0f} steps ({t['rejected_steps']:.0f} rejected), multibody/integrator "
        f"{t['multibody_s']:.1f} s, I/O {t['io_s']:.2f} s"
        + (
            f"; {t['transport_fallbacks']:.0f} steps fell back to the upwind transport"
            if t.get("transport_fallbacks")
            else ""
        )
    )


def _ideal_cycle_output(ideal) -> CycleOutput:
    """The ideal-joint cycle in the layout of the coupled outputs (film quantities NaN)."""
    n = len(ideal.crank_angle)
    nan = np.full(n, np.nan)
    columns = {
        "crank_angle": ideal.crank_angle,
        "time": ideal.time,
        "x_piston": ideal.piston_position,
        "v_piston": ideal.piston_velocity,
        "a_piston": ideal.piston_acceleration,
        "rod_angle": ideal.rod_angle,
        "F_gas": ideal.gas_force,
        "p_cyl": ideal.cylinder_pressure,
        "crank_torque": ideal.crank_torque,
        "pin_force_x": ideal.pin_force_x,
        "pin_force_y": ideal.pin_force_y,
        "input_power": ideal.crank_torque * ideal.crank_speed - ideal.gas_force * ideal.piston_velocity,
    }
    for name in (
        "ecc_x",
        "ecc_y",
        "ecc_rate_x",
        "ecc_rate_y",
        "omega_rel",
        "h_min",
        "p_max",
        "F_hydro",
        "F_asperity",
        "friction_torque",
        "friction_power",
        "squeeze_power",
        "dissipated_power",
        "contact_area_ratio",
        "deformation_max",
        "deformation_max_angle",
        "kinetic_energy",
        "potential_energy",
        "side_flow",
        "supply_flow",
        "cavitated_area_ratio",
        "oil_volume",
        *ENERGY_COLUMNS,
    ):
        columns[name] = nan.copy()
    return CycleOutput(columns, math.nan)


def run_case(
    case_path: str | Path,
    comm: MPI.Comm,
    *,
    joint: str | None = None,
    progress: bool = False,
    resume: bool = True,
) -> RunSummary:
    """Run one case directory; write ``results/`` beside its case.toml; return the summary.

    Args:
        case_path: the case directory (or its TOML file).
        comm: the communicator of this case (the film mesh is distributed over it).
        joint: override ``solver.joint`` of the case.
        progress: show a progress bar on rank 0 (cycle, crank angle, h_min).
        resume: continue from ``results/checkpoint.npz`` if it belongs to the same case.

    Raises:
        InputError: a bad case (on every rank of comm).
        SimulationError: the run failed.
    """
    start = time.perf_counter()
    case = load_case(case_path)
    joint = joint or case.solver.joint
    if joint not in JOINTS:
        raise InputError(f"joint = {joint!r} is out of range (allowed: {', '.join(map(repr, JOINTS))})")
    if case.oil.thermal == "effective" and joint not in ("mixed-fem", "short-bearing"):
        raise InputError(
            f'oil.thermal = "effective" needs a film with a side flow (allowed: joint '
            f'"mixed-fem" or "short-bearing"; got {joint!r})'
        )
    out_dir = case.directory / "results"
    if comm.rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    handler = results_io.attach_log(out_dir / "run.log", comm)
    run = None
    try:
        log.info("case %s: joint %s, solver %s", case.name, joint, __version__)
        ideal = simulate_ideal(engine_from_case(case), step_deg=math.degrees(case.solver.step))
        run = _Run(case, comm, joint)
        if joint == "ideal":  # kinematically determined: the ideal cycle is the answer
            cycles_done, periodic = 1, True
            cycle = _ideal_cycle_output(ideal)
        else:
            cycle, cycles_done, periodic = _cycles(run, out_dir, progress, resume)
        fields = run.write_fields(out_dir, cycle)
        wall = time.perf_counter() - start
        summary = results_io.write_results(
            out_dir,
            case,
            run,
            cycle,
            ideal,
            joint=joint,
            cycles=cycles_done,
            periodic=periodic,
            wall_time=wall,
            fields=fields,
            comm=comm,
        )
        if comm.rank == 0:
            checkpoint = out_dir / "checkpoint.npz"
            if checkpoint.exists():
                checkpoint.unlink()
        log.info(
            "finished in %.1f s: h_min min %.3g um, p_max max %.3g MPa, %d cycles, periodic %s",
            wall,
            summary.h_min_min * 1e6,
            summary.p_max_max / 1e6,
            cycles_done,
            periodic,
        )
        if run.thermal is not None:
            log.info(
                "film temperature %.6g C, viscosity %.6g Pa s, heat balance closure %.2g",
                summary.film_temperature,
                summary.film_viscosity,
                summary.thermal_closure,
            )
        return summary
    finally:
        results_io.detach_log(handler)
        if run is not None and run.model is not None:
            run.model.close()


def _cycles(run: _Run, out_dir: Path, progress: bool, resume: bool):
    """Integrate cycles until periodic (and, with oil.thermal = "effective", thermally consistent);
    checkpoint at cycle ends. Returns (last cycle, count, periodic)."""
    case, comm = run.case, run.comm
    fingerprint = _case_fingerprint(case, run.joint_name)
    checkpoint = out_dir / "checkpoint.npz"
    state = results_io.read_checkpoint(checkpoint, fingerprint) if resume else None
    timings: list[dict[str, float]] = []
    if state is not None:
        first, t0, q0, qd0, history, timings, thermal_state, film_states, friction = state
        log.info("resuming after cycle %d from %s", first, checkpoint)
        if run.model is not None:  # an elastic bushing's deformation (JFO: film fraction) history goes on
            for time_s, film_state in film_states:
                run.model.commit_history(film_state, time_s)
            if film_states:  # and the next solve starts where the run's would have: from the cycle's end
                run.model.start_from(film_states[-1][1])
        if run.thermal is not None and thermal_state:
            thermal = run.thermal
            run.thermal = EffectiveTemperature.from_state(thermal.model, thermal.tolerance, thermal_state)
    else:
        first, history, friction = 0, [], []
        t0, q0, qd0 = run.em.initial_state(0.0)
    bar = None
    if progress and comm.rank == 0:
        bar = tqdm(
            total=case.solver.max_cycles * 720,
            initial=first * 720,
            unit="deg",
            desc=case.name,
            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} deg [{elapsed}<{remaining}] {postfix}",
        )

    def report(cycle_index, angle, h_min):
        if bar is not None:
            bar.n = cycle_index * 720 + angle
            bar.set_postfix_str(
                f"cycle {cycle_index + 1}, {angle:.0f} deg, h_min {h_min * 1e6:.3f} um", refresh=False
            )
            bar.refresh()

    cycle = None
    periodic = False
    c = case.small_end.clearance
    friction_tolerance = case.solver.periodic_friction_tolerance

    def settled() -> tuple[bool, str]:  # (periodic by the cycles' min h_min and friction, what changed)
        h_change = abs(history[-1] - history[-2]) / c if len(history) > 1 else math.inf
        f_change = _relative_change(friction)
        text = (
            f"min h_min = {history[-1] * 1e6:.4g} um (change {h_change:.2g} of the clearance), "
            f"mean friction power = {friction[-1]:.6g} W (change {f_change:.2g})"
        )
        return h_change < case.solver.periodic_tolerance and (
            friction_tolerance is None or f_change < friction_tolerance
        ), text

    def at_film_temperature(t_start: float) -> None:  # the temperature the thermal iteration asks for
        if run.thermal is not None and run.thermal.temperature != run.film_temperature:
            run.set_film_temperature(run.thermal.temperature, t_start)

    def thermal_step(cycle_index: int, cycle: CycleOutput) -> bool:  # True: consistent (or isothermal)
        if run.thermal is None:
            return True
        try:
            balance = run.heat_balance(cycle)
            following = run.thermal.record(balance)
        except ThermalError as err:
            raise SimulationError(f"cycle {cycle_index + 1}: {err}") from None
        log.info(
            "cycle %d: film %.6g C, %.4g Pa s: heat %.4g W, into the oil %.4g W, carried by the side "
            "flow (%.4g mm^3/s) %.4g W, closure %.2g; next cycle at %.6g C",
            cycle_index + 1,
            balance.temperature,
            run.film_viscosity,
            balance.dissipated_power,
            balance.heat_to_oil,
            balance.side_flow * 1e9,
            balance.heat_carried,
            balance.closure,
            following,
        )
        return run.thermal.converged

    try:
        # log lines go above the progress bar instead of through it
        with _logs_above_the_bar() if bar is not None else nullcontext():
            for index in range(first, case.solver.max_cycles):
                at_film_temperature(t0)
                cycle, (t0, q0, qd0) = run.integrate_cycle(index, t0, q0, qd0, progress=report)
                history.append(cycle.h_min_min)
                friction.append(cycle.friction_power_mean)
                settled_now, text = settled()
                log.info("cycle %d: %s", index + 1, text)
                consistent = thermal_step(index, cycle)
                begin = time.perf_counter()
                timings.append(cycle.timing)
                if comm.rank == 0:
                    thermal = run.thermal.state() if run.thermal is not None else None
                    film = run.model.committed_history() if run.model is not None else None
                    results_io.write_checkpoint(
                        checkpoint,
                        fingerprint,
                        index + 1,
                        t0,
                        q0,
                        qd0,
                        history,
                        timings,
                        thermal=thermal,
                        film=film,
                        friction=friction,
                    )
                cycle.timing["io_s"] = time.perf_counter() - begin
                cycle.timing["wall_s"] += cycle.timing["io_s"]
                log.info("cycle %d: %s", index + 1, describe_timing(cycle.timing))
                if settled_now and consistent:
                    periodic = True
                    break
    finally:
        if bar is not None:
            bar.close()
    if cycle is None:  # resumed after the last allowed cycle: run one more to have outputs
        at_film_temperature(t0)
        cycle, _ = run.integrate_cycle(len(history), t0, q0, qd0)
        history.append(cycle.h_min_min)
        friction.append(cycle.friction_power_mean)
        thermal_step(len(history) - 1, cycle)
        timings.append(cycle.timing)
    run.timings = timings
    run.cycle_history = {"h_min_min": list(history), "friction_power_mean": list(friction)}
    if not settled()[0]:
        log.warning(
            "not periodic after %d cycles (tolerance %g of the clearance%s)",
            len(history),
            case.solver.periodic_tolerance,
            "" if friction_tolerance is None else f"; friction {friction_tolerance:g} of itself",
        )
    if run.thermal is not None and not run.thermal.converged:
        log.warning(
            "not thermally consistent after %d cycles: heat balance closure %.2g (tolerance %g)",
            len(history),
            run.thermal.history[-1].closure,
            run.thermal.tolerance,
        )
    return cycle, len(history), periodic
