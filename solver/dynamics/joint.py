"""Clearance-joint laws for the small end and the big end: kinematics in, forces and torques (with
Jacobians) out.

All three implement ``solver.dynamics.multibody.ClearanceJoint`` (DESIGN 3.1): the arguments are the
eccentricity ``e'`` of the journal (pin) in the bushing frame [m], its rate ``de'/dt`` in the bushing
frame [m/s] and the relative speed ``omega_rel = omega_journal - omega_bushing`` [rad/s]; the result is
the force of the bushing on the journal in the bushing frame, the torques on journal and bushing about
their centres (counter-clockwise +), and on request the Jacobian ``d[F'_x, F'_y, T_j, T_b] /
d[e'_x, e'_y, de'_x/dt, de'_y/dt, omega_rel]``.

- ``FilmJoint``: the finite-element mixed-lubrication film (solver.film.model.Film): averaged
  Reynolds equation with VI cavitation, Greenwood-Tripp asperity contact, viscous and asperity
  friction; its Jacobian is exact with the active set frozen (one factorisation, back-substitutions).
- ``ShortBearingJoint``: Ocvirk's short-bearing film (Reynolds without the circumferential pressure
  flow, half-Sommerfeld cavitation) for rotation and squeeze, as most of the literature used.
- ``DryContactJoint``: Lankarani-Nikravesh contact force with Coulomb friction, no lubricant.
- ``EqualFilmsJoint``: equal finite-element films side by side (a floating pin's two bosses), one solved.

A film solve that fails, or a state outside the clearance (``|e'| >= c`` for the film models), returns
NaN forces: the implicit integrator then retries the step shorter (solver.dynamics.integrate).
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import numpy as np

from solver.case import Case
from solver.dynamics.multibody import ClearanceJoint, JointForces
from solver.errors import FilmNotConverged, InputError, out_of_range
from solver.film.surface import Surface

JOINTS = ("mixed-fem", "short-bearing", "dry", "ideal")

_NAN_FORCES = JointForces(np.full(2, np.nan), math.nan, math.nan, np.full((4, 5), np.nan))


def _complex_step_jacobian(function, z: np.ndarray) -> np.ndarray:
    """d function / d z by complex steps: exact to round-off for analytic (branch-free) expressions."""
    h = 1e-30 * max(1.0, float(np.max(np.abs(z))))
    columns = []
    for k in range(z.size):
        zc = z.astype(complex)
        zc[k] += 1j * h
        columns.append(np.imag(function(zc)) / h)
    return np.column_stack(columns)


class FilmJoint(ClearanceJoint):
    """The finite-element film (and asperity contact) of solver.film.model as a clearance joint.

    The film model is built once and reused: each call updates its kinematics and warm-starts the VI.
    Asking for the Jacobian at the state just solved costs no new solve, and the film results of the
    last ``CACHE_SIZE`` states are kept (``result_at``), so that post-processing the integrator's
    output states does not solve the film again. Counters: ``n_solves``, ``n_jacobians``,
    ``n_failures``.

    With an elastic bushing the film also depends on time, through the deformation's rate (implicit
    Euler from the last committed state): the time and the commit count are part of a state's key, and
    ``commit(t)`` after an accepted output state makes its deformation the start of the next rate (a
    rejected step never commits, so it cannot corrupt the history).

    Where the film is thinnest (``h_min_angle``): along the eccentricity for a rigid bushing; with an
    elastic one the film node where the deformed gap ``c - e' . n + w`` is least (taken right after the
    solve, from the film's deformation; the film's h_min is that node's gap, or the rigid gap along e'
    plus the deformation there when that is smaller: then along the eccentricity).
    """

    CACHE_SIZE = 512

    def __init__(self, model):
        from solver.film.types import Kinematics  # (numpy only)

        self._kinematics = Kinematics  # (imported once here, not on every force evaluation)
        self.model = model
        self._key: tuple | None = None
        self._result = None
        self.last_result = None
        # key -> (FilmResult, the elastic unknowns of that solve or None, bushing angle [rad] of h_min)
        self._cache: dict[tuple, tuple[object, np.ndarray | None, float]] = {}
        self._node_xy: np.ndarray | None = None  # the film's owned nodes (x, y) on the unit circle
        self._elastic = model.has_history  # the deformation's (JFO: film fraction's) history
        self._commits = 0
        self._last_key: tuple | None = None
        self.n_solves = self.n_jacobians = self.n_failures = 0
        #: a list to record the committed states' kinematics in: (t, (e_x, e_y, de_x/dt, de_y/dt, omega_rel)),
        #: a commit at the time of the last one replacing it (solver.study.relaxation); None: not recorded
        self.trace: list[tuple[float, tuple]] | None = None

    def set_viscosity(self, viscosity: float) -> None:
        """The oil's viscosity [Pa s] anew: the film keeps its history and warm start
        (solver.film.model.Film.set_viscosity); the results kept for the old viscosity are dropped."""
        self.model.set_viscosity(viscosity)
        self._cache.clear()
        self._key = None

    def _state_key(self, ecc, ecc_rate, omega_rel, t) -> tuple:
        key = (float(ecc[0]), float(ecc[1]), float(ecc_rate[0]), float(ecc_rate[1]), float(omega_rel))
        return key + (float(t), self._commits) if self._elastic else key

    def commit(self, t: float) -> np.ndarray | None:
        """Elastic bushing: the deformation of the last evaluated state, at time t, starts the next rate;
        returns that state's unknowns (solver.film.model.Film.history_state), or None."""
        if not self._elastic or self._last_key not in self._cache:
            return None
        state = self._cache[self._last_key][1]
        self.model.commit_history(state, t)
        self._commits += 1
        if self.trace is not None:
            if self.trace and self.trace[-1][0] == t:
                self.trace.pop()
            self.trace.append((float(t), self._last_key[:5]))
        return state

    def result_at(self, ecc, ecc_rate, omega_rel, t: float = 0.0):
        """The FilmResult at a state (from the cache, or a new solve); None if the solve fails."""
        key = self._state_key(ecc, ecc_rate, omega_rel, t)
        if key not in self._cache:
            self.forces(ecc, ecc_rate, omega_rel, t)
        return self._cache[key][0] if key in self._cache else None

    def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):  # noqa: D102
        key = self._state_key(ecc, ecc_rate, omega_rel, t)
        self._last_key = key
        if not all(math.isfinite(v) for v in key):
            return _NAN_FORCES
        if math.hypot(key[0], key[1]) >= self.model.bearing.clearance * self.model.max_eccentricity_ratio * (
            1 - 1e-9
        ):
            return _NAN_FORCES
        if not jacobian and key != self._key and key in self._cache:
            # a state solved before (e.g. an output state evaluated again at the start of the next
            # integration interval): the forces are known, no solve needed
            r = self._cache[key][0]
            self.last_result = r
            return JointForces(np.array(r.force), r.torque_journal, r.torque_bushing, None)
        try:
            if key != self._key:
                self._result = self.model.solve(
                    self._kinematics(key[:2], key[2:4], key[4], 0.0), float(t) if self._elastic else None
                )
                self._key = key
                self.n_solves += 1
                self._cache[key] = (
                    self._result,
                    self.model.history_state(),
                    self._h_min_angle(key[:2], self._result.h_min),
                )
                if len(self._cache) > self.CACHE_SIZE:
                    del self._cache[next(iter(self._cache))]
            jac = None
            if jacobian:
                jac = self.model.jacobian().matrix
                self.n_jacobians += 1
        except (FilmNotConverged, InputError):
            self.n_failures += 1
            self._key = None
            return _NAN_FORCES
        r = self._result
        self.last_result = r
        return JointForces(np.array(r.force), r.torque_journal, r.torque_bushing, jac)

    def _h_min_angle(self, ecc, h_min: float) -> float:
        """Bushing angle [rad, 0..2 pi) of the thinnest film of the state just solved (class docstring).
        Collective on the film's communicator with an elastic bushing."""
        along_e = math.atan2(ecc[1], ecc[0]) % (2 * math.pi)
        W = self.model.W
        if W is None:  # rigid: h = c - |e'| along e'
            return along_e
        if self._node_xy is None:
            V = self.model.V
            self._node_xy = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local, :2].copy()
        beta = self.model.frame_angle  # the solution frame's angle: a node at theta is at theta + beta
        c, s = math.cos(beta), math.sin(beta)
        x = self._node_xy @ np.array([[c, s], [-s, c]])  # the nodes in the bushing frame
        clearance = self.model.bearing.clearance
        gap = clearance * (1.0 - x @ (np.asarray(ecc, dtype=float) / clearance) + W.x.array[: len(x)])
        local = (float(gap.min()), math.atan2(*x[int(np.argmin(gap))][::-1])) if len(x) else (math.inf, 0.0)
        comm = self.model.comm
        at_nodes, angle = local if comm.size == 1 else min(comm.allgather(local))
        if h_min < at_nodes - 1e-9 * clearance:  # the film's h_min is the rigid gap's point, along e'
            return along_e
        return angle % (2 * math.pi)

    #: the variables of solver.study.results.VARIABLES this joint reports at a state (``outputs``)
    OUTPUTS: ClassVar[tuple[str, ...]] = (
        "p_max",
        "F_hydro",
        "F_asperity",
        "contact_area_ratio",
        "h_min",
        "h_min_angle",
        "deformation_max",
        "deformation_max_angle",
        "side_flow",
        "supply_flow",
        "cavitated_area_ratio",
        "oil_volume",
    )

    def outputs(self, ecc, ecc_rate, omega_rel, t, forces) -> dict[str, float]:
        """The film's variables (``OUTPUTS``) at a state whose ``forces`` were just evaluated (its
        result from the cache); {} where the film cannot be solved there."""
        result = self.result_at(ecc, ecc_rate, omega_rel, t)
        if result is None:
            return {}
        angle = self._cache[self._state_key(ecc, ecc_rate, omega_rel, t)][2]
        return {
            "p_max": result.p_max,
            "F_hydro": result.hydro_load,
            "F_asperity": result.asperity_load,
            "contact_area_ratio": result.contact_area_ratio,
            "h_min": result.h_min,
            "h_min_angle": math.degrees(angle),
            "deformation_max": result.max_deformation,
            "deformation_max_angle": result.max_deformation_theta,
            "side_flow": result.side_flow,
            "supply_flow": result.supply_flow,
            "cavitated_area_ratio": result.cavitated_area_ratio,
            "oil_volume": result.oil_volume,
        }


def _turn(angle: float) -> np.ndarray:
    """The rotation matrix of ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


_S = np.array([[0.0, -1.0], [1.0, 0.0]])  # a quarter turn: S v is v turned by +90 deg


class JournalFrameFilmJoint(ClearanceJoint):
    """The finite-element film solved in the journal's frame: a film whose feature (an oil hole) is on
    the journal and turns with it, as the crankpin's hole of the big end.

    The film model (solver.film.model.Film) holds its mesh, and so its hole, still in its own frame and
    takes the surface it is meshed on as its stationary one, with the other one sliding at the relative
    speed. Here that stationary surface is the journal's: the film is built with the journal's and the
    bushing's roughness exchanged (its "journal" is the bushing's surface) and is handed, at a relative
    angle ``phi`` of the journal frame to the bushing frame (``Q = A(phi)^T``)::

        e_f = Q e',   de_f/dt = Q de'/dt - omega_rel S e_f,   omega_f = -omega_rel

    (the gap ``c - e_f . n`` is the same gap seen from the journal, and only the slip between the
    surfaces drives the wedge and the shear). Its force on its inner body is the journal's, so
    ``F' = Q^T F_f``; its "journal" torque is on the bushing and its "bushing" torque on the journal
    (the Couette torques exchange with the slip's sign; the pressure part is shared, -e x F / 2 each;
    the asperity normals pass through the journal's centre instead of the bushing's, which moves
    ``e x F_asperity``, ~c / (mu_f R) ~ 1 % of the asperity friction torque, from one body to the
    other: their sum, the moment balance, is unchanged). The Jacobian is the film's, through these
    maps: exact at a given phi.

    ``phi = frame_angle(t)``: a function of time alone (the big end: crank angle less the ideal
    mechanism's rod angle at t; the rod's angle in the clearance joint differs from it by ~c / l,
    1e-4 rad, against a hole of ~0.2 rad).

    A film with history (the JFO film's film fraction, a Winkler shell's deformation) keeps it on its
    mesh, in the journal's frame: its rate is the change at a point of that frame, the ``dh/dt`` of the
    Reynolds equation written in it (the slip of the bushing's surface is in ``omega_f``); a Winkler
    shell's ``w = k p`` is local, so the shell's deformation at a point is the same whichever surface
    carries it. The FE eye's modes are not: they belong to the bushing (the rod's eye) and the film's
    node at theta is at theta + phi(t) on it, so the film takes the eye's shapes there,
    ``Phi(phi) = T(theta + phi, z) Psi``, for each solve's time, and the deformation's rate at a node
    through the committed states each with its own time's shapes (the deformation sliding past the
    node; solver.film.model.Film.set_bushing_angle, given ``frame_angle`` here). The modal unknowns do
    not turn, and the Jacobian's form is unchanged (exact at a given phi). ``commit(t)`` commits the
    film's last evaluated state (FilmJoint.commit).
    """

    def __init__(self, film: FilmJoint, frame_angle):
        self.film, self.model, self.frame_angle = film, film.model, frame_angle
        self.OUTPUTS = film.OUTPUTS
        film.model.set_bushing_angle(frame_angle)  # (the FE eye's shapes turn with it: the class docstring)

    def commit(self, t: float) -> np.ndarray | None:
        """A film with history: its last evaluated state, at time t, starts the next rate (in the journal's
        frame, FilmJoint.commit); returns that state's unknowns, or None."""
        return self.film.commit(t)

    def set_viscosity(self, viscosity: float) -> None:
        """The oil's viscosity [Pa s] anew (FilmJoint.set_viscosity)."""
        self.film.set_viscosity(viscosity)

    def in_journal_frame(
        self, ecc, ecc_rate, omega_rel, t
    ) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """(e_f, de_f/dt, omega_f, Q) of a bushing-frame state at time t (class docstring)."""
        Q = _turn(float(self.frame_angle(t))).T
        e_f = Q @ np.asarray(ecc, dtype=float)
        rate_f = Q @ np.asarray(ecc_rate, dtype=float) - float(omega_rel) * (_S @ e_f)
        return e_f, rate_f, -float(omega_rel), Q

    def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):  # noqa: D102
        e_f, rate_f, omega_f, Q = self.in_journal_frame(ecc, ecc_rate, omega_rel, t)
        f = self.film.forces(e_f, rate_f, omega_f, t, jacobian)
        force = Q.T @ np.asarray(f.force, dtype=float)
        jac = None
        if jacobian and f.jacobian is not None:
            # d z_f / d z, z = (e', de'/dt, omega_rel)
            M = np.zeros((5, 5))
            M[0:2, 0:2] = Q
            M[2:4, 0:2] = -float(omega_rel) * (_S @ Q)
            M[2:4, 2:4] = Q
            M[2:4, 4] = -(_S @ e_f)
            M[4, 4] = -1.0
            # (F', T_j, T_b) from the film's (F_f, T_jf, T_bf)
            P = np.zeros((4, 4))
            P[0:2, 0:2] = Q.T
            P[2, 3] = P[3, 2] = 1.0
            jac = P @ np.asarray(f.jacobian, dtype=float) @ M
        return JointForces(force, f.bushing_torque, f.journal_torque, jac)

    def outputs(self, ecc, ecc_rate, omega_rel, t, forces) -> dict[str, float]:
        """The film's variables (FilmJoint.OUTPUTS) at a state whose ``forces`` were just evaluated, the
        angles turned back to the bushing frame."""
        e_f, rate_f, omega_f, _ = self.in_journal_frame(ecc, ecc_rate, omega_rel, t)
        out = self.film.outputs(e_f, rate_f, omega_f, t, None)
        turn = math.degrees(float(self.frame_angle(t)))
        if "h_min_angle" in out:
            out["h_min_angle"] = (out["h_min_angle"] + turn) % 360.0
        if "deformation_max_angle" in out:  # rad
            out["deformation_max_angle"] = (out["deformation_max_angle"] + float(self.frame_angle(t))) % (
                2 * math.pi
            )
        return out


class EqualFilmsJoint(ClearanceJoint):
    """``films`` equal films side by side that move together, as one finite-element film solved once: a
    floating pin's two bosses (``pin_boss.films = 2``).

    The two bosses are equal (the same bore, width, clearance, surface and oil) and symmetric about the
    pin's mid-plane, and the planar model neither tilts nor bends the pin: both see the same eccentricity,
    its rate and the same relative speed, so both films are the same film. Their sum is ``films`` times
    one film of one boss's width (each with its own two edges): the force, both torques, the Jacobian
    (linear in the forces), and the flows, loads and oil volume of the outputs; the peak pressure, the
    film thickness and the area ratios are each film's own. The dissipation, computed from the forces and
    torques, counts ``films`` times with them.
    """

    #: the outputs (FilmJoint.OUTPUTS) that add over the films; the others are each film's own
    SUMMED: ClassVar[tuple[str, ...]] = ("F_hydro", "F_asperity", "side_flow", "supply_flow", "oil_volume")

    def __init__(self, film: FilmJoint, films: int):
        if films not in (1, 2):
            raise out_of_range("films", films, "1 or 2")
        self.film, self.model, self.films = film, film.model, films
        self.OUTPUTS = film.OUTPUTS

    def commit(self, t: float) -> np.ndarray | None:
        """A film with history: its last evaluated state starts the next rate (FilmJoint.commit)."""
        return self.film.commit(t)

    def set_viscosity(self, viscosity: float) -> None:
        """The oil's viscosity [Pa s] anew (FilmJoint.set_viscosity)."""
        self.film.set_viscosity(viscosity)

    def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):  # noqa: D102
        f = self.film.forces(ecc, ecc_rate, omega_rel, t, jacobian)
        n = self.films
        jac = None if f.jacobian is None else n * np.asarray(f.jacobian, dtype=float)
        return JointForces(
            n * np.asarray(f.force, dtype=float), n * f.journal_torque, n * f.bushing_torque, jac
        )

    def outputs(self, ecc, ecc_rate, omega_rel, t, forces) -> dict[str, float]:
        """The film's variables (FilmJoint.OUTPUTS), the ``SUMMED`` ones over the films."""
        out = self.film.outputs(ecc, ecc_rate, omega_rel, t, None)
        return {name: self.films * v if name in self.SUMMED else v for name, v in out.items()}


@dataclasses.dataclass(frozen=True, kw_only=True)
class ShortBearingJoint(ClearanceJoint):
    """Ocvirk's short-bearing film, half-Sommerfeld, for rotation and squeeze (bushing frame).

    With ``g(theta) = omega_rel/2 dh/dtheta + dh/dt`` (h = c - e'_x cos - e'_y sin) the short-bearing
    pressure is ``p = 6 mu g (z^2 - B^2/4) / h^3`` where positive (g < 0), so the force on the journal
    and the friction torques are integrals over theta (1440 points, exact derivatives by complex steps)::

        F' = mu B^3 R integral_{g<0} g n / h^3 dtheta
        T_j = -mu R^3 B omega_rel integral dtheta / h + R/2 integral integral p dh/dtheta dtheta dz
        T_b = +mu R^3 B omega_rel integral dtheta / h + R/2 integral integral p dh/dtheta dtheta dz

    The axial (Poiseuille) flow ``-h^3/(12 mu) dp/dz = -g z`` per unit length of circumference leaves
    both edges of the pressurised arc, so the side flow (``side_flow``) is ``Q = -B R integral_{g<0} g
    dtheta`` (>= 0; it does not depend on mu at given kinematics).

    The peak pressure (``p_max``) is on the mid-plane z = 0, ``p_max = 3/2 mu B^2 max_theta (-g / h^3)``
    over the pressurised arc (0 where there is none), rotation and squeeze together: the largest of the
    quadrature angles, refined to the stationary point ``g' h = 3 g h'`` between its neighbours. For pure
    rotation its angle from the maximum gap is Ocvirk's ``cos theta_m = (1 - sqrt(1 + 24 eps^2)) /
    (4 eps)`` (e.g. Hamrock, Fundamentals of Fluid Film Lubrication, ch. 16).

    ``films`` identical films side by side, each ``width`` wide with its own edges (a floating pin's two
    bosses), sum their forces, torques and side flow; the peak pressure is one film's.
    """

    radius: float  # m
    width: float  # m, of one film
    clearance: float  # m
    viscosity: float  # Pa s
    points: int = 1440
    films: int = 1  # identical films side by side (a floating pin's two bosses): forces, torques, flow summed

    def __post_init__(self) -> None:
        for name in ("radius", "width", "clearance", "viscosity"):
            if not getattr(self, name) > 0:
                raise out_of_range(name, getattr(self, name), "> 0")
        if self.films not in (1, 2):
            raise out_of_range("films", self.films, "1 or 2")
        object.__setattr__(self, "_theta", (np.arange(self.points) + 0.5) * 2 * math.pi / self.points)

    def set_viscosity(self, viscosity: float) -> None:
        """The oil's viscosity [Pa s] anew (the forces are linear in it)."""
        if not viscosity > 0:
            raise out_of_range("viscosity", viscosity, "> 0")
        object.__setattr__(self, "viscosity", viscosity)  # (frozen: the one value that follows the oil)

    def _wedge_and_squeeze(self, ex, ey, rx, ry, w):
        """(cos, sin, h, dh/dtheta, g) on the quadrature angles; the film is pressurised where g < 0."""
        cos, sin = np.cos(self._theta), np.sin(self._theta)
        dh = ex * sin - ey * cos
        return cos, sin, self.clearance - ex * cos - ey * sin, dh, 0.5 * w * dh - rx * cos - ry * sin

    def _outputs(self, z: np.ndarray) -> np.ndarray:
        w = z[4]
        cos, sin, h, dh, g = self._wedge_and_squeeze(*z)
        active = np.real(g) < 0
        d = 2 * math.pi / self.points
        mu, B, R = self.viscosity, self.width, self.radius
        weight = np.where(active, g / h**3, 0.0)
        Fx = mu * B**3 * R * np.sum(weight * cos) * d
        Fy = mu * B**3 * R * np.sum(weight * sin) * d
        # integral over z of p: -mu B^3 g / h^3 (where g < 0)
        pressure_moment = 0.5 * R * np.sum(-mu * B**3 * weight * dh) * d
        couette = mu * R**3 * B * w * np.sum(1.0 / h) * d
        return self.films * np.array([Fx, Fy, -couette + pressure_moment, couette + pressure_moment])

    def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):  # noqa: D102
        z = np.array([ecc[0], ecc[1], ecc_rate[0], ecc_rate[1], omega_rel], dtype=float)
        if not np.all(np.isfinite(z)) or math.hypot(z[0], z[1]) >= self.clearance * (1 - 1e-9):
            return _NAN_FORCES
        out = self._outputs(z)
        jac = _complex_step_jacobian(self._outputs, z) if jacobian else None
        return JointForces(out[:2].copy(), float(out[2]), float(out[3]), jac)

    def side_flow(self, ecc, ecc_rate, omega_rel) -> float:
        """The oil's volume flow out of both edges [m^3/s] (class docstring); NaN outside the clearance."""
        ex, ey, rx, ry = (float(v) for v in (*ecc, *ecc_rate))
        finite = all(math.isfinite(v) for v in (ex, ey, rx, ry, omega_rel))
        if not finite or math.hypot(ex, ey) >= self.clearance:
            return math.nan
        g = self._wedge_and_squeeze(ex, ey, rx, ry, omega_rel)[4]
        flow = -self.width * self.radius * np.sum(np.minimum(g, 0.0)) * 2 * math.pi / self.points
        return float(self.films * flow)

    def peak_pressure(self, ecc, ecc_rate, omega_rel) -> tuple[float, float]:
        """(p_max [Pa], its bushing angle [rad] in [0, 2 pi)) on the mid-plane (class docstring); (0, NaN)
        without a pressurised arc, (NaN, NaN) outside the clearance."""
        ex, ey, rx, ry = (float(v) for v in (*ecc, *ecc_rate))
        w = float(omega_rel)
        if not all(math.isfinite(v) for v in (ex, ey, rx, ry, w)) or math.hypot(ex, ey) >= self.clearance:
            return math.nan, math.nan

        def q(theta):  # -g / h^3 where the film is pressurised (g < 0), else 0
            cos, sin = np.cos(theta), np.sin(theta)
            h = self.clearance - ex * cos - ey * sin
            g = 0.5 * w * (ex * sin - ey * cos) - rx * cos - ry * sin
            return np.where(g < 0, -g / h**3, 0.0)

        values = q(self._theta)
        i = int(np.argmax(values))
        if not values[i] > 0:
            return 0.0, math.nan
        from scipy.optimize import minimize_scalar

        step = 2 * math.pi / self.points
        best = minimize_scalar(
            lambda theta: -float(q(theta)),
            bounds=(self._theta[i] - step, self._theta[i] + step),
            method="bounded",
            options={"xatol": 1e-10},
        )
        theta, peak = (best.x, -best.fun) if -best.fun > values[i] else (self._theta[i], values[i])
        return 1.5 * self.viscosity * self.width**2 * float(peak), float(theta) % (2 * math.pi)

    #: the variables of solver.study.results.VARIABLES this joint reports at a state (``outputs``)
    OUTPUTS: ClassVar[tuple[str, ...]] = ("F_hydro", "F_asperity", "side_flow", "p_max")

    def outputs(self, ecc, ecc_rate, omega_rel, t, forces) -> dict[str, float]:
        """The film load (all of the force: no asperity contact), the side flow and the peak pressure at
        a state whose ``forces`` were just evaluated."""
        return {
            "F_hydro": float(np.hypot(*np.asarray(forces.force))),
            "F_asperity": 0.0,
            "side_flow": self.side_flow(ecc, ecc_rate, omega_rel),
            "p_max": self.peak_pressure(ecc, ecc_rate, omega_rel)[0],
        }


def hertz_line_stiffness(
    radius: float, clearance: float, E_journal: float, nu_journal: float, E_bushing: float, nu_bushing: float
) -> float:
    """Lankarani-Nikravesh stiffness K = (4/3) E* sqrt(R*) of the pin in its bore [N/m^1.5].

    R* = R_j R_b / (R_b - R_j) for the conformal internal contact (R_b = R_j + c), and
    1/E* = (1 - nu_j^2)/E_j + (1 - nu_b^2)/E_b (Flores et al. 2006 use the same law for revolute
    clearance joints).
    """
    R_b = radius + clearance
    R_star = radius * R_b / (R_b - radius)
    E_star = 1 / ((1 - nu_journal**2) / E_journal + (1 - nu_bushing**2) / E_bushing)
    return 4 / 3 * E_star * math.sqrt(R_star)


@dataclasses.dataclass(frozen=True, kw_only=True)
class DryContactJoint(ClearanceJoint):
    """Lankarani-Nikravesh contact with Coulomb friction (no lubricant).

    Penetration ``delta = |e'| - c`` (> 0 in contact), normal ``n = e'/|e'|``; the force of the bushing
    on the journal is ``-F_n n + F_t t`` with ::

        F_n = K delta^1.5 (1 + 3 (1 - c_e^2) / 4 * d delta/dt / v_impact)
        F_t = -mu F_n v_t / sqrt(v_t^2 + v_reg^2),   v_t = slip of the journal surface over the bushing

    ``v_impact`` is a fixed reference impact speed (the law must be memoryless here), and the friction
    is smoothed below ``v_reg``. Torques: the friction force times R on the journal and on the bushing.
    With the Hertz point-contact stiffness of ``hertz_line_stiffness`` (the usual choice for revolute
    clearance joints) a pin is soft: under the firing load of the reference engine the penetration
    reaches ~2 clearances (h_min < 0 in the results means penetration).
    """

    radius: float  # m
    clearance: float  # m
    stiffness: float  # N/m^1.5, K
    restitution: float = 0.9  # c_e
    friction: float = 0.1  # mu
    impact_speed: float = 0.1  # m/s
    slip_regularisation: float = 1e-3  # m/s

    def __post_init__(self) -> None:
        if not 0 <= self.restitution <= 1:
            raise out_of_range("restitution", self.restitution, "[0, 1]")
        for name in ("radius", "clearance", "stiffness", "impact_speed", "slip_regularisation"):
            if not getattr(self, name) > 0:
                raise out_of_range(name, getattr(self, name), "> 0")

    def set_viscosity(self, viscosity: float) -> None:
        """No lubricant: the viscosity does not enter the dry contact."""

    def _outputs(self, z: np.ndarray) -> np.ndarray:
        ex, ey, rx, ry, w = z
        e = np.sqrt(ex * ex + ey * ey)
        if np.real(e) <= self.clearance:
            return np.zeros(4, dtype=z.dtype)
        nx, ny = ex / e, ey / e
        delta = e - self.clearance
        delta_rate = rx * nx + ry * ny
        Fn = (
            self.stiffness
            * delta**1.5
            * (1 + 0.75 * (1 - self.restitution**2) * delta_rate / self.impact_speed)
        )
        # slip of the journal surface at the contact point over the bushing (along t = S n):
        v_t = self.radius * w + (-rx * ny + ry * nx)
        Ft = -self.friction * Fn * v_t / np.sqrt(v_t * v_t + self.slip_regularisation**2)
        Fx, Fy = -Fn * nx - Ft * ny, -Fn * ny + Ft * nx
        return np.array([Fx, Fy, self.radius * Ft, -self.radius * Ft])

    def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):  # noqa: D102
        z = np.array([ecc[0], ecc[1], ecc_rate[0], ecc_rate[1], omega_rel], dtype=float)
        if not np.all(np.isfinite(z)):
            return _NAN_FORCES
        out = self._outputs(z)
        jac = _complex_step_jacobian(self._outputs, z) if jacobian else None
        return JointForces(np.real(out[:2]).copy(), float(np.real(out[2])), float(np.real(out[3])), jac)

    #: the variables of solver.study.results.VARIABLES this joint reports at a state (``outputs``)
    OUTPUTS: ClassVar[tuple[str, ...]] = ("F_hydro", "F_asperity")

    def outputs(self, ecc, ecc_rate, omega_rel, t, forces) -> dict[str, float]:
        """The contact load (all of the force: no film) at a state whose ``forces`` were just evaluated."""
        return {"F_hydro": 0.0, "F_asperity": float(np.hypot(*np.asarray(forces.force)))}


def surface_from_case(surf) -> Surface:
    """The film's Surface (roughness and contact models) of a case's ``surface`` section (the pin is
    the journal)."""
    return Surface(
        sigma_journal=surf.sigma_pin,
        sigma_bushing=surf.sigma_bushing,
        peklenik_gamma=surf.peklenik_gamma,
        eta_beta_sigma=surf.eta_beta_sigma,
        sigma_over_beta=surf.sigma_over_beta,
        E_journal=surf.E_pin,
        nu_journal=surf.nu_pin,
        E_bushing=surf.E_bushing,
        nu_bushing=surf.nu_bushing,
        E_composite=surf.composite_modulus,
        asperity_friction=surf.asperity_friction,
    )


def bearing_supply(oil) -> dict[str, object]:
    """The oil supply of a case's ``oil`` section (already checked to fit the small end, solver.case) as
    keyword arguments of solver.film.types.Bearing (SI; the rod frame is the bushing frame)."""
    if oil.inlet == "hole":
        return {
            "supply_pressure": oil.supply_pressure,
            "supply_hole_angle": oil.supply_hole_angle,
            "supply_hole_diameter": oil.supply_hole_diameter,
        }
    if oil.inlet == "axial-groove":
        return {
            "supply_pressure": oil.supply_pressure,
            "groove": "axial",
            "groove_angle": oil.groove_angle,
            "groove_arc": oil.groove_arc,
            "groove_length": oil.groove_length,
        }
    if oil.inlet == "circumferential-groove":
        return {
            "supply_pressure": oil.supply_pressure,
            "groove": "circumferential",
            "groove_width": oil.groove_width,
        }
    return {}


def joint_from_case(case: Case, engine, comm, joint: str):
    """The clearance-joint law of the case: (joint, film model or None). ``ideal`` gives (None, None)."""
    se, oil, surf, solver = case.small_end, case.oil, case.surface, case.solver
    if joint == "ideal":
        return None, None
    if joint == "short-bearing":
        return ShortBearingJoint(
            radius=se.pin_radius, width=se.width, clearance=se.clearance, viscosity=oil.viscosity
        ), None
    if joint == "dry":
        stiffness = hertz_line_stiffness(
            se.pin_radius, se.clearance, surf.E_pin, surf.nu_pin, surf.E_bushing, surf.nu_bushing
        )
        return DryContactJoint(
            radius=se.pin_radius,
            clearance=se.clearance,
            stiffness=stiffness,
            restitution=surf.restitution,
            friction=surf.asperity_friction,
            impact_speed=surf.impact_speed,
            slip_regularisation=solver.slip_regularisation,
        ), None
    if joint != "mixed-fem":
        raise InputError(f"joint = {joint!r} is out of range (allowed: {', '.join(map(repr, JOINTS))})")
    # the film's rules were checked when the case was read (solver.case, solver.film_rules)
    bushing = eye_bushing(se, se.pin_radius, surf, SMALL_END_SHANK_ANGLE_DEG)
    model = _film_model(
        case,
        engine,
        comm,
        radius=se.pin_radius,
        width=se.width,
        clearance=se.clearance,
        supply=bearing_supply(oil),
        bushing=bushing,
        edge_relief=edge_relief(se, "small_end"),
    )
    return FilmJoint(model), model


def edge_relief(section, name: str):
    """The bore's EdgeRelief (solver.film.relief) of a case section's ``edge_relief_*`` fields ([small_end] or
    [big_end], named ``name``), or None when its depth is 0 (a cylindrical bore)."""
    if section.edge_relief_depth == 0.0:
        return None
    from solver.film.relief import EdgeRelief

    return EdgeRelief(
        depth=section.edge_relief_depth,
        length=section.edge_relief_length,
        shape=section.edge_relief_shape,
        section=name,
    )


def _film_model(
    case: Case,
    engine,
    comm,
    *,
    radius,
    width,
    clearance,
    supply: dict,
    bushing,
    surface=None,
    joint="small_end",
    viscosity=None,
    edge_relief=None,
):
    """The finite-element film (solver.film.model.Film) of a journal of ``radius`` in a bearing of
    ``width`` and radial ``clearance`` [m]: the oil of ``[oil]`` (viscosity, cavitation law and pressure,
    piezoviscosity, cavitated shear; the inlet max-gap or none as ``oil.inlet``, the supply ``supply``:
    keyword arguments of solver.film.types.Bearing), the roughness and contact of ``[surface]`` (or of
    ``surface``, a solver.film.surface.Surface), the mesh and transport of ``[solver]``, ``omega_ref`` the
    crank speed, and ``bushing`` (None: rigid); ``joint``: the case section that chose the bushing, named
    by the film's one-line errors; ``viscosity`` [Pa s]: the film's oil viscosity instead of ``[oil]``'s
    (the piezoviscous law's reference too); ``edge_relief``: the bore's (solver.film.relief.EdgeRelief) or
    None."""
    from solver.film.spec import FilmSpec
    from solver.film.types import Bearing
    from solver.film.viscosity import viscosity_law

    oil, solver = case.oil, case.solver
    viscosity = oil.viscosity if viscosity is None else viscosity
    bearing = Bearing(
        radius=radius,
        width=width,
        clearance=clearance,
        viscosity=viscosity,
        cavitation_pressure=oil.cavitation_pressure,
        inlet="max-gap" if oil.inlet == "max-gap" else "none",
        **supply,
    )
    surface = surface if surface is not None else surface_from_case(case.surface)
    spec = FilmSpec(
        bearing=bearing,
        omega_ref=engine.crank_motion.speed,
        mesh_size=solver.mesh_size,
        mesh_edge_size=solver.mesh_edge_size,
        roughness=surface.roughness(),
        contact=surface.contact(),
        slip_regularisation=solver.slip_regularisation,
        bushing=bushing,
        piezoviscosity=viscosity_law(oil.piezoviscosity, oil.pressure_viscosity, viscosity),
        cavitation=oil.cavitation,
        transport=solver.film_fraction_transport,
        cavitated_shear=oil.cavitated_shear,
        joint=joint,
        edge_relief=edge_relief,
    )
    from solver.film.factory import make_film  # dolfinx, PETSc and gmsh: only for a finite-element joint

    return make_film(spec, comm)


def crankpin_angle_to_rod(engine):
    """phi(t) [rad]: the crank's (crankpin's) frame relative to the rod's, crank angle less the rod
    angle of the ideal mechanism, ``theta - asin((a - r sin theta) / l)`` (DESIGN 3.7's frame; the crank
    angle from the crank's prescribed motion)."""
    r, l, a = engine.crank_radius, engine.rod_length, engine.pin_offset
    motion = engine.crank_motion

    def angle(t: float) -> float:
        theta = float(motion.angle(t))
        return theta - math.asin((a - r * math.sin(theta)) / l)

    return angle


#: the eyes' shanks in their films' (bushings') frame, the rod's: its x' axis points from the big end to
#: the small end (solver.dynamics.engine), so the small eye's shank is at 180 deg, the big eye's at 0 deg
SMALL_END_SHANK_ANGLE_DEG = 180.0
BIG_END_SHANK_ANGLE_DEG = 0.0


def eye_bushing(section, radius: float, surface, shank_angle_deg: float):
    """A rod eye's shell as the film's bushing description (solver.film.bushings): None (rigid), a Winkler
    layer, or the finite-element eye (an FEEye): the keys of ``section`` (solver.case.SmallEnd or BigEnd:
    ``elastic``, the width, the shell's thickness, the eye's radius and moduli, the clamp's half angle and
    the compliance's basis, modes, tolerance and grid) round a bore of ``radius`` [m], the shell's moduli
    of ``surface`` (solver.case.Surface: E_bushing, nu_bushing), clamped around ``shank_angle_deg``.
    Cheap: nothing is meshed here."""
    from solver.film.bushings import bushing_model

    return bushing_model(
        section.elastic,
        radius=radius,
        width=section.width,
        bushing_thickness=section.bushing_thickness,
        eye_outer_radius=section.eye_outer_radius,
        E_eye=section.E_eye,
        nu_eye=section.nu_eye,
        E_bushing=surface.E_bushing,
        nu_bushing=surface.nu_bushing,
        shank_half_angle_deg=math.degrees(section.shank_half_angle),
        shank_angle_deg=shank_angle_deg,
        modes=section.compliance_modes,
        tolerance=section.compliance_tolerance,
        basis=section.compliance_basis,
        grid=(section.compliance_grid_theta, section.compliance_grid_z),
    )


def big_eye_bushing(case: Case):
    """The big end's shell (:func:`eye_bushing`): rigid, a Winkler layer, or the finite-element big eye
    (``big_end.elastic = "fe"``: the eye of ``big_end.eye_outer_radius`` with the shell of
    ``big_end.bushing_thickness`` and the moduli of ``[big_end_surface]``, clamped on the arc of
    ``big_end.shank_half_angle`` around ``BIG_END_SHANK_ANGLE_DEG``, toward the small end; the cap is
    continuous with the eye)."""
    return eye_bushing(case.big_end, case.big_end.radius, case.big_end_surface, BIG_END_SHANK_ANGLE_DEG)


def journal_frame_surface(surf):
    """The film's surface (solver.film.surface.Surface) of a joint whose film is solved in its journal's
    frame (:class:`JournalFrameFilmJoint`): the case's surface (solver.case.Surface) with the journal's
    (pin_*) and the bushing's roughness and moduli exchanged, since that film's stationary surface is
    the journal's."""
    return dataclasses.replace(
        surface_from_case(surf),
        sigma_journal=surf.sigma_bushing,
        sigma_bushing=surf.sigma_pin,
        E_journal=surf.E_bushing,
        nu_journal=surf.nu_bushing,
        E_bushing=surf.E_pin,
        nu_bushing=surf.nu_pin,
    )


def big_end_joint_from_case(case: Case, engine=None, comm=None) -> ClearanceJoint | None:
    """The big end's clearance-joint law (``big_end.joint``): ``None`` for an ideal big end, else the
    crankpin (journal, turning with the crank) in the rod's big eye (bushing): Ocvirk's short bearing in
    the oil of ``[oil]``; the finite-element film (``mixed-fem``: a :class:`FilmJoint` whose ``model`` is
    the film, built on ``comm`` with ``omega_ref`` the crank speed of ``engine``; rigid eye, the oil,
    cavitation law and max-gap inlet of ``[oil]``, the roughness of ``[big_end_surface]``, the mesh of
    ``[solver]``, the shell of ``big_end.elastic``: rigid, Winkler or the finite-element big eye
    (``big_eye_bushing``); with ``big_end.supply = "hole"`` the hole in the crankpin, the film solved in
    the crankpin's frame: a :class:`JournalFrameFilmJoint`, the FE eye's shapes turned into it); or the
    dry contact (Hertz stiffness from ``[big_end_surface]``'s moduli). The big end's surface
    (``case.big_end_surface``: the crankpin is its pin, the big eye's shell its bushing) is its own; the
    small end and the pin's bosses keep ``[surface]``."""
    be, surf = case.big_end, case.big_end_surface
    if be.joint == "ideal":
        return None
    if be.joint == "short-bearing":
        return ShortBearingJoint(
            radius=be.radius, width=be.width, clearance=be.clearance, viscosity=case.oil.viscosity
        )
    if be.joint == "dry":
        stiffness = hertz_line_stiffness(
            be.radius, be.clearance, surf.E_pin, surf.nu_pin, surf.E_bushing, surf.nu_bushing
        )
        return DryContactJoint(
            radius=be.radius,
            clearance=be.clearance,
            stiffness=stiffness,
            restitution=surf.restitution,
            friction=surf.asperity_friction,
            impact_speed=surf.impact_speed,
            slip_regularisation=case.solver.slip_regularisation,
        )
    if be.joint == "mixed-fem":
        if engine is None:
            from solver.dynamics.engine import engine_from_case

            engine = engine_from_case(case)
        if comm is None:
            from mpi4py import MPI

            comm = MPI.COMM_SELF
        bushing = big_eye_bushing(case)
        if be.supply == "none":
            model = _film_model(
                case,
                engine,
                comm,
                radius=be.radius,
                width=be.width,
                clearance=be.clearance,
                supply={},
                bushing=bushing,
                surface=surface_from_case(surf),
                joint="big_end",
                edge_relief=edge_relief(be, "big_end"),
            )
            return FilmJoint(model)
        # the crankpin's hole turns with it: the film in the crankpin's frame, its surfaces exchanged
        # (JournalFrameFilmJoint), the hole fixed on its mesh
        surface = journal_frame_surface(surf)
        model = _film_model(
            case,
            engine,
            comm,
            radius=be.radius,
            width=be.width,
            clearance=be.clearance,
            supply={
                "supply_pressure": be.supply_pressure,
                "supply_hole_angle": be.supply_hole_angle,
                "supply_hole_diameter": be.supply_hole_diameter,
            },
            bushing=bushing,
            surface=surface,
            joint="big_end",
            edge_relief=edge_relief(be, "big_end"),  # a function of z only: the same in the crankpin's frame
        )
        return JournalFrameFilmJoint(FilmJoint(model), crankpin_angle_to_rod(engine))
    raise InputError(
        f"big_end.joint = {be.joint!r} is out of range "
        "(allowed: 'ideal', 'short-bearing', 'mixed-fem', 'dry')"
    )


def pin_boss_joint_from_case(case: Case, engine=None, comm=None) -> ClearanceJoint | None:
    """The floating pin's film in the piston bosses (``pin_boss``): ``None`` for a fixed pin, else the pin
    (journal) in the bosses (bushing: the piston, which does not turn) in the oil of ``[oil]`` times
    ``pin_boss.viscosity_ratio``: Ocvirk's short bearing (``short-bearing``, smooth; ``pin_boss.films``:
    two films of half the total width side by side, or one of the total width), or the finite-element film
    (``mixed-fem``: rigid bosses, the roughness and asperity contact of ``[pin_boss_surface]``, the
    Reynolds cavitation and the inlet max-gap or none of ``[oil]``, no supply, the mesh of ``[solver]``,
    built on ``comm`` with ``omega_ref`` the crank speed of ``engine``; with ``films = 2`` one film of half
    the total width counted twice, an :class:`EqualFilmsJoint`; with ``films = 1`` a :class:`FilmJoint` of
    the total width)."""
    if case.small_end.pin != "floating":
        return None
    pb = case.pin_boss
    viscosity = case.oil.viscosity * pb.viscosity_ratio
    if pb.joint == "short-bearing":
        return ShortBearingJoint(
            radius=pb.radius,
            width=pb.width / pb.films,
            clearance=pb.clearance,
            viscosity=viscosity,
            films=pb.films,
        )
    if pb.joint == "mixed-fem":  # (oil.cavitation = "reynolds": solver.case)
        if engine is None:
            from solver.dynamics.engine import engine_from_case

            engine = engine_from_case(case)
        if comm is None:
            from mpi4py import MPI

            comm = MPI.COMM_SELF
        model = _film_model(
            case,
            engine,
            comm,
            radius=pb.radius,
            width=pb.width / pb.films,
            clearance=pb.clearance,
            supply={},
            bushing=None,
            surface=surface_from_case(case.pin_boss_surface),
            joint="pin_boss",
            viscosity=viscosity,
        )
        film = FilmJoint(model)
        return film if pb.films == 1 else EqualFilmsJoint(film, pb.films)
    raise InputError(f"pin_boss.joint = {pb.joint!r} is out of range (allowed: 'short-bearing', 'mixed-fem')")
