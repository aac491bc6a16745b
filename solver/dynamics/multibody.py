"""Planar rigid multibody systems with Lagrange multipliers and Baumgarte stabilisation (numpy only).

Each body i has the Cartesian coordinates ``q_i = [x_i, y_i, phi_i]`` of its centre of mass and its
rotation; ``q`` stacks them, ``M = diag(m_i, m_i, J_i)``. Joints are holonomic constraints
``Phi(q, t) = 0`` with Jacobian ``Phi_q`` and ``gamma`` defined by ``Phi_q qdd = gamma`` (the part of
d^2 Phi/dt^2 without ``qdd``). The equations of motion are the augmented system of DESIGN 3.6
(Nikravesh 1988, eq. 6.63; Baumgarte 1972)::

    [ M    Phi_q^T ] [ qdd    ]   [ Q                                   ]
    [ Phi_q   0    ] [ lambda ] = [ gamma - 2 alpha dPhi/dt - beta^2 Phi ]          (1)

with ``dPhi/dt = Phi_q qd + Phi_t``. Sign convention of the multipliers: (1) reads
``M qdd = Q - Phi_q^T lambda``, so joint k exerts the generalized force ``-Phi_q,k^T lambda_k`` on the
bodies (:func:`joint_reactions`). Positions and velocities can also be projected back onto the
constraint manifold (:func:`project_positions`, :func:`project_velocities`), the drift control that
is better than Baumgarte's (Eich 1993; Bayo & Ledesma 1996).

Notation: ``A(phi) = [[cos, -sin], [sin, cos]]`` is a body's rotation, ``S = [[0, -1], [1, 0]]`` so
that ``dA/dphi = A S = S A``, and ``s'`` is a point in a body's frame (``s = A s'`` in the global
frame). A body index ``None`` is the ground (fixed, frame = global frame).

Force elements (:class:`Gravity`, :class:`AppliedForce`, :class:`AppliedTorque`,
:class:`ClearanceJointElement`) return the generalized force ``Q`` and, on request, its Jacobians
``dQ/dq`` and ``dQ/dqd`` that the implicit integrator needs (solver.dynamics.integrate). The clearance
joint is the interface of DESIGN 3.1: the element computes the eccentricity of the journal in the bushing
frame and its rate from the two bodies' coordinates, hands them to a :class:`ClearanceJoint` (a film
model later, :class:`LinearClearanceJoint` now) and maps the returned forces and their Jacobians back
to both bodies by the chain rule.

References: P. E. Nikravesh, Computer-Aided Analysis of Mechanical Systems, Prentice Hall 1988;
J. Baumgarte, Comput. Methods Appl. Mech. Eng. 1 (1972) 1-16; E. Eich, SIAM J. Numer. Anal. 30
(1993) 1467-1482.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import ClassVar

import numpy as np

from solver.errors import InputError, out_of_range

#: ``S`` of the module docstring: rotation by +90 degrees, ``dA/dphi = A S``.
S = np.array([[0.0, -1.0], [1.0, 0.0]])

Point = tuple[float, float]


class MechanismError(RuntimeError):
    """The mechanism cannot be solved: singular augmented matrix, or a projection did not converge."""


def rotation(phi: float) -> np.ndarray:
    """Rotation matrix ``A(phi)`` from a body frame to the global frame."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array(((c, -s), (s, c)))


def _as_point(value: Sequence[float], what: str) -> np.ndarray:
    point = np.asarray(value, dtype=float).reshape(-1)
    if point.shape != (2,) or not np.all(np.isfinite(point)):
        raise InputError(f"{what} = {value!r} must be two finite numbers (m)")
    return point


def _pose(q: np.ndarray, body: int | None) -> tuple[np.ndarray, float]:
    """Position and angle of a body (the ground is at the origin with angle 0)."""
    if body is None:
        return np.zeros(2), 0.0
    return q[3 * body : 3 * body + 2], float(q[3 * body + 2])


def _rates(qd: np.ndarray, body: int | None) -> tuple[np.ndarray, float]:
    if body is None:
        return np.zeros(2), 0.0
    return qd[3 * body : 3 * body + 2], float(qd[3 * body + 2])


# --------------------------------------------------------------------------------------------------
# Bodies
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Body:
    """A rigid planar body; its coordinates are those of its centre of mass.

    Attributes:
        name: unique name in the mechanism.
        mass: kg, >= 0 (zero only for a body whose coordinates are all fixed by joints).
        inertia: kg m^2, about the centre of mass, >= 0 (same remark).
    """

    name: str
    mass: float  # kg
    inertia: float  # kg m^2, centroidal

    def __post_init__(self) -> None:
        for attribute, unit in (("mass", "kg"), ("inertia", "kg m^2")):
            value = getattr(self, attribute)
            if not (np.isfinite(value) and value >= 0.0):
                raise out_of_range(f"body {self.name!r} {attribute}", f"{value:g}", f">= 0 {unit}")


# --------------------------------------------------------------------------------------------------
# Constraints
# --------------------------------------------------------------------------------------------------
class Constraint(abc.ABC):
    """A holonomic joint ``Phi(q, t) = 0`` of ``n_equations`` equations.

    Subclasses give ``phi``, ``jacobian`` (``Phi_q``), ``gamma`` (``Phi_q qdd = gamma``) and, when the
    constraint depends on time, ``phi_t`` (``dPhi/dt`` at fixed q).
    """

    n_equations: ClassVar[int]
    name: str

    @abc.abstractmethod
    def bodies(self) -> tuple[int | None, ...]:
        """Indices of the bodies the joint connects (``None`` = ground)."""

    @abc.abstractmethod
    def phi(self, q: np.ndarray, t: float) -> np.ndarray:
        """Constraint residual ``Phi(q, t)``, shape (n_equations,)."""

    @abc.abstractmethod
    def jacobian(self, q: np.ndarray, t: float) -> np.ndarray:
        """``Phi_q``, shape (n_equations, len(q))."""

    @abc.abstractmethod
    def gamma(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """Right-hand side of ``Phi_q qdd = gamma`` (Nikravesh 1988, eq. 3.33)."""

    def phi_t(self, q: np.ndarray, t: float) -> np.ndarray:
        """``dPhi/dt`` at fixed q (zero for joints that do not depend on time)."""
        return np.zeros(self.n_equations)


@dataclasses.dataclass(frozen=True)
class Revolute(Constraint):
    """Revolute joint: point ``s'_i`` of body i coincides with point ``s'_j`` of body j (or the ground).

    ``Phi = r_i + A_i s'_i - r_j - A_j s'_j`` (2 equations, Nikravesh 1988, eq. 4.8). The multipliers are
    a force: the joint exerts ``-lambda`` on body i and ``+lambda`` on body j (global frame, at the
    joint), so ``lambda`` is the force of body i on body j.

    Attributes:
        body_i: index of body i.
        point_i: m, the joint centre in body i's frame.
        body_j: index of body j, ``None`` for the ground.
        point_j: m, the joint centre in body j's frame (global coordinates for the ground).
        name: joint name.
    """

    body_i: int
    point_i: Point
    body_j: int | None = None
    point_j: Point = (0.0, 0.0)
    name: str = "revolute"
    n_equations: ClassVar[int] = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "_s_i", _as_point(self.point_i, f"{self.name}.point_i"))
        object.__setattr__(self, "_s_j", _as_point(self.point_j, f"{self.name}.point_j"))

    def bodies(self) -> tuple[int | None, ...]:  # noqa: D102
        return (self.body_i, self.body_j)

    def _points(self, q):
        """Global lever arms A s' of both points (zero arm for the ground side), as scalars."""
        result = []
        for body, point in ((self.body_i, self._s_i), (self.body_j, self._s_j)):
            angle = 0.0 if body is None else q[3 * body + 2]
            c, s = math.cos(angle), math.sin(angle)
            result.append((c * point[0] - s * point[1], s * point[0] + c * point[1]))
        return result

    def phi(self, q, t):  # noqa: D102
        (ax, ay), (bx, by) = self._points(q)
        value = np.array([ax - bx, ay - by])
        if self.body_i is not None:
            value += q[3 * self.body_i : 3 * self.body_i + 2]
        if self.body_j is not None:
            value -= q[3 * self.body_j : 3 * self.body_j + 2]
        return value

    def jacobian(self, q, t):  # noqa: D102
        jac = np.zeros((2, q.size))
        for body, (x, y), sign in zip((self.body_i, self.body_j), self._points(q), (1.0, -1.0)):
            if body is not None:
                k = 3 * body
                jac[0, k] = jac[1, k + 1] = sign
                jac[0, k + 2], jac[1, k + 2] = -sign * y, sign * x  # sign * S A s'
        return jac

    def gamma(self, q, qd, t):  # noqa: D102
        # d^2/dt^2 (A s') = S A s' phidd - A s' phid^2, so gamma = A_i s'_i phid_i^2 - A_j s'_j phid_j^2.
        gx = gy = 0.0
        for body, (x, y), sign in zip((self.body_i, self.body_j), self._points(q), (1.0, -1.0)):
            if body is not None:
                w2 = sign * qd[3 * body + 2] ** 2
                gx += x * w2
                gy += y * w2
        return np.array([gx, gy])


@dataclasses.dataclass(frozen=True)
class Translational(Constraint):
    """Translational (prismatic) joint: body i slides along an axis fixed in body j (or the ground).

    Two equations (Nikravesh 1988, sec. 4.4), with ``d = r_i + A_i s'_i - r_j - A_j s'_j`` and the axis
    normal ``n = A_j S u'`` (``u'`` the unit axis in body j's frame)::

        Phi_1 = phi_i - phi_j - angle          (no relative rotation)
        Phi_2 = n^T d - offset                  (point s'_i stays on the axis line, shifted by offset)

    The multipliers are ``lambda_1`` (N m, the reaction moment is ``-lambda_1`` on body i) and
    ``lambda_2`` (N, the reaction force on body i is ``-lambda_2 n``).

    Attributes:
        body_i: index of the sliding body.
        point_i: m, the sliding point in body i's frame.
        axis: direction of the axis in body j's frame (normalised here).
        body_j: index of the guiding body, ``None`` for the ground.
        point_j: m, a point of the axis in body j's frame.
        offset: m, signed distance of the sliding point from the axis along ``n = S u``.
        angle: rad, the constant angle phi_i - phi_j.
        name: joint name.
    """

    body_i: int
    point_i: Point
    axis: Point = (1.0, 0.0)
    body_j: int | None = None
    point_j: Point = (0.0, 0.0)
    offset: float = 0.0  # m
    angle: float = 0.0  # rad
    name: str = "translational"
    n_equations: ClassVar[int] = 2

    def __post_init__(self) -> None:
        axis = _as_point(self.axis, f"{self.name}.axis")
        if not np.linalg.norm(axis) > 0.0:
            raise InputError(f"{self.name}.axis = {self.axis!r} must not be zero")
        object.__setattr__(self, "_u", axis / np.linalg.norm(axis))
        object.__setattr__(self, "_s_i", _as_point(self.point_i, f"{self.name}.point_i"))
        object.__setattr__(self, "_s_j", _as_point(self.point_j, f"{self.name}.point_j"))

    def bodies(self) -> tuple[int | None, ...]:  # noqa: D102
        return (self.body_i, self.body_j)

    def _geometry(self, q):
        r_i, phi_i = _pose(q, self.body_i)
        r_j, phi_j = _pose(q, self.body_j)
        s_i = rotation(phi_i) @ self._s_i
        s_j = rotation(phi_j) @ self._s_j
        normal = rotation(phi_j) @ (S @ self._u)
        return r_i, phi_i, r_j, phi_j, s_i, s_j, normal, r_i + s_i - r_j - s_j

    def phi(self, q, t):  # noqa: D102
        _, phi_i, _, phi_j, _, _, normal, d = self._geometry(q)
        return np.array([phi_i - phi_j - self.angle, normal @ d - self.offset])

    def jacobian(self, q, t):  # noqa: D102
        r_i, _, r_j, _, s_i, s_j, normal, d = self._geometry(q)
        jac = np.zeros((2, q.size))
        i, j = self.body_i, self.body_j
        jac[0, 3 * i + 2] = 1.0
        jac[1, 3 * i : 3 * i + 2] = normal
        jac[1, 3 * i + 2] = normal @ S @ s_i
        if j is not None:
            jac[0, 3 * j + 2] = -1.0
            jac[1, 3 * j : 3 * j + 2] = -normal
            # d/dphi_j (n^T d) = (S n)^T d - n^T S s_j = -n^T S (d + s_j)
            jac[1, 3 * j + 2] = -normal @ S @ (d + s_j)
        return jac

    def gamma(self, q, qd, t):  # noqa: D102
        _, _, _, _, s_i, s_j, normal, d = self._geometry(q)
        rd_i, omega_i = _rates(qd, self.body_i)
        rd_j, omega_j = _rates(qd, self.body_j)
        d_dot = rd_i + S @ s_i * omega_i - rd_j - S @ s_j * omega_j
        # d^2/dt^2 (n^T d) = n^T d_dd + 2 n_dot^T d_dot + n_dd^T d with n_dot = S n omega_j,
        # n_dd = S n omega_j_dot - n omega_j^2; gamma collects the terms without accelerations, negated.
        value = (
            normal @ (s_i * omega_i**2 - s_j * omega_j**2)
            - 2.0 * omega_j * (S @ normal) @ d_dot
            + omega_j**2 * (normal @ d)
        )
        return np.array([0.0, value])


@dataclasses.dataclass(frozen=True)
class Driver(Constraint):
    """Prescribed motion of one coordinate: ``Phi = q_k - f(t)`` (Nikravesh 1988, sec. 4.6).

    The multiplier is the generalized force the driver needs: it exerts ``-lambda`` on the coordinate
    (a torque in N m for ``"phi"``, a force in N for ``"x"``/``"y"``).

    Attributes:
        body: index of the driven body.
        coordinate: ``"x"``, ``"y"`` or ``"phi"``.
        motion: ``t -> (f, df/dt, d^2f/dt^2)`` in m or rad and their rates.
        name: joint name.
    """

    body: int
    coordinate: str
    motion: Callable[[float], tuple[float, float, float]]
    name: str = "driver"
    n_equations: ClassVar[int] = 1

    def __post_init__(self) -> None:
        if self.coordinate not in ("x", "y", "phi"):
            raise InputError(f"{self.name}.coordinate = {self.coordinate!r} (allowed: 'x', 'y', 'phi')")

    @property
    def index(self) -> int:
        """Position of the driven coordinate in q."""
        return 3 * self.body + ("x", "y", "phi").index(self.coordinate)

    def bodies(self) -> tuple[int | None, ...]:  # noqa: D102
        return (self.body,)

    def phi(self, q, t):  # noqa: D102
        return np.array([q[self.index] - self.motion(t)[0]])

    def jacobian(self, q, t):  # noqa: D102
        jac = np.zeros((1, q.size))
        jac[0, self.index] = 1.0
        return jac

    def phi_t(self, q, t):  # noqa: D102
        return np.array([-self.motion(t)[1]])

    def gamma(self, q, qd, t):  # noqa: D102
        return np.array([self.motion(t)[2]])


def constant_speed(angle0: float, speed: float) -> Callable[[float], tuple[float, float, float]]:
    """Motion ``f(t) = angle0 + speed t`` for a :class:`Driver` (rad, rad/s)."""
    return lambda t: (angle0 + speed * t, speed, 0.0)


# --------------------------------------------------------------------------------------------------
# Force elements
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ForceEvaluation:
    """Generalized force of one or all force elements at one state.

    Attributes:
        Q: generalized force (N for x, y; N m for phi), shape (n_q,).
        dQ_dq: ``dQ/dq``, shape (n_q, n_q), or ``None`` when not requested.
        dQ_dqd: ``dQ/dqd``, shape (n_q, n_q), or ``None`` when not requested.
    """

    Q: np.ndarray
    dQ_dq: np.ndarray | None = None
    dQ_dqd: np.ndarray | None = None


class ForceElement(abc.ABC):
    """Something that produces generalized forces: gravity, an applied load, a clearance joint."""

    @abc.abstractmethod
    def evaluate(
        self, bodies: Sequence[Body], q: np.ndarray, qd: np.ndarray, t: float, jacobian: bool = False
    ) -> ForceEvaluation:
        """Generalized force at (q, qd, t); with ``jacobian`` also ``dQ/dq`` and ``dQ/dqd``."""


def _point_load(
    n_q: int, body: int, angle: float, point: np.ndarray, force: np.ndarray, torque: float
) -> np.ndarray:
    """Generalized force of a global force at body point s' plus a torque: [F, (S A s')^T F + T]."""
    Q = np.zeros(n_q)
    Q[3 * body : 3 * body + 2] = force
    Q[3 * body + 2] = (S @ rotation(angle) @ point) @ force + torque
    return Q


@dataclasses.dataclass(frozen=True)
class Gravity(ForceElement):
    """Weight ``m_i g`` of every body at its centre of mass.

    Attributes:
        acceleration: m/s^2, the gravity vector in the global frame (e.g. (0, -9.81)).
    """

    acceleration: Point = (0.0, -9.80665)

    def evaluate(self, bodies, q, qd, t, jacobian=False):  # noqa: D102
        Q = np.zeros(q.size)
        for index, body in enumerate(bodies):
            Q[3 * index : 3 * index + 2] = body.mass * np.asarray(self.acceleration, dtype=float)
        if not jacobian:
            return ForceEvaluation(Q)
        return ForceEvaluation(Q, np.zeros((q.size, q.size)), np.zeros((q.size, q.size)))


@dataclasses.dataclass(frozen=True)
class AppliedForce(ForceElement):
    """A force given in the global frame, applied at a point of a body.

    ``Q_i = [F, (S A_i s')^T F]`` (the moment of F about the centre of mass).

    Attributes:
        body: index of the loaded body.
        point: m, the point of application in the body frame.
        force: ``(t, q, qd) -> F`` (N, shape (2,), global frame).
        force_jacobian: ``(t, q, qd) -> (dF/dq, dF/dqd)`` each of shape (2, n_q), or ``None`` when F
            does not depend on the state (the moment arm's rotation is accounted for either way).
    """

    body: int
    point: Point
    force: Callable[[float, np.ndarray, np.ndarray], np.ndarray]
    force_jacobian: Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None

    def evaluate(self, bodies, q, qd, t, jacobian=False):  # noqa: D102
        _, angle = _pose(q, self.body)
        point = np.asarray(self.point, dtype=float)
        force = np.asarray(self.force(t, q, qd), dtype=float)
        Q = _point_load(q.size, self.body, angle, point, force, 0.0)
        if not jacobian:
            return ForceEvaluation(Q)
        lever = S @ rotation(angle) @ point
        dQ_dq = np.zeros((q.size, q.size))
        dQ_dqd = np.zeros((q.size, q.size))
        rows = slice(3 * self.body, 3 * self.body + 2)
        # d/dphi of (S A s')^T F at fixed F: (S S A s')^T F = -(A s')^T F
        dQ_dq[3 * self.body + 2, 3 * self.body + 2] = -(rotation(angle) @ point) @ force
        if self.force_jacobian is not None:
            dF_dq, dF_dqd = (np.asarray(a, dtype=float) for a in self.force_jacobian(t, q, qd))
            dQ_dq[rows] += dF_dq
            dQ_dq[3 * self.body + 2] += lever @ dF_dq
            dQ_dqd[rows] += dF_dqd
            dQ_dqd[3 * self.body + 2] += lever @ dF_dqd
        return ForceEvaluation(Q, dQ_dq, dQ_dqd)


@dataclasses.dataclass(frozen=True)
class AppliedTorque(ForceElement):
    """A torque on a body (N m, counter-clockwise positive).

    Attributes:
        body: index of the loaded body.
        torque: ``(t, q, qd) -> T`` in N m.
        torque_jacobian: ``(t, q, qd) -> (dT/dq, dT/dqd)`` each of shape (n_q,), or ``None`` when T does
            not depend on the state.
    """

    body: int
    torque: Callable[[float, np.ndarray, np.ndarray], float]
    torque_jacobian: Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None

    def evaluate(self, bodies, q, qd, t, jacobian=False):  # noqa: D102
        Q = np.zeros(q.size)
        Q[3 * self.body + 2] = self.torque(t, q, qd)
        if not jacobian:
            return ForceEvaluation(Q)
        dQ_dq = np.zeros((q.size, q.size))
        dQ_dqd = np.zeros((q.size, q.size))
        if self.torque_jacobian is not None:
            dT_dq, dT_dqd = self.torque_jacobian(t, q, qd)
            dQ_dq[3 * self.body + 2] = dT_dq
            dQ_dqd[3 * self.body + 2] = dT_dqd
        return ForceEvaluation(Q, dQ_dq, dQ_dqd)


# --------------------------------------------------------------------------------------------------
# Clearance joint interface (DESIGN 3.1)
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class JointForces:
    """What a clearance-joint model returns for one relative position and velocity.

    Attributes:
        force: N, shape (2,), the force of the bushing on the journal in the bushing frame (film +
            asperity + friction). The bushing receives ``-force``.
        journal_torque: N m, torque on the journal about the journal centre (counter-clockwise +).
        bushing_torque: N m, torque on the bushing about the bushing centre (counter-clockwise +).
        jacobian: shape (4, 5) or ``None``: derivatives of ``[F'_x, F'_y, T_journal, T_bushing]`` with
            respect to ``[e'_x, e'_y, de'_x/dt, de'_y/dt, omega_rel]``.
    """

    force: np.ndarray
    journal_torque: float = 0.0
    bushing_torque: float = 0.0
    jacobian: np.ndarray | None = None


class ClearanceJoint(abc.ABC):
    """A journal (pin) in a bushing with clearance: the law from relative kinematics to forces.

    Implementations are the film models (the coupling issue) and :class:`LinearClearanceJoint`. The
    arguments are those of DESIGN 3.1: the eccentricity ``e' = A_b^T (r_journal - r_bushing)`` in the
    bushing frame, its rate ``de'/dt`` in the bushing frame (frame rotation included) and the relative
    rotation speed ``omega_journal - omega_bushing``.
    """

    @abc.abstractmethod
    def forces(
        self, ecc: np.ndarray, ecc_rate: np.ndarray, omega_rel: float, t: float, jacobian: bool = False
    ) -> JointForces:
        """Forces at one state. THIS is the (possibly expensive) force evaluation, e.g. a film solve.

        Args:
            ecc: m, shape (2,), eccentricity of the journal centre in the bushing frame.
            ecc_rate: m/s, shape (2,), its time derivative in the bushing frame.
            omega_rel: rad/s, journal minus bushing angular velocity.
            t: s, time.
            jacobian: also return ``JointForces.jacobian`` (exact, e.g. from the film's factorisation).
        """

    #: the variables of the results' table (solver.study.results.VARIABLES) that ``outputs`` gives
    OUTPUTS: ClassVar[tuple[str, ...]] = ()

    def outputs(self, ecc, ecc_rate, omega_rel, t, forces: JointForces) -> dict[str, float]:
        """The joint's own output variables (``OUTPUTS``) at a state whose ``forces`` were just
        evaluated; a joint with none reports nothing (the study fills them with their defaults)."""
        return {}


@dataclasses.dataclass(frozen=True)
class LinearClearanceJoint(ClearanceJoint):
    """Linear spring-damper in the bushing frame: ``F' = -k e' - c de'/dt``, ``T_j = -T_b = -c_r omega_rel``.

    The simplest clearance joint, for tests and as a template for film models. With large ``k`` and
    ``c`` it is a very stiff joint (the case the implicit integrator is for).

    Attributes:
        stiffness: N/m, k >= 0.
        damping: N s/m, c >= 0.
        rotational_damping: N m s, c_r >= 0.
    """

    stiffness: float  # N/m
    damping: float  # N s/m
    rotational_damping: float = 0.0  # N m s

    def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):  # noqa: D102
        force = -self.stiffness * np.asarray(ecc) - self.damping * np.asarray(ecc_rate)
        torque = -self.rotational_damping * omega_rel
        jac = None
        if jacobian:
            jac = np.zeros((4, 5))
            jac[0:2, 0:2] = -self.stiffness * np.eye(2)
            jac[0:2, 2:4] = -self.damping * np.eye(2)
            jac[2, 4] = -self.rotational_damping
            jac[3, 4] = self.rotational_damping
        return JointForces(force, torque, -torque, jac)


@dataclasses.dataclass(frozen=True)
class ClearanceKinematics:
    """Relative pin/bushing kinematics of DESIGN 3.1 and their derivatives with respect to q, qd.

    Attributes:
        ecc: m, e' = A_b^T (r_J - r_B), bushing frame.
        ecc_rate: m/s, de'/dt = A_b^T (v_J - v_B) - omega_b S e'.
        omega_rel: rad/s, omega_j - omega_b.
        dz_dq: (5, n_q), derivative of z = [e', de'/dt, omega_rel] with respect to q.
        dz_dqd: (5, n_q), derivative of z with respect to qd.
    """

    ecc: np.ndarray
    ecc_rate: np.ndarray
    omega_rel: float
    dz_dq: np.ndarray
    dz_dqd: np.ndarray


@dataclasses.dataclass(frozen=True)
class ClearanceJointElement(ForceElement):
    """Force element that connects a :class:`ClearanceJoint` to two bodies (journal j, bushing b).

    Kinematics (DESIGN 3.1), with ``r_J = r_j + A_j s'_j`` and ``r_B = r_b + A_b s'_b`` the centres::

        e'       = A_b^T (r_J - r_B)
        de'/dt   = A_b^T (v_J - v_B) - omega_b S e'          (rate in the rotating bushing frame)
        omega_rel = omega_j - omega_b

    Loads: the journal gets ``F = A_b F'`` at ``r_J`` plus ``T_journal``; the bushing gets ``-F`` at
    ``r_B`` plus ``T_bushing``. The Jacobians are ``dQ/dq = G (dY/dz) (dz/dq) + (dG/dq) Y`` and
    ``dQ/dqd = G (dY/dz) (dz/dqd)`` with ``Y = [F', T_j, T_b]`` and ``G = dQ/dY``, so one call of
    ``joint.forces(..., jacobian=True)`` gives the exact Jacobian the implicit integrator needs.

    Attributes:
        joint: the force law.
        journal_body: index of the body carrying the journal (pin), ``None`` for the ground.
        journal_point: m, journal centre in that body's frame.
        bushing_body: index of the body carrying the bushing, ``None`` for the ground.
        bushing_point: m, bushing centre in that body's frame.
        name: element name.
    """

    joint: ClearanceJoint
    journal_body: int | None
    journal_point: Point
    bushing_body: int | None
    bushing_point: Point
    name: str = "clearance_joint"

    def __post_init__(self) -> None:
        object.__setattr__(self, "_s_j", _as_point(self.journal_point, f"{self.name}.journal_point"))
        object.__setattr__(self, "_s_b", _as_point(self.bushing_point, f"{self.name}.bushing_point"))

    def kinematics(self, q: np.ndarray, qd: np.ndarray) -> ClearanceKinematics:
        """Eccentricity, its rate and the relative speed, with their derivatives (no force evaluation)."""
        j, b = self.journal_body, self.bushing_body
        r_j, phi_j = _pose(q, j)
        r_b, phi_b = _pose(q, b)
        rd_j, omega_j = _rates(qd, j)
        rd_b, omega_b = _rates(qd, b)
        A_b = rotation(phi_b)
        s_j = rotation(phi_j) @ self._s_j
        s_b = A_b @ self._s_b
        ecc = A_b.T @ (r_j + s_j - r_b - s_b)
        velocity = rd_j + S @ s_j * omega_j - rd_b - S @ s_b * omega_b
        ecc_rate = A_b.T @ velocity - omega_b * (S @ ecc)
        de_dq = np.zeros((2, q.size))
        dedot_dq = np.zeros((2, q.size))
        domega_dqd = np.zeros(q.size)
        if j is not None:
            de_dq[:, 3 * j : 3 * j + 2] = A_b.T
            de_dq[:, 3 * j + 2] = A_b.T @ S @ s_j
            dedot_dq[:, 3 * j : 3 * j + 2] = -omega_b * (S @ A_b.T)
            dedot_dq[:, 3 * j + 2] = -A_b.T @ s_j * omega_j - omega_b * (S @ A_b.T @ S @ s_j)
            domega_dqd[3 * j + 2] = 1.0
        if b is not None:
            de_dq[:, 3 * b : 3 * b + 2] = -A_b.T
            de_dq[:, 3 * b + 2] = -S @ (ecc + self._s_b)
            dedot_dq[:, 3 * b : 3 * b + 2] = omega_b * (S @ A_b.T)
            dedot_dq[:, 3 * b + 2] = -S @ A_b.T @ velocity - omega_b * ecc
            domega_dqd[3 * b + 2] = -1.0
        dz_dq = np.vstack([de_dq, dedot_dq, np.zeros((1, q.size))])
        # de'/dt = (de'/dq) qd, hence d(de'/dt)/dqd = de'/dq.
        dz_dqd = np.vstack([np.zeros((2, q.size)), de_dq, domega_dqd[None, :]])
        return ClearanceKinematics(ecc, ecc_rate, omega_j - omega_b, dz_dq, dz_dqd)

    def loads(
        self, q: np.ndarray, qd: np.ndarray, t: float, forces: JointForces | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Loads ``[F_x, F_y, T]`` (N, N, N m; global frame) on the journal body and on the bushing body.

        The force acts at the journal centre (resp. bushing centre) and T is the joint torque about that
        centre; pass ``forces`` to reuse an evaluation, otherwise this calls ``joint.forces`` once.
        """
        if forces is None:
            kin = self.kinematics(q, qd)
            forces = self.joint.forces(kin.ecc, kin.ecc_rate, kin.omega_rel, t)
        F = rotation(_pose(q, self.bushing_body)[1]) @ np.asarray(forces.force, dtype=float)
        journal = np.array([F[0], F[1], forces.journal_torque])
        return journal, np.array([-F[0], -F[1], forces.bushing_torque])

    def evaluate(self, bodies, q, qd, t, jacobian=False):  # noqa: D102
        kin = self.kinematics(q, qd)
        result = self.joint.forces(kin.ecc, kin.ecc_rate, kin.omega_rel, t, jacobian=jacobian)
        j, b = self.journal_body, self.bushing_body
        _, phi_j = _pose(q, j)
        _, phi_b = _pose(q, b)
        A_b = rotation(phi_b)
        s_j = rotation(phi_j) @ self._s_j
        s_b = A_b @ self._s_b
        F = A_b @ np.asarray(result.force, dtype=float)
        Q = np.zeros(q.size)
        G = np.zeros((q.size, 4))  # dQ/dY, Y = [F'_x, F'_y, T_j, T_b]
        if j is not None:
            Q[3 * j : 3 * j + 2] += F
            Q[3 * j + 2] += (S @ s_j) @ F + result.journal_torque
            G[3 * j : 3 * j + 2, 0:2] += A_b
            G[3 * j + 2, 0:2] += (S @ s_j) @ A_b
            G[3 * j + 2, 2] += 1.0
        if b is not None:
            Q[3 * b : 3 * b + 2] -= F
            Q[3 * b + 2] += -(S @ s_b) @ F + result.bushing_torque
            G[3 * b : 3 * b + 2, 0:2] -= A_b
            G[3 * b + 2, 0:2] -= (S @ s_b) @ A_b
            G[3 * b + 2, 3] += 1.0
        if not jacobian:
            return ForceEvaluation(Q)
        if result.jacobian is None:
            raise MechanismError(f"{self.name}: the joint returned no Jacobian although one was requested")
        GJ = G @ np.asarray(result.jacobian, dtype=float)
        dQ_dq = GJ @ kin.dz_dq
        dQ_dqd = GJ @ kin.dz_dqd
        # (dG/dq) Y at fixed Y: F = A_b F' turns with phi_b (dF/dphi_b = S F), lever arms turn with
        # their bodies; the bushing moment -(S A_b s'_b)^T A_b F' does not depend on phi_b.
        if j is not None:
            dQ_dq[3 * j + 2, 3 * j + 2] += -s_j @ F
            if b is not None:
                dQ_dq[3 * j : 3 * j + 2, 3 * b + 2] += S @ F
                dQ_dq[3 * j + 2, 3 * b + 2] += s_j @ F
        if b is not None:
            dQ_dq[3 * b : 3 * b + 2, 3 * b + 2] -= S @ F
        return ForceEvaluation(Q, dQ_dq, dQ_dqd)


# --------------------------------------------------------------------------------------------------
# The mechanism
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Mechanism:
    """Bodies, joints and force elements; assembles M, Phi, Phi_q, Phi_t, gamma and Q.

    Attributes:
        bodies: the bodies; body i owns q[3 i : 3 i + 3].
        constraints: the ideal joints; their equations are stacked in this order.
        force_elements: gravity, applied loads, clearance joints.
        rows: (set on construction) ``{joint name: slice}`` of each joint's rows in Phi and lambda.
    """

    bodies: tuple[Body, ...]
    constraints: tuple[Constraint, ...] = ()
    force_elements: tuple[ForceElement, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "bodies", tuple(self.bodies))
        object.__setattr__(self, "constraints", tuple(self.constraints))
        object.__setattr__(self, "force_elements", tuple(self.force_elements))
        names = [body.name for body in self.bodies]
        if len(set(names)) != len(names):
            raise InputError(f"body names must be unique, got {names}")
        joint_names = [c.name for c in self.constraints]
        if len(set(joint_names)) != len(joint_names):
            raise InputError(f"joint names must be unique, got {joint_names}")
        for constraint in self.constraints:
            for body in constraint.bodies():
                if body is not None and not 0 <= body < len(self.bodies):
                    raise InputError(f"joint {constraint.name!r} refers to body {body}, which does not exist")
        rows, start = {}, 0
        for constraint in self.constraints:
            rows[constraint.name] = slice(start, start + constraint.n_equations)
            start += constraint.n_equations
        object.__setattr__(self, "rows", rows)
        diagonal = np.ravel([[b.mass, b.mass, b.inertia] for b in self.bodies])
        object.__setattr__(self, "_mass_matrix", np.diag(diagonal))

    @property
    def n_coordinates(self) -> int:
        """Number of coordinates, 3 per body."""
        return 3 * len(self.bodies)

    @property
    def n_constraints(self) -> int:
        """Number of constraint equations (= number of multipliers)."""
        return sum(c.n_equations for c in self.constraints)

    @property
    def mass_matrix(self) -> np.ndarray:
        """``M = diag(m_i, m_i, J_i)`` (a copy)."""
        return self._mass_matrix.copy()

    def body_index(self, name: str) -> int:
        """Index of the body called ``name``."""
        for index, body in enumerate(self.bodies):
            if body.name == name:
                return index
        raise KeyError(name)

    def constraint(self, name: str) -> Constraint:
        """The joint called ``name``."""
        for constraint in self.constraints:
            if constraint.name == name:
                return constraint
        raise KeyError(name)

    def phi(self, q: np.ndarray, t: float) -> np.ndarray:
        """Stacked residuals ``Phi(q, t)``."""
        return np.concatenate([c.phi(q, t) for c in self.constraints] or [np.zeros(0)])

    def jacobian(self, q: np.ndarray, t: float) -> np.ndarray:
        """Stacked ``Phi_q``, shape (n_constraints, n_coordinates)."""
        if not self.constraints:
            return np.zeros((0, q.size))
        return np.vstack([c.jacobian(q, t) for c in self.constraints])

    def phi_t(self, q: np.ndarray, t: float) -> np.ndarray:
        """Stacked ``Phi_t``."""
        return np.concatenate([c.phi_t(q, t) for c in self.constraints] or [np.zeros(0)])

    def gamma(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """Stacked ``gamma`` of ``Phi_q qdd = gamma``."""
        return np.concatenate([c.gamma(q, qd, t) for c in self.constraints] or [np.zeros(0)])

    def forces(self, q: np.ndarray, qd: np.ndarray, t: float, jacobian: bool = False) -> ForceEvaluation:
        """Sum of all force elements' generalized forces (and Jacobians). The force evaluation."""
        n = q.size
        Q = np.zeros(n)
        dQ_dq = np.zeros((n, n)) if jacobian else None
        dQ_dqd = np.zeros((n, n)) if jacobian else None
        for element in self.force_elements:
            part = element.evaluate(self.bodies, q, qd, t, jacobian=jacobian)
            Q += part.Q
            if jacobian:
                dQ_dq += part.dQ_dq
                dQ_dqd += part.dQ_dqd
        return ForceEvaluation(Q, dQ_dq, dQ_dqd)

    def augmented_matrix(self, q: np.ndarray, t: float) -> np.ndarray:
        """The matrix of (1), ``[[M, Phi_q^T], [Phi_q, 0]]``."""
        jac = self.jacobian(q, t)
        m = jac.shape[0]
        return np.block([[self._mass_matrix, jac.T], [jac, np.zeros((m, m))]])

    def energy(self, q: np.ndarray, qd: np.ndarray, gravity: Sequence[float] = (0.0, 0.0)) -> float:
        """Kinetic plus gravitational potential energy (J), ``1/2 qd^T M qd - sum m_i g . r_i``."""
        g = np.asarray(gravity, dtype=float)
        potential = -sum(b.mass * (g @ q[3 * i : 3 * i + 2]) for i, b in enumerate(self.bodies))
        return 0.5 * qd @ self._mass_matrix @ qd + potential


def _solve_augmented(mechanism: Mechanism, matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    try:
        solution = np.linalg.solve(matrix, rhs)
    except np.linalg.LinAlgError as err:
        raise MechanismError(
            "singular augmented matrix (redundant joints, or a massless body with a free coordinate)"
        ) from err
    return solution


def accelerations(
    mechanism: Mechanism,
    q: np.ndarray,
    qd: np.ndarray,
    t: float,
    Q: np.ndarray,
    *,
    alpha: float = 0.0,
    beta: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations and multipliers from the augmented system (1) with Baumgarte's terms.

    Args:
        mechanism: the mechanism.
        q: coordinates (m, rad).
        qd: velocities (m/s, rad/s).
        t: s, time.
        Q: generalized forces at (q, qd, t), from ``mechanism.forces`` (the caller pays the force
            evaluation, so that it is visible where the expensive calls happen).
        alpha: 1/s, Baumgarte's velocity feedback (0 = none).
        beta: 1/s, Baumgarte's position feedback (0 = none).

    Returns:
        ``(qdd, lambda)``; the joints exert ``-Phi_q^T lambda`` on the bodies.
    """
    jac = mechanism.jacobian(q, t)
    rhs = mechanism.gamma(q, qd, t)
    if alpha:
        rhs = rhs - 2.0 * alpha * (jac @ qd + mechanism.phi_t(q, t))
    if beta:
        rhs = rhs - beta**2 * mechanism.phi(q, t)
    n, m = q.size, jac.shape[0]
    matrix = np.zeros((n + m, n + m))
    matrix[:n, :n] = mechanism._mass_matrix
    matrix[:n, n:] = jac.T
    matrix[n:, :n] = jac
    solution = _solve_augmented(mechanism, matrix, np.concatenate([Q, rhs]))
    return solution[:n], solution[n:]


def project_positions(
    mechanism: Mechanism, q: np.ndarray, t: float, *, tolerance: float = 1e-12, max_iterations: int = 30
) -> np.ndarray:
    """Closest point on ``Phi(q, t) = 0``: Gauss-Newton with minimum-norm corrections.

    ``q <- q - Phi_q^+ Phi`` until ``max |Phi| <= tolerance`` (m or rad); for a kinematically determined
    mechanism (square ``Phi_q``) this is Newton's method on the constraint equations.

    Raises:
        MechanismError: no convergence (the configuration cannot be assembled).
    """
    q = np.array(q, dtype=float)
    for _ in range(max_iterations):
        residual = mechanism.phi(q, t)
        if residual.size == 0 or np.max(np.abs(residual)) <= tolerance:
            return q
        correction, *_ = np.linalg.lstsq(mechanism.jacobian(q, t), -residual, rcond=None)
        q += correction
    raise MechanismError(
        f"position projection did not converge in {max_iterations} iterations "
        f"(max |Phi| = {np.max(np.abs(mechanism.phi(q, t))):.3g}); can the mechanism be assembled?"
    )


def project_velocities(mechanism: Mechanism, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
    """Closest velocities with ``Phi_q qd + Phi_t = 0`` (minimum-norm correction)."""
    qd = np.array(qd, dtype=float)
    if not mechanism.constraints:
        return qd
    jac = mechanism.jacobian(q, t)
    correction, *_ = np.linalg.lstsq(jac, -(jac @ qd + mechanism.phi_t(q, t)), rcond=None)
    return qd + correction


def joint_reactions(mechanism: Mechanism, q: np.ndarray, t: float, lam: np.ndarray) -> dict[str, np.ndarray]:
    """Loads that each ideal joint exerts on the bodies, from the multipliers.

    Returns:
        ``{joint name: R}`` with ``R`` of shape (n_bodies, 3): row i is ``[F_x, F_y, M_z]`` exerted by the
        joint on body i (N, N, N m; global frame; the moment about body i's centre of mass), i.e. the
        rows of ``-Phi_q,k^T lambda_k``. For a :class:`Revolute` the force acts at the joint centre, so
        ``R[body_j, :2]`` is the force of body i on body j.
    """
    result = {}
    for constraint in mechanism.constraints:
        rows = mechanism.rows[constraint.name]
        generalized = -constraint.jacobian(q, t).T @ lam[rows]
        result[constraint.name] = generalized.reshape(len(mechanism.bodies), 3)
    return result
