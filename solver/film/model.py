"""The finite-element film of one journal bearing: kinematics in, forces, friction and flow out (SI).

A ``Film`` is what solver.film.factory.make_film builds from a FilmSpec: a FilmSpace (mesh, space,
geometry), its FilmForms (operator and functionals) and one FilmSolver (solver.film.interfaces: the
cavitation law with or without an elastic bushing). It is built once per bearing and reused across
solves: a change of kinematics only updates ``fem.Constant``s and warm-starts from the last solution;
a change of viscosity (``set_viscosity``) only updates constants too. After a solve, ``jacobian()``
gives the exact derivatives of the film forces and torques with respect to the eccentricity and its
rate (active set frozen). The Film never asks which kind of film it holds.

Conventions (DESIGN 3.1): see solver.film.types. Oil inlet (``Bearing.inlet``). ``"max-gap"``: the film
is at ambient pressure along the axial line of maximum film thickness (the classic finite-bearing
tables' assumption, Butenschoen 1976, Raimondi & Boyd 1958), solved in a frame turned so that line lies
on the mesh seam (solver.film.frame). ``"none"``: only the edges are at ambient pressure (and a supply
at the supply pressure) and the cavitation law alone places the film's start and end.

History (solver.film.history): a film with an elastic bushing (its deformation) or the mass-conserving
film (its film fraction) carries states between accepted steps: ``commit_history`` after each accepted
step, the rates by BDF2 through the committed states.
"""

from __future__ import annotations

import dataclasses
import math
import time

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import fem

from solver.errors import FilmNotConverged, InputError, out_of_range
from solver.film.forms import FilmForms
from solver.film.frame import FrameTurn, frame_angle, in_frame, rotation, turn_jacobian
from solver.film.functionals import quiet_jit
from solver.film.history import FilmHistory
from solver.film.interfaces import FilmSolver
from solver.film.space import FilmSpace
from solver.film.types import Bearing, FilmJacobian, FilmResult, FilmStats, Kinematics


class Film:
    """A composed film (module docstring). Build it with solver.film.factory.make_film."""

    # rad: the warm start is turned with the solution frame only when the frame jumps (the pin crossing its
    # clearance, where the field stays in the bushing frame); while it turns with the eccentricity the
    # field turns with it, and the last pressure as it is is the better start (turning it at every change
    # cost 13 % more VI iterations on a crossing and 6 x more under a load turning 0.3 rad per solve)
    TURN_THRESHOLD = 0.5

    def __init__(self, space: FilmSpace, forms: FilmForms, solver: FilmSolver):
        self.space, self.forms, self.solver = space, forms, solver
        self.spec = space.spec
        self.history = FilmHistory()
        self.stats = FilmStats()
        self._last: Kinematics | None = None
        self._beta = 0.0
        # with the max-gap inlet the solution frame turns with the eccentricity (serial: FrameTurn)
        self._turn = (
            FrameTurn(space.owned_coords)
            if space.bearing.inlet == "max-gap" and space.comm.size == 1
            else None
        )
        self._fields = None  # output Functions and the expressions they interpolate (fields_si), built once

    # -- what the study and the tools read --------------------------------------------------------
    @property
    def bearing(self) -> Bearing:
        return self.space.bearing

    @property
    def scales(self):
        return self.space.scales

    @property
    def sigma(self) -> float:
        return self.space.sigma

    @property
    def mesh(self):
        return self.space.mesh

    @property
    def mesh_spec(self):
        return self.space.mesh_spec

    @property
    def comm(self):
        return self.space.comm

    @property
    def V(self):  # noqa: N802 - the space's usual symbol
        return self.space.V

    @property
    def P(self):  # noqa: N802 - the film's unknown, the paper's symbol
        return self.space.P

    @property
    def W(self):  # noqa: N802 - the deformation / c, the paper's symbol
        return self.space.W

    @property
    def pressure(self):
        return self.space.pressure

    @property
    def dofs(self) -> int:
        """Global number of pressure unknowns."""
        return self.space.dofs

    @property
    def frame_angle(self) -> float:
        """The angle [rad] by which the last solve's solution frame is turned from the bushing frame
        (counter-clockwise): the angle of the maximum gap with the max-gap inlet (solver.film.frame),
        0 with any other inlet or before a solve. A field of the solution at theta is at
        theta + frame_angle in the bushing frame."""
        return self._beta

    @property
    def max_eccentricity_ratio(self) -> float:
        """|e| / c below which the film is defined: 1 when rigid; with an elastic bushing the pin may
        go further, into the deformed bushing."""
        return self.solver.max_eccentricity_ratio

    def reach(self, load) -> float:
        """|e| / c the journal may reach under the static ``load`` [N] (bushing frame, on the journal),
        the equilibrium's bound: max_eccentricity_ratio for a rigid film; an elastic bushing raises its
        max_eccentricity_ratio to what its compliance gives under that load
        (solver.film.solvers.CoupledFilm.reach)."""
        return self.solver.reach(load)

    def start_near(self, kin: Kinematics) -> None:
        """Make the next solve (at ``kin``) start from the last solution whose Jacobian was computed,
        moved to first order along its sensitivities: an elastic film's (CoupledFilm.start_near; a rigid
        film keeps its warm start). For a search that computes a Jacobian at each step (the
        equilibrium); the dynamics keep the last solution."""
        eps = np.asarray(in_frame(kin, self._frame_angle(kin)).ecc, float) / self.bearing.clearance
        self.solver.start_near(eps)

    def set_bushing_angle(self, angle) -> None:
        """The bushing turned against the film's frame by ``angle(t)`` [rad], a function of the solve's
        time (None: not turned; the default): a film node at theta is at theta + angle(t) on the bushing.
        For a film solved in the journal's frame (solver.dynamics.joint.JournalFrameFilmJoint): the FE
        eye's shapes are taken at the turned nodes for each solve's time, and the deformation's rate
        through the committed states each with its own time's shapes
        (solver.film.solvers.CoupledFilm.set_bushing_angle); nothing changes for a rigid film or a
        Winkler layer, whose deformation is local."""
        self.solver.set_bushing_angle(angle)

    # -- history ------------------------------------------------------------------------------------
    @property
    def has_history(self) -> bool:
        """True when a solve depends on committed film states (solver.film.history)."""
        return self.solver.has_history

    def history_state(self) -> np.ndarray | None:
        """The film state of the last solve, a copy, for ``commit_history`` (None without history)."""
        return self.solver.state()

    def commit_history(self, state: np.ndarray, time_s: float) -> None:
        """Make ``state`` (from history_state) at ``time_s`` the start of the rates for solves after
        ``time_s`` (solver.film.history.FilmHistory.commit)."""
        if not self.has_history:
            return
        if self.spec.quasi_static:
            raise InputError(
                "a quasi-static film commits no history (allowed: FilmSpec(quasi_static=False), with inlet "
                "'none' for a film with history)"
            )
        if self.history.commit(state, time_s):
            self.stats.euler_rate_steps += 1

    def start_from(self, state: np.ndarray) -> None:
        """Make ``state`` (from history_state) the next solve's warm start."""
        self.solver.start_from(state)

    def committed_history(self) -> list[tuple[float, np.ndarray]]:
        """The committed states kept, oldest first: (time [s], state), copies; [] if none."""
        return self.history.committed()

    def rate_history(self, time_s: float | None) -> list[tuple[float, np.ndarray]]:
        """The committed states a solve at ``time_s`` takes its rate from ([]: quasi-static)."""
        return self.history.before(time_s)

    # -- a new viscosity ----------------------------------------------------------------------------
    def set_viscosity(self, viscosity: float) -> None:
        """The oil's viscosity [Pa s] anew, for every film kind: the scales, p_ref in the forms and what
        follows from them (the bounds and prescribed values; an elastic bushing's gains); the film, its
        history and its warm start are kept (no new form, no recompilation)."""
        if not viscosity > 0:
            raise out_of_range("viscosity", viscosity, "> 0 Pa s")
        self.space.set_scales(dataclasses.replace(self.space.bearing, viscosity=viscosity))
        self.forms.set_scales()
        self.solver.set_scales()
        self._last = None  # (the state's forces changed: a Jacobian needs a new solve)

    # -- solve ------------------------------------------------------------------------------------
    def set_kinematics(self, kin: Kinematics) -> None:
        """Update the film's constants from SI kinematics (bushing frame)."""
        s, c = self.scales, self.bearing.clearance
        eps = np.asarray(kin.ecc, float) / c
        limit = self.max_eccentricity_ratio
        if not math.hypot(*eps) < limit:
            raise out_of_range("eccentricity ratio", f"{math.hypot(*eps):.6g}", f"[0, {limit:g})")
        rate = np.asarray(kin.ecc_rate, float) / s.eccentricity_rate
        U2 = self.bearing.radius * (kin.omega_journal - kin.omega_bushing) / s.speed  # journal, bushing frame
        U1 = 0.0
        self.space.params.set(
            eps_x=eps[0],
            eps_y=eps[1],
            deps_x=rate[0],
            deps_y=rate[1],
            U_mean=(U1 + U2) / 2,
            U_half_diff=(U1 - U2) / 2,
        )

    def _frame_angle(self, kin: Kinematics) -> float:
        return frame_angle(kin, self.bearing.clearance) if self.bearing.inlet == "max-gap" else 0.0

    def solve(self, kin: Kinematics, time_s: float | None = None) -> FilmResult:
        """Solve the film for the given kinematics (warm start from the last solution).

        With history, ``time_s`` [s] puts the rates of the history's states in the film (BDF2 through
        the two latest states committed before ``time_s``); without ``time_s`` (or before any commit)
        the film is quasi-static.
        """
        start = time.perf_counter()
        stats = self.stats
        stats.solves += 1
        self.solver.prepare(time_s, self.history)
        try:
            try:
                result = self._solve(kin, start)
            except FilmNotConverged as err:
                if not self.solver.fall_back():
                    raise
                stats.vi_iterations += err.iterations
                stats.transport_fallbacks += 1
                result = self._solve(kin, start)
        except FilmNotConverged as err:
            stats.failures += 1
            stats.vi_iterations += err.iterations
            raise
        finally:
            stats.solve_seconds += time.perf_counter() - start
        stats.vi_iterations += result.iterations
        return result

    def _solve(self, kin: Kinematics, start: float) -> FilmResult:
        space, s = self.space, self.scales
        beta = self._frame_angle(kin)
        if self._turn is not None and self._last is not None:
            # the warm start in the new frame: the last pressure turned with the frame
            delta = (beta - self._beta + math.pi) % (2 * math.pi) - math.pi
            if abs(delta) > self.TURN_THRESHOLD:
                n = self._turn.size
                space.P.x.array[:n] = self._turn(space.P.x.array[:n], delta)
                self.solver.turn(self._turn, delta)
        self.set_kinematics(in_frame(kin, beta))
        iterations = self.solver.solve()
        self.forms.set_film_fraction(self.solver.film_fraction())  # (weights the Couette shear: JFO)
        if space.piezo is not None:
            p = space.true_pressure(space.P.x.array)
            if not np.all(np.isfinite(p)):
                raise FilmNotConverged(
                    "piezoviscous film: unbounded pressure (the reduced pressure reached its "
                    "limit); at this load the film needs an elastic bushing",
                    0,
                    iterations,
                )
            space.pressure.x.array[:] = p
        self._last, self._beta = kin, beta
        self._in_contact = self.forms.contact_cells()  # for the functionals and the Jacobian of this state
        values = self.forms.values(self._in_contact)
        p_max, theta, z = self._pressure_peak()
        back = rotation(beta)
        self._force_solved = np.array([values["force_x"], values["force_y"]])
        hydro = back @ np.array([values["hydro_x"], values["hydro_y"]])
        asperity = back @ np.array([values.get("asperity_x", 0.0), values.get("asperity_y", 0.0)])
        h_min = self.solver.h_min(np.asarray(kin.ecc))
        peak = self.solver.deformation_peak()
        deformation = (0.0, 0.0) if peak is None else (peak[0], (peak[1] + beta) % (2 * math.pi))
        flows = self.solver.flows()
        contact_area = asperity_normal = asperity_p_max = 0.0
        contact = space.contact
        if contact is not None:
            asperity_normal = values["asperity_normal"] * s.force
            contact_area = values["contact_area"] / (2 * math.pi * self.mesh_spec.width)
            if h_min / self.sigma < contact.support:  # (p_c = 0 above it: no evaluation)
                asperity_p_max = float(contact.pressure(np.array([h_min / self.sigma]))[0])
        return FilmResult(
            force=(float(hydro[0] + asperity[0]), float(hydro[1] + asperity[1])),
            hydro_force=(float(hydro[0]), float(hydro[1])),
            asperity_force=(float(asperity[0]), float(asperity[1])),
            p_max=p_max * s.pressure,
            p_max_theta=(theta + beta) % (2 * math.pi),
            p_max_z=z * self.bearing.radius,
            h_min=h_min,
            torque_journal=values["torque_journal"],
            torque_bushing=values["torque_bushing"],
            asperity_torque_journal=values.get("asperity_torque_journal", 0.0),
            asperity_normal_force=asperity_normal,
            contact_area_ratio=contact_area,
            asperity_p_max=asperity_p_max,
            side_flow=flows[0],
            supply_flow=flows[1],
            cavitated_area_ratio=self._cavitated_area(),
            oil_volume=self.solver.oil_volume(),
            iterations=iterations,
            solve_time=time.perf_counter() - start,
            sigma=self.sigma,
            max_deformation=deformation[0],
            max_deformation_theta=deformation[1],
        )

    def _cavitated_area(self) -> float:
        """Ruptured film area / bearing area (nodal areas)."""
        areas = self.space.nodal_areas.getArray(readonly=True)
        ruptured = self.solver.ruptured()
        local = np.array([areas[ruptured].sum(), areas.sum()])
        total = local if self.comm.size == 1 else self.comm.allreduce(local, op=MPI.SUM)
        return float(total[0] / total[1])

    def _pressure_peak(self) -> tuple[float, float, float]:
        """(P_max, theta, Z) over the dofs, reduced over ranks."""
        coords = self.space.owned_coords
        n_owned = len(coords)
        values = self.space.pressure.x.array[:n_owned]
        if n_owned:
            i = int(np.argmax(values))
            local = (
                float(values[i]),
                math.atan2(coords[i, 1], coords[i, 0]) % (2 * math.pi),
                float(coords[i, 2]),
            )
        else:
            local = (-math.inf, 0.0, 0.0)
        return local if self.comm.size == 1 else max(self.comm.allgather(local))

    # -- Jacobian ---------------------------------------------------------------------------------
    def jacobian(self) -> FilmJacobian:
        """Exact derivatives of forces and torques w.r.t. (ecc_x, ecc_y, ecc_rate_x, ecc_rate_y,
        omega_rel), SI."""
        if self._last is None:
            raise RuntimeError("jacobian() needs a solve() first")
        start = time.perf_counter()
        try:
            return self._jacobian()
        finally:
            self.stats.jacobians += 1
            self.stats.jacobian_seconds += time.perf_counter() - start

    def _jacobian(self) -> FilmJacobian:
        space, s = self.space, self.scales
        dr, gradients, w_gradients, f_gradients = self.forms.residual_derivatives()
        dP, dW, dF = self.solver.sensitivities(dr)
        if space.piezo is not None:  # of the true pressure: dp = (mu(p) / mu0) dq node by node
            slope = space.piezo.ratio(space.pressure.x.array * s.pressure)
            for vec in dP:
                vec.getArray()[:] *= slope[: len(vec.getArray())]
        J = self.forms.jacobian(dP, dW, gradients, w_gradients, self._in_contact, dF, f_gradients)
        for vec in dP:
            vec.destroy()
        # Relative speed Omega = omega_j - omega_b: U_mean = Omega / (2 omega_ref), U_half_diff = -U_mean.
        J = np.column_stack([J[:, :4], (J[:, 4] - J[:, 5]) / (2 * s.omega_ref)])
        turning = (
            self.bearing.inlet == "max-gap" and math.hypot(*self._last.ecc) > 1e-9 * self.bearing.clearance
        )
        J = turn_jacobian(
            J,
            self._beta,
            self._last,
            self._force_solved,
            self.bearing.clearance,
            s.eccentricity_rate,
            turning,
        )
        in_scale = np.array([self.bearing.clearance] * 2 + [s.eccentricity_rate] * 2 + [1.0])[None, :]
        return FilmJacobian(J / in_scale)

    # -- fields ---------------------------------------------------------------------------------
    def fields_si(self) -> dict[str, fem.Function]:
        """Pressure [Pa], film thickness [m] (and asperity pressure [Pa], deformation [m], film
        fraction) as Functions on the film mesh, for output: the same Functions on every call, holding
        the current solution."""
        with quiet_jit():
            return self._fields_si()

    def _fields_si(self) -> dict[str, fem.Function]:
        space = self.space
        extra = self.solver.nodal_fields()
        if self._fields is None:  # Functions and compiled expressions, reused by every call
            points = space.V.element.interpolation_points()
            functions = {
                "pressure": fem.Function(space.V, name="pressure_Pa"),
                "film_thickness": fem.Function(space.V, name="film_thickness_m"),
            }
            for name, (function_name, _) in extra.items():
                functions[name] = fem.Function(space.V, name=function_name)
            expressions = {
                "film_thickness": fem.Expression(space.geometry.H * self.bearing.clearance, points)
            }
            if space.contact is not None:
                functions["asperity_pressure"] = fem.Function(space.V, name="asperity_pressure_Pa")
                Hs = space.geometry.H / space.params.S
                expressions["asperity_pressure"] = fem.Expression(space.contact.pressure(Hs, mod=ufl), points)
            self._fields = functions, expressions
        functions, expressions = self._fields
        functions["pressure"].x.array[:] = space.pressure.x.array * self.scales.pressure
        for name, (_, values) in extra.items():
            functions[name].x.array[: len(values)] = values
        for name, expression in expressions.items():
            functions[name].interpolate(expression)
        return functions

    def close(self) -> None:
        self.solver.close()
        self.space.close()
        self.forms.close()

    def __enter__(self) -> Film:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
