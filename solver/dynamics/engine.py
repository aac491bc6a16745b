"""The single-cylinder crank-rod-piston mechanism of DESIGN 3.7 on the planar multibody model.

Frame and conventions (DESIGN 3.7): origin at the crank centre, +x along the cylinder axis from the
crank to the piston, +y lateral, +z out of the plane (counter-clockwise angles and torques positive).
The crank turns counter-clockwise; crank angle ``theta`` is the angle of the crank throw from +x,
0 = TDC at the start of intake, 360 deg = firing TDC (with a pin offset the piston's extreme positions
are a little away from 0 and 180 deg). Gravity acts along -x.

Bodies (coordinates of the centres of mass, solver.dynamics.multibody):

- crank (0): centre of mass on its axis; throw (crankpin) at ``(r, 0)`` in its frame; phi = theta.
- rod (1): frame x' from the big end to the small end, origin at the centre of mass, which lies
  ``l_g`` from the big end: big end at ``(-l_g, 0)``, small end at ``(l - l_g, 0)``; phi = rod angle.
- piston (2): centre of mass at the pin centre, at ``y = a`` (pin offset), no rotation.
- pin (3), only for a full-floating pin (:class:`FloatingPin`): centre of mass at its axis, free to turn;
  the piston (2) is then the assembly without the pin, its centre at the bosses' centre.

Joints: main bearing (crank - ground, revolute at the origin), big end (crankpin - rod: an ideal
revolute, or a clearance joint with the crankpin as journal and the bushing in the rod's big eye),
small end (pin - rod: an ideal revolute, or a clearance joint with the pin on the piston as journal and
the bushing in the rod; with a floating pin the journal is the pin body, which the bosses' clearance joint
holds in the piston), cylinder (piston - ground, translational along +x at offset a), and the crank
driver ``phi_crank = theta(t)`` (constant speed or a periodic speed trace).

Loads: gravity ``m g`` along -x on every body; gas force ``F_gas = (p_cyl - p_crankcase) pi bore^2/4``
acting on the piston along -x (towards the crank) on the cylinder axis.

Reported reactions (global frame; ``EngineCycle``):

- main-bearing force: force of the crank journal on the main bearing (i.e. on the ground);
- big-end force: force of the crankpin on the rod big end;
- small-end force = ``pin_force`` of DESIGN 4: force of the pin (piston) on the rod small end,
  positive x = rod in tension at TDC (``m_pis r omega^2 (1 + r/l)`` with gas and gravity off);
- side thrust: y-force of the cylinder wall on the piston;
- crank torque: torque the driver must apply to the crank (counter-clockwise +); its cycle mean is
  negative when the gas does net work (the engine drives the driver).

For the ideal engine the crank motion is prescribed and the mechanism is kinematically determined, so
``simulate_ideal`` solves the constraint equations at each crank angle for q, qd, qdd (Newton, to
round-off) and the augmented system for the multipliers; it can also integrate the equations of
motion with the error-controlled integrators of solver.dynamics.integrate, the path the clearance joint uses.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from solver.case import Case
from solver.dynamics import gas as gas_model
from solver.dynamics.integrate import integrate
from solver.dynamics.multibody import (
    AppliedForce,
    Body,
    ClearanceJoint,
    ClearanceJointElement,
    Driver,
    Gravity,
    Mechanism,
    Revolute,
    Translational,
    accelerations,
    joint_reactions,
    project_positions,
    project_velocities,
)
from solver.errors import InputError, out_of_range

STANDARD_GRAVITY = 9.80665  # m/s^2
RPM = 2.0 * math.pi / 60.0  # rad/s per rpm
CYCLE = gas_model.CYCLE  # rad, 720 deg

CRANK, ROD, PISTON = 0, 1, 2  # body indices
PIN = 3  # the floating pin's body index (only with a floating pin)


@dataclasses.dataclass(frozen=True)
class FloatingPin:
    """A full-floating piston pin (DESIGN 9): a body of its own between the rod's small end and the piston.

    Attributes:
        mass: kg, the pin's (the piston body keeps ``piston_mass - mass``).
        inertia: kg m^2, its polar moment of inertia about its axis.
        boss: the clearance-joint law of the pin in the piston's bosses (journal = pin, bushing = piston).
    """

    mass: float
    inertia: float
    boss: ClearanceJoint


@dataclasses.dataclass(frozen=True)
class CrankMotion:
    """Prescribed crank angle ``theta(t)``: constant speed, or a periodic speed trace ``omega(theta)``.

    The trace is interpolated as a periodic cubic spline of ``g = dt/dtheta = 1/omega`` through the
    given points, so that ``t(theta) = int g dtheta`` is exact for the spline, ``theta(t)`` is its
    inverse (Newton), ``omega = 1/g`` and ``alpha = d omega/dt = -g'/g^3`` are consistent derivatives
    of one function (the crank driver needs that).

    Attributes:
        speed: rad/s, the constant speed (ignored when a trace is given).
        trace_angle: rad, crank angles of the trace, strictly increasing in [0, 4 pi), or ``None``.
        trace_speed: rad/s, speeds at those angles (> 0), or ``None``.
    """

    speed: float
    trace_angle: np.ndarray | None = None
    trace_speed: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.trace_angle is None:
            if not (math.isfinite(self.speed) and self.speed > 0.0):
                raise out_of_range("engine.speed_rpm", f"{self.speed / RPM:g}", "> 0")
            return
        angle = np.asarray(self.trace_angle, dtype=float)
        speed = np.asarray(self.trace_speed, dtype=float)
        if np.any(speed <= 0.0) or not np.all(np.isfinite(speed)):
            raise out_of_range("engine.speed_file speed_rpm", f"{speed.min() / RPM:g}", "> 0")
        nodes = np.append(angle, angle[0] + CYCLE)
        spline = CubicSpline(nodes, np.append(1.0 / speed, 1.0 / speed[0]), bc_type="periodic")
        antiderivative = spline.antiderivative()
        object.__setattr__(self, "_g", spline)
        object.__setattr__(self, "_G", antiderivative)
        object.__setattr__(self, "_start", float(angle[0]))

    @classmethod
    def from_trace(cls, angle: np.ndarray, speed: np.ndarray) -> CrankMotion:
        """A periodic trace (rad, rad/s); ``speed`` of the result is the cycle-mean speed."""
        probe = cls(1.0, np.asarray(angle, dtype=float), np.asarray(speed, dtype=float))
        return cls(CYCLE / probe.cycle_time, probe.trace_angle, probe.trace_speed)

    def _window(self, theta: np.ndarray) -> np.ndarray:
        return self._start + np.mod(theta - self._start, CYCLE)

    def _g_of(self, theta: np.ndarray, derivative: int = 0) -> np.ndarray:
        if self.trace_angle is None:
            return np.full(np.shape(theta), 1.0 / self.speed if derivative == 0 else 0.0)
        return self._g(self._window(theta), derivative)

    @property
    def cycle_time(self) -> float:
        """s, duration of one 720 deg cycle."""
        if self.trace_angle is None:
            return CYCLE / self.speed
        return float(self._G(self._start + CYCLE) - self._G(self._start))

    def time(self, theta: np.ndarray | float) -> np.ndarray:
        """s, time at crank angle theta (rad), with t = 0 at theta = 0."""
        theta = np.asarray(theta, dtype=float)
        if self.trace_angle is None:
            return theta / self.speed
        cycles = np.floor(theta / CYCLE)

        def since_start(x):  # int_start^x g, x in the spline window
            return self._G(x) - self._G(self._start)

        within = since_start(self._window(np.mod(theta, CYCLE))) - since_start(self._window(0.0))
        within = np.where(within < 0.0, within + self.cycle_time, within)
        return cycles * self.cycle_time + within

    def angle(self, t: np.ndarray | float) -> np.ndarray:
        """rad, crank angle at time t (inverse of :meth:`time`, Newton's method)."""
        t = np.asarray(t, dtype=float)
        theta = t * (CYCLE / self.cycle_time)
        if self.trace_angle is None:
            return theta
        for _ in range(50):
            step = (self.time(theta) - t) / self._g_of(theta)
            theta = theta - step
            if np.max(np.abs(step)) < 1e-14 * max(1.0, float(np.max(np.abs(theta)))):
                break
        return theta

    def speed_at(self, theta: np.ndarray | float) -> np.ndarray:
        """rad/s, omega(theta)."""
        return 1.0 / self._g_of(np.asarray(theta, dtype=float))

    def acceleration_at(self, theta: np.ndarray | float) -> np.ndarray:
        """rad/s^2, d omega/dt = -g'(theta)/g(theta)^3."""
        theta = np.asarray(theta, dtype=float)
        return -self._g_of(theta, 1) / self._g_of(theta) ** 3

    def motion(self, t: float) -> tuple[float, float, float]:
        """(theta, omega, alpha) at time t: the crank driver's f(t), f', f''."""
        if self.trace_angle is None:
            return self.speed * t, self.speed, 0.0
        theta = float(self.angle(t))
        return theta, float(self.speed_at(theta)), float(self.acceleration_at(theta))


def load_speed_trace(path: str | Path) -> CrankMotion:
    """Read ``engine.speed_file`` (CSV ``crank_angle_deg,speed_rpm``) into a :class:`CrankMotion`.

    Raises:
        InputError: as solver.dynamics.gas.read_crank_angle_csv, or a speed <= 0.
    """
    theta, speed = gas_model.read_crank_angle_csv(path, {"speed_rpm": RPM}, field="engine.speed_file")
    if np.any(speed <= 0.0):
        k = int(np.argmax(speed <= 0.0))
        raise InputError(
            f"engine.speed_file = {str(path)!r}: speed_rpm = {speed[k] / RPM:g} "
            f"at {math.degrees(theta[k]):g} deg "
            "is out of range (allowed: > 0)"
        )
    return CrankMotion.from_trace(theta, speed)


@dataclasses.dataclass(frozen=True, kw_only=True)
class EngineModel:
    """Everything the mechanism needs, in SI (see the module docstring for the frame).

    Attributes:
        bore: m.
        crank_radius: m, r.
        rod_length: m, l.
        pin_offset: m, a (piston pin at y = a).
        rod_cg_from_big_end: m, l_g.
        rod_mass: kg.
        rod_inertia: kg m^2, about the rod's centre of mass.
        piston_mass: kg, piston assembly with pin.
        crank_mass: kg, centre of mass on the axis.
        crank_inertia: kg m^2.
        gravity: m/s^2, magnitude of gravity along -x (0 = off).
        crankcase_pressure: Pa, absolute.
        cylinder_pressure: p(theta), solver.dynamics.gas.CylinderPressure.
        crank_motion: theta(t).
        name: for reports.
    """

    bore: float
    crank_radius: float
    rod_length: float
    pin_offset: float = 0.0
    rod_cg_from_big_end: float
    rod_mass: float
    rod_inertia: float
    piston_mass: float
    crank_mass: float = 0.0
    crank_inertia: float = 0.0
    gravity: float = STANDARD_GRAVITY
    crankcase_pressure: float = 1e5
    cylinder_pressure: gas_model.CylinderPressure
    crank_motion: CrankMotion
    name: str = "engine"

    def __post_init__(self) -> None:
        if not self.rod_length > self.crank_radius + abs(self.pin_offset):
            raise out_of_range("rod_length", f"{self.rod_length:g} m", "> crank_radius + |pin_offset|")
        for attribute in ("bore", "crank_radius", "rod_mass", "rod_inertia", "piston_mass"):
            if not getattr(self, attribute) > 0.0:
                raise out_of_range(attribute, f"{getattr(self, attribute):g}", "> 0")

    @property
    def piston_area(self) -> float:
        """m^2, pi bore^2 / 4."""
        return math.pi * self.bore**2 / 4.0

    def gas_force(self, theta: np.ndarray | float) -> np.ndarray:
        """N, ``F_gas = (p_cyl - p_crankcase) pi bore^2/4`` (positive pushes the piston towards the crank)."""
        return (self.cylinder_pressure.pressure(theta) - self.crankcase_pressure) * self.piston_area

    def gas_force_derivative(self, theta: np.ndarray | float) -> np.ndarray:
        """N/rad, dF_gas/dtheta."""
        return self.cylinder_pressure.derivative(theta) * self.piston_area


def engine_from_case(case: Case) -> EngineModel:
    """Build the :class:`EngineModel` of a validated case (reads the pressure and speed files).

    Raises:
        InputError: bad trace files, or a gas target the single-zone model cannot reach.
    """
    e, g = case.engine, case.gas
    geometry = gas_model.CylinderGeometry(
        bore=e.bore,
        crank_radius=e.crank_radius,
        rod_length=e.rod_length,
        pin_offset=e.pin_offset,
        compression_ratio=g.compression_ratio,
    )
    if g.model == "trace":
        pressure = gas_model.load_pressure_trace(g.pressure_file)
    elif g.model == "none":
        pressure = gas_model.ConstantPressure(g.crankcase_pressure)
    else:
        targets = {"peak_pressure": g.peak_pressure, "imep": g.imep} if g.model == "single-zone" else {}
        pressure = gas_model.single_zone_model(
            geometry,
            polytropic_exponent=g.polytropic_exponent,
            intake_pressure=g.intake_pressure,
            exhaust_pressure=g.exhaust_pressure,
            combustion_start=g.combustion_start,
            combustion_duration=g.combustion_duration,
            wiebe_a=g.wiebe_a,
            wiebe_m=g.wiebe_m,
            exhaust_opening=g.exhaust_opening,
            blowdown_duration=g.blowdown_duration,
            valve_overlap=g.valve_overlap,
            **targets,
        )
    motion = load_speed_trace(e.speed_file) if e.speed_file is not None else CrankMotion(e.speed)
    return EngineModel(
        bore=e.bore,
        crank_radius=e.crank_radius,
        rod_length=e.rod_length,
        pin_offset=e.pin_offset,
        rod_cg_from_big_end=e.rod_cg_from_big_end,
        rod_mass=e.rod_mass,
        rod_inertia=e.rod_inertia,
        piston_mass=e.piston_mass,
        crank_mass=e.crank_mass,
        crank_inertia=e.crank_inertia,
        gravity=STANDARD_GRAVITY if e.gravity else 0.0,
        crankcase_pressure=g.crankcase_pressure,
        cylinder_pressure=pressure,
        crank_motion=motion,
        name=case.name,
    )


@dataclasses.dataclass(frozen=True)
class EngineMechanism:
    """The engine's :class:`Mechanism` and what is needed to read it.

    Attributes:
        engine: the engine.
        mechanism: bodies crank (0), rod (1), piston (2); joints ``main_bearing``, ``big_end`` (only
            when ideal), ``small_end`` (only when ideal), ``cylinder``, ``crank_driver``.
        small_end: the small end's clearance-joint force element, or ``None`` for an ideal small end.
        big_end: the big end's clearance-joint force element, or ``None`` for an ideal big end.
        pin_boss: the floating pin's film in the piston bosses (journal = pin, body 3; bushing = piston),
            or ``None`` for a fixed pin.
    """

    engine: EngineModel
    mechanism: Mechanism
    small_end: ClearanceJointElement | None
    big_end: ClearanceJointElement | None = None
    pin_boss: ClearanceJointElement | None = None

    @property
    def floating_pin(self) -> bool:
        """The pin is a body of its own (index ``PIN``)."""
        return self.pin_boss is not None

    @property
    def clearance_joints(self) -> dict[str, ClearanceJointElement]:
        """The clearance joints by name (``small_end``, ``big_end``, ``pin_boss``), ideal ones left out."""
        return {
            name: element
            for name, element in (
                ("small_end", self.small_end),
                ("big_end", self.big_end),
                ("pin_boss", self.pin_boss),
            )
            if element is not None
        }

    def initial_state(self, theta: float = 0.0) -> tuple[float, np.ndarray, np.ndarray]:
        """(t, q, qd) at crank angle theta, assembled exactly (pins centred, no relative motion; a floating
        pin at the piston's centre, angle 0, not turning)."""
        ideal = self if not self.clearance_joints else build_mechanism(self.engine)
        t = float(self.engine.crank_motion.time(theta))
        q = project_positions(ideal.mechanism, _configuration_guess(self.engine, theta), t, tolerance=1e-14)
        qd = project_velocities(ideal.mechanism, q, np.zeros_like(q), t)
        if self.floating_pin:
            piston = slice(3 * PISTON, 3 * PISTON + 2)
            q = np.concatenate([q, q[piston], [0.0]])
            qd = np.concatenate([qd, qd[piston], [0.0]])
        return t, q, qd


def _configuration_guess(engine: EngineModel, theta: float) -> np.ndarray:
    """Closed-form slider-crank positions, used only as the starting point of Newton's method."""
    r, l, a, l_g = engine.crank_radius, engine.rod_length, engine.pin_offset, engine.rod_cg_from_big_end
    big_end = r * np.array([math.cos(theta), math.sin(theta)])
    rod_angle = math.asin((a - big_end[1]) / l)
    rod_centre = big_end + l_g * np.array([math.cos(rod_angle), math.sin(rod_angle)])
    pin_x = big_end[0] + l * math.cos(rod_angle)
    return np.array([0.0, 0.0, theta, rod_centre[0], rod_centre[1], rod_angle, pin_x, a, 0.0])


def build_mechanism(
    engine: EngineModel,
    small_end: ClearanceJoint | None = None,
    big_end: ClearanceJoint | None = None,
    pin: FloatingPin | None = None,
) -> EngineMechanism:
    """The crank-rod-piston mechanism with ideal small and big ends, or clearance joints there.

    A clearance joint replaces the revolute constraint by its film force: the rod is then free at that
    end (two more free coordinates, its position relative to the pin, resp. to the crankpin), and the
    joint's Jacobian block enters the integrator's through the force element (solver.dynamics.multibody).

    Args:
        engine: the engine.
        small_end: ``None`` for an ideal revolute small end; otherwise the clearance-joint law, placed
            with the journal = pin centre on the piston (body 2, point (0, 0)) and the bushing centre
            in the rod at ``(l - l_g, 0)`` (body 1): forces and kinematics in the rod (bushing) frame.
        big_end: ``None`` for an ideal revolute big end; otherwise the clearance-joint law, placed with
            the journal = crankpin centre on the crank (body 0, point (r, 0)) and the bushing centre in
            the rod at ``(-l_g, 0)`` (body 1): forces and kinematics in the rod (bushing) frame, the
            relative speed ``omega_crank - omega_rod``.
        pin: ``None`` for the pin fixed in the piston; a :class:`FloatingPin`: the pin is body 3 (mass
            and inertia its own, the piston's mass ``piston_mass - pin.mass``), the small end (which must
            then be a clearance joint) has the pin as journal (relative speed ``omega_pin - omega_rod``)
            and the boss film ``pin.boss`` joins the pin (journal) to the piston (bushing, at its centre;
            relative speed ``omega_pin``). The fixed pin's bodies, constraints and their order are those of
            the mechanism without a floating pin.

    Returns:
        The :class:`EngineMechanism`.
    """
    r, l, a, l_g = engine.crank_radius, engine.rod_length, engine.pin_offset, engine.rod_cg_from_big_end
    if pin is not None and small_end is None:
        raise InputError(
            "a floating pin turns in the small end's film: the small end must be a clearance joint"
        )
    bodies = (
        Body("crank", engine.crank_mass, engine.crank_inertia),
        Body("rod", engine.rod_mass, engine.rod_inertia),
        # its rotation is fixed by the cylinder joint
        Body("piston", engine.piston_mass if pin is None else engine.piston_mass - pin.mass, 0.0),
    )
    if pin is not None:
        if not 0.0 < pin.mass < engine.piston_mass:
            raise out_of_range(
                "pin mass", f"{pin.mass:g} kg", f"(0, piston_mass = {engine.piston_mass:g} kg)"
            )
        bodies += (Body("pin", pin.mass, pin.inertia),)
    constraints = [
        Revolute(CRANK, (0.0, 0.0), None, (0.0, 0.0), name="main_bearing"),
        Translational(PISTON, (0.0, 0.0), (1.0, 0.0), None, (0.0, 0.0), offset=a, angle=0.0, name="cylinder"),
        Driver(CRANK, "phi", engine.crank_motion.motion, name="crank_driver"),
    ]
    forces = []
    element = big_element = boss_element = None
    if small_end is None:
        constraints.insert(1, Revolute(PISTON, (0.0, 0.0), ROD, (l - l_g, 0.0), name="small_end"))
    else:
        journal = PISTON if pin is None else PIN
        element = ClearanceJointElement(small_end, journal, (0.0, 0.0), ROD, (l - l_g, 0.0), name="small_end")
        forces.append(element)
    if big_end is None:
        constraints.insert(1, Revolute(CRANK, (r, 0.0), ROD, (-l_g, 0.0), name="big_end"))
    else:
        big_element = ClearanceJointElement(big_end, CRANK, (r, 0.0), ROD, (-l_g, 0.0), name="big_end")
        forces.append(big_element)
    if pin is not None:
        boss_element = ClearanceJointElement(pin.boss, PIN, (0.0, 0.0), PISTON, (0.0, 0.0), name="pin_boss")
        forces.append(boss_element)
    if engine.gravity:
        forces.append(Gravity((-engine.gravity, 0.0)))

    def gas_load(t, q, qd):
        return np.array([-float(engine.gas_force(q[3 * CRANK + 2])), 0.0])

    def gas_load_jacobian(t, q, qd):
        dF_dq = np.zeros((2, q.size))
        dF_dq[0, 3 * CRANK + 2] = -float(engine.gas_force_derivative(q[3 * CRANK + 2]))
        return dF_dq, np.zeros((2, q.size))

    # the gas force acts on the cylinder axis (y = 0), i.e. at (0, -a) in the piston frame
    forces.append(AppliedForce(PISTON, (0.0, -a), gas_load, gas_load_jacobian))
    return EngineMechanism(
        engine, Mechanism(bodies, tuple(constraints), tuple(forces)), element, big_element, boss_element
    )


@dataclasses.dataclass(frozen=True)
class EngineCycle:
    """One 720 deg cycle of the ideal-joint engine (global frame, SI; see the module docstring).

    Attributes:
        crank_angle: deg, 0 to 720 inclusive.
        time: s.
        crank_speed: rad/s.
        piston_position: m, x of the pin centre.
        piston_velocity: m/s.
        piston_acceleration: m/s^2.
        rod_angle: rad, angle of the rod axis (big end -> small end) from +x, counter-clockwise.
        main_bearing_force: N, (N, 2), force of the crank journal on the main bearing.
        big_end_force: N, (N, 2), force of the crankpin on the rod big end.
        small_end_force: N, (N, 2), force of the pin on the rod small end (DESIGN 4 ``pin_force``).
        side_thrust: N, y-force of the cylinder wall on the piston.
        crank_torque: N m, torque the driver applies to the crank (counter-clockwise +).
        cylinder_pressure: Pa, absolute.
        gas_force: N, (p_cyl - p_crankcase) pi bore^2 / 4, pushing the piston towards the crank.
        constraint_violation: max |Phi| at each point (m or rad); round-off for "kinematic".
        integrator: "kinematic" or the scipy method name.
        n_steps: integrator steps (grid points for "kinematic").
        n_force_evaluations: force evaluations by the integrator (without Jacobian); one per grid
            point for "kinematic".
        n_jacobian_evaluations: force evaluations with Jacobian.
        n_output_evaluations: force evaluations for the outputs at the grid points (dense output).
        wall_time: s.
    """

    crank_angle: np.ndarray
    time: np.ndarray
    crank_speed: np.ndarray
    piston_position: np.ndarray
    piston_velocity: np.ndarray
    piston_acceleration: np.ndarray
    rod_angle: np.ndarray
    main_bearing_force: np.ndarray
    big_end_force: np.ndarray
    small_end_force: np.ndarray
    side_thrust: np.ndarray
    crank_torque: np.ndarray
    cylinder_pressure: np.ndarray
    gas_force: np.ndarray
    constraint_violation: np.ndarray
    integrator: str
    n_steps: int
    n_force_evaluations: int
    n_jacobian_evaluations: int
    n_output_evaluations: int
    wall_time: float

    @property
    def pin_force_x(self) -> np.ndarray:
        """N, x-force of the pin on the rod small end (DESIGN 4)."""
        return self.small_end_force[:, 0]

    @property
    def pin_force_y(self) -> np.ndarray:
        """N, y-force of the pin on the rod small end (DESIGN 4)."""
        return self.small_end_force[:, 1]

    def columns(self) -> dict[str, tuple[np.ndarray, str, str]]:
        """Output variables as ``{name: (values, units, long_name)}`` (DESIGN 4 names where they exist)."""
        return {
            "crank_angle": (self.crank_angle, "degree", "crank angle (0 = TDC at start of intake)"),
            "time": (self.time, "s", "time"),
            "x_piston": (self.piston_position, "m", "piston pin position along the cylinder axis"),
            "v_piston": (self.piston_velocity, "m/s", "piston velocity"),
            "a_piston": (self.piston_acceleration, "m/s^2", "piston acceleration"),
            "rod_angle": (self.rod_angle, "rad", "connecting rod angle from the cylinder axis"),
            "main_bearing_force_x": (self.main_bearing_force[:, 0], "N", "crank on the main bearing, x"),
            "main_bearing_force_y": (self.main_bearing_force[:, 1], "N", "crank on the main bearing, y"),
            "big_end_force_x": (self.big_end_force[:, 0], "N", "force of the crankpin on the rod big end, x"),
            "big_end_force_y": (self.big_end_force[:, 1], "N", "force of the crankpin on the rod big end, y"),
            "ideal_pin_force_x": (self.pin_force_x, "N", "force of the pin on the rod small end, x (ideal)"),
            "ideal_pin_force_y": (self.pin_force_y, "N", "force of the pin on the rod small end, y (ideal)"),
            "side_thrust": (self.side_thrust, "N", "force of the cylinder wall on the piston, y"),
            "crank_torque": (self.crank_torque, "N m", "driving torque on the crank (counter-clockwise +)"),
            "p_cyl": (self.cylinder_pressure, "Pa", "cylinder pressure (absolute)"),
            "F_gas": (self.gas_force, "N", "gas force on the piston, towards the crank"),
        }


def _cycle_from_states(
    em: EngineMechanism,
    angles_deg,
    times,
    q,
    qd,
    qdd,
    lam,
    *,
    integrator,
    n_steps,
    n_force,
    n_jac,
    n_output=0,
    wall_time,
) -> EngineCycle:
    mech, engine = em.mechanism, em.engine
    n = len(times)
    main, big, small = np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2))
    side, torque, violation = np.zeros(n), np.zeros(n), np.zeros(n)
    for k in range(n):
        reactions = joint_reactions(mech, q[k], times[k], lam[k])
        main[k] = -reactions["main_bearing"][CRANK, :2]  # force of the crank on the bearing
        big[k] = reactions["big_end"][ROD, :2]  # force of the crankpin on the rod
        small[k] = reactions["small_end"][ROD, :2]  # force of the pin on the rod
        side[k] = reactions["cylinder"][PISTON, 1]  # wall on the piston
        torque[k] = reactions["crank_driver"][CRANK, 2]  # driver on the crank
        violation[k] = np.max(np.abs(mech.phi(q[k], times[k])))
    theta = q[:, 3 * CRANK + 2]
    return EngineCycle(
        crank_angle=np.asarray(angles_deg, dtype=float),
        time=np.asarray(times, dtype=float),
        crank_speed=qd[:, 3 * CRANK + 2],
        piston_position=q[:, 3 * PISTON],
        piston_velocity=qd[:, 3 * PISTON],
        piston_acceleration=qdd[:, 3 * PISTON],
        rod_angle=q[:, 3 * ROD + 2],
        main_bearing_force=main,
        big_end_force=big,
        small_end_force=small,
        side_thrust=side,
        crank_torque=torque,
        cylinder_pressure=engine.cylinder_pressure.pressure(theta),
        gas_force=engine.gas_force(theta),
        constraint_violation=violation,
        integrator=integrator,
        n_steps=n_steps,
        n_force_evaluations=n_force,
        n_jacobian_evaluations=n_jac,
        n_output_evaluations=n_output,
        wall_time=wall_time,
    )


def simulate_ideal(
    engine: EngineModel,
    *,
    step_deg: float = 0.5,
    integrator: str = "kinematic",
    method: str | None = None,
    rtol: float = 1e-8,
    atol: float | None = None,
    baumgarte: float | None = None,
    projection: bool = False,
) -> EngineCycle:
    """One 720 deg cycle with ideal joints on the crank-angle grid 0, step_deg, ..., 720.

    Args:
        engine: the engine.
        step_deg: deg, output step; 720 / step_deg must be an integer.
        integrator: ``"kinematic"``: q, qd, qdd from the constraint equations at each crank angle
            (exact to round-off, the prescribed crank makes the system kinematically determined) and
            lambda from the augmented system; ``"explicit"`` or ``"implicit"``: integrate the equations
            of motion with error control (solver.dynamics.integrate) from the assembled state at 0 deg.
        method: integrator (default ``"RK45"`` explicit, ``"ESDIRK32"`` implicit;
            see solver.dynamics.integrate).
        rtol: relative tolerance of the integrators.
        atol: absolute tolerance (default: ``rtol`` x 1e-3 m on positions, scaled by the crank speed for
            velocities).
        baumgarte: 1/s, alpha = beta of Baumgarte's terms (default: the mean crank speed; much larger
            gains make the explicit method's step stability-limited).
        projection: project onto the constraint manifold after every step.

    Returns:
        The :class:`EngineCycle` (force evaluations happen once per grid point for "kinematic").
    """
    count = 720.0 / step_deg
    if not (step_deg > 0.0 and abs(count - round(count)) < 1e-9 * count):
        raise out_of_range("step_deg", f"{step_deg:g}", "> 0 with 720 / step_deg an integer")
    start = time.perf_counter()
    em = build_mechanism(engine)
    mech = em.mechanism
    angles_deg = np.linspace(0.0, 720.0, int(round(count)) + 1)
    times = engine.crank_motion.time(np.radians(angles_deg))
    if integrator == "kinematic":
        _, q_k, qd_k = em.initial_state(0.0)
        qdd_k = np.zeros_like(q_k)
        states = {name: [] for name in ("q", "qd", "qdd", "lam")}
        for k, t_k in enumerate(times):
            if k:
                dt = t_k - times[k - 1]
                guess = q_k + qd_k * dt + 0.5 * qdd_k * dt**2
                q_k = project_positions(mech, guess, t_k, tolerance=1e-14)
                qd_k = project_velocities(mech, q_k, qd_k, t_k)
            Q = mech.forces(q_k, qd_k, t_k).Q
            qdd_k, lam_k = accelerations(mech, q_k, qd_k, t_k, Q)
            for name, value in zip(states, (q_k, qd_k, qdd_k, lam_k)):
                states[name].append(value)
        arrays = {name: np.array(value) for name, value in states.items()}
        return _cycle_from_states(
            em,
            angles_deg,
            times,
            arrays["q"],
            arrays["qd"],
            arrays["qdd"],
            arrays["lam"],
            integrator="kinematic",
            n_steps=len(times),
            n_force=len(times),
            n_jac=0,
            wall_time=time.perf_counter() - start,
        )
    if integrator not in ("explicit", "implicit"):
        raise ValueError(f"integrator = {integrator!r} (allowed: 'kinematic', 'explicit', 'implicit')")
    method = method or ("RK45" if integrator == "explicit" else "ESDIRK32")
    omega = engine.crank_motion.speed
    if atol is None:
        length_scale = 1e-3 * rtol  # m
        atol = np.concatenate(
            [
                np.tile([length_scale, length_scale, 1e-2 * rtol], 3),
                np.tile([length_scale * omega, length_scale * omega, 1e-2 * rtol * omega], 3),
            ]
        )
    gain = omega if baumgarte is None else baumgarte
    t0, q0, qd0 = em.initial_state(0.0)
    trajectory = integrate(
        mech,
        q0,
        qd0,
        (t0, float(times[-1])),
        method=method,
        rtol=rtol,
        atol=atol,
        alpha=gain,
        beta=gain,
        projection=projection,
        t_eval=times,
    )
    return _cycle_from_states(
        em,
        angles_deg,
        trajectory.t,
        trajectory.q,
        trajectory.qd,
        trajectory.qdd,
        trajectory.lam,
        integrator=method,
        n_steps=trajectory.n_steps,
        n_force=trajectory.n_force_evaluations,
        n_jac=trajectory.n_jacobian_evaluations,
        n_output=trajectory.n_output_evaluations,
        wall_time=time.perf_counter() - start,
    )
