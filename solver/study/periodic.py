"""The cycle map of a coupled run: the state a cycle carries to the next, how much each part of it changed,
and the extrapolation of the cycle-end states to the periodic state (``solver.periodic_acceleration``).

A run is the fixed-point iteration ``x_(k+1) = P(x_k)`` of the cycle map P: one 720 deg cycle from the state
x_k at a cycle end (crank angle 0 mod 720 deg). That state (:class:`EndState`) is

- the mechanism's coordinates q and velocities qd (the crank's angle taken modulo the cycle, which the
  driver prescribes: only the pin's two degrees of freedom in its bushing are free);
- each film's committed history (solver.film.history; none for a rigid Reynolds film), the small end's
  and the big end's: the last solve's unknowns, with the JFO film's u (film fraction
  ``theta = 1 + min(u, 0)``, the oil held in the film) and an elastic bushing's modal deformation (the
  big end's alike: its FE eye's modes or its Winkler shell's nodes). The big end's film with the hole
  is solved in the crankpin's frame and keeps its state there, on its own mesh: its parts are combined
  as they are (nothing to rotate).

Each cycle logs the change of each part between its start and its end (:func:`state_changes`), the
numbers that show which part settles slowly.

**Extrapolation** (``periodic_acceleration = "mpe"``): a mode of P that contracts by lambda per cycle
takes ``log(tol) / log(lambda)`` plain cycles to settle. From cycles run one after the other, each giving a
pair (start x_j, end P(x_j)) with residual ``f_j = P(x_j) - x_j``, the next start is

    x = sum_j alpha_j P(x_j),   alpha = argmin || sum_j alpha_j f_j ||  with  sum_j alpha_j = 1,

over the last pairs: on a consecutive sequence ``x_(j+1) = P(x_j)`` this is the minimal polynomial
extrapolation (Cabay & Jackson 1976; Smith, Ford & Sidi 1987) that Skelboe (1980, "Computation of the
periodic steady-state response of nonlinear networks by extrapolation methods", IEEE Trans. Circuits
Syst. 27) uses for periodic steady states, and on any pairs the Anderson mixing (Walker & Ni 2011): the
affine combination that would make the linearised cycle's change smallest. It removes the modes that
the pairs span in one step. The norm weighs each part by its scale: the pin's eccentricity in its
bushing by the clearance and its rate by clearance x crank speed (the mechanism's free coordinates),
each film's film fraction and deformation (/ its clearance) by their root mean square over that film's
nodes, the effective temperature in K. The combination is taken of the coordinates and velocities, the
film states (each film's own) and the temperature, and made admissible: film fraction in [0, 1], the
positions and velocities projected on the constraints with the combined eccentricities and their rates
kept (:func:`onto_constraints`), the pin inside its clearance (else the step is halved toward the plain
start); a combination with any |alpha_j| above MAX_COEFFICIENT is refused (the plain start). Each
film's committed history is moved by the same correction as its last state, so that the first step's
rate (BDF2 through the committed states) stays the cycle's own.

The periodic test (solver.study.cycles) is the plain one, on consecutive cycles of the iteration:
with the extrapolation it starts from the third cycle, each cycle from the extrapolation of the last
three (the first cycle's pair, from the pin centred in a full film, takes a small coefficient).

Numpy only (the films with history are serial: solver.film.spec).
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np

from solver.dynamics.engine import CRANK, PIN
from solver.dynamics.multibody import MechanismError
from solver.study.energy import kept_motion

log = logging.getLogger(__name__)

#: the parts of the state whose change over each cycle is logged and kept (results.nc ``history.*``):
#: the small end's film parts unprefixed, the big end's after them (names are an interface: added to,
#: never renamed)
STATE_PARTS = (
    "position",
    "velocity",
    "film_fraction",
    "deformation",
    "temperature",
    "big_end_film_fraction",
    "big_end_deformation",
)
#: the prefix of each film's parts, by its joint
FILM_PREFIX = {"small_end": "", "big_end": "big_end_"}
#: K, the effective film temperature's scale in the extrapolation's norm: its closure tolerance, 1e-6,
#: is ~1e-5 K of the fixed point's change, and the pin's cycle-end position moves by ~3e-4 clearance a
#: cycle at the integration's tolerance; at 1 K the position's noise outweighed the temperature's last
#: changes (the closure stayed at 1.5e-5 where the plain secant reached 1e-7)
TEMPERATURE_SCALE = 0.01
#: the ``solver.periodic_acceleration`` values
ACCELERATIONS = ("none", "mpe", "film")
#: pairs (start, end) the extrapolation combines, the latest last
PAIRS = 3
#: the largest |alpha_j| accepted: a mode contracting by lambda a cycle takes 1 / (1 - lambda), 5 at
#: lambda = 0.8; a larger one extrapolates far along directions the pairs hardly resolve, e.g. near
#: the periodic state, where the residuals are the integration's noise (the pin's cycle-end position
#: moves by ~3e-4 clearance a cycle at the positions' atol of 1e-4 clearance); the step is then the
#: plain one
MAX_COEFFICIENT = 5.0


def mixing_coefficients(residuals: list[np.ndarray]) -> np.ndarray | None:
    """alpha minimising ``|| sum_j alpha_j f_j ||`` with ``sum_j alpha_j = 1`` (module docstring) for the
    residuals f_j, oldest first; None for a combination beyond MAX_COEFFICIENT (or not finite).

    With ``alpha = e_last - D gamma`` over the differences D of consecutive residuals, gamma is D's
    least-squares solution for the last residual (Walker & Ni 2011, eq. 2.2)."""
    F = np.array(residuals, dtype=float).T  # residuals as columns
    D = F[:, 1:] - F[:, :-1]
    gamma, *_ = np.linalg.lstsq(D, F[:, -1], rcond=1e-10)
    alpha = np.zeros(F.shape[1])
    alpha[-1] = 1.0
    alpha[1:] -= gamma
    alpha[:-1] += gamma
    if not np.all(np.isfinite(alpha)) or np.max(np.abs(alpha)) > MAX_COEFFICIENT:
        return None
    return alpha


def onto_constraints(em, q, qd, t: float, tolerance: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """(q, qd) on the constraints at t with the clearance joints' eccentricities and their rates (and a
    floating pin's angle and speed) kept: Newton on ``Phi(q) = 0`` and those coordinates held, then the
    velocities' correction that keeps the rates (the position counterpart of the outputs' consistent
    velocities, solver.study.outputs.StateOutputs.consistent; the rows: solver.study.energy.kept_motion).
    A minimum-norm projection of the whole q instead spreads the integrator's drift (max |Phi| ~1e-7 m)
    over the free coordinates too: it moved the JFO big end's pin by 0.001-0.002 of its clearance at
    every extrapolated start, more than a plain cycle's change near the periodic state.

    Raises:
        MechanismError: no convergence in 30 iterations.
    """
    mech, joints = em.mechanism, list(em.clearance_joints.values())
    q, qd = np.array(q, dtype=float), np.array(qd, dtype=float)
    rest = np.zeros_like(q)

    def held(x: np.ndarray) -> np.ndarray:  # the coordinates kept
        ecc = [np.asarray(joint.kinematics(x, rest).ecc, dtype=float) for joint in joints]
        return np.concatenate([*ecc, [x[3 * PIN + 2]] if em.floating_pin else []])

    target, rates = held(q), kept_motion(em, q, t)[mech.n_constraints :] @ qd
    for _ in range(30):
        residual = np.concatenate([mech.phi(q, t), held(q) - target])
        if np.max(np.abs(residual)) <= tolerance:
            break
        q -= np.linalg.lstsq(kept_motion(em, q, t), residual, rcond=None)[0]
    else:
        raise MechanismError("the extrapolated configuration does not assemble")
    rows = kept_motion(em, q, t)
    n = mech.n_constraints
    residual = np.concatenate([-mech.phi_t(q, t) - rows[:n] @ qd, rates - rows[n:] @ qd])
    return q, qd + rows.T @ np.linalg.lstsq(rows @ rows.T, residual, rcond=None)[0]


@dataclasses.dataclass(frozen=True)
class HistoryFilm:
    """A film with history as the cycle map sees its state x: the first ``nodes`` entries the film's
    unknown u (JFO: the film fraction ``theta = 1 + min(u, 0)``), the rest its deformation / clearance
    (an elastic bushing's modes, a Winkler shell's nodes); its parts are named with ``prefix``."""

    prefix: str
    nodes: int
    jfo: bool

    @classmethod
    def of(cls, name: str, model) -> HistoryFilm | None:
        """The film ``model`` (solver.film.model) of joint ``name``, or None: no film or no history."""
        if model is None or not model.has_history:
            return None
        return cls(FILM_PREFIX[name], model.space.n, model.spec.cavitation == "jfo")

    def parts(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """The film fraction (JFO) and the deformation of state x, each divided by sqrt(nodes): their
        norms the root mean square over the film's nodes."""
        n, parts = self.nodes, {}
        if self.jfo:
            parts[self.prefix + "film_fraction"] = (1.0 + np.minimum(x[:n], 0.0)) / math.sqrt(n)
        if x.size > n:
            parts[self.prefix + "deformation"] = x[n:] / math.sqrt(n)
        return parts

    def changes(self, a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> dict[str, float]:
        """The change from parts ``a`` to parts ``b`` (:meth:`parts`): the film fraction's largest at a
        node, the deformation's root mean square over the nodes."""
        change = {}
        fraction, deformation = self.prefix + "film_fraction", self.prefix + "deformation"
        if fraction in a and fraction in b:
            change[fraction] = float(np.max(np.abs(b[fraction] - a[fraction])) * math.sqrt(self.nodes))
        if deformation in a and deformation in b:
            change[deformation] = float(np.linalg.norm(b[deformation] - a[deformation]))
        return change

    def admissible(self, x: np.ndarray) -> np.ndarray:
        """State x with its film fraction in [0, 1] (JFO: u >= -1), a copy."""
        x = np.array(x, dtype=float)
        if self.jfo:
            x[: self.nodes] = np.maximum(x[: self.nodes], -1.0)
        return x


@dataclasses.dataclass
class EndState:
    """The state at a cycle end (module docstring): time [s], coordinates, velocities, the small end's
    film's committed history ((time [s], state), oldest first; [] without history), and with oil.thermal =
    "effective" the film temperature [C] of the next cycle (a cycle's start: the one it runs at; its
    end: the balance's fixed point with the cycle's means, solver.study.thermal.ThermalModel.fixed_point;
    NaN when isothermal); the big end's film's committed history as the small end's."""

    t: float
    q: np.ndarray
    qd: np.ndarray
    film: list[tuple[float, np.ndarray]]
    temperature: float = math.nan
    big_end_film: list[tuple[float, np.ndarray]] = dataclasses.field(default_factory=list)

    def history(self, name: str) -> list[tuple[float, np.ndarray]]:
        """The committed history of joint ``name``'s film (FILM_PREFIX)."""
        return self.film if name == "small_end" else self.big_end_film


class CycleMap:
    """The parts of a run's end states, their changes and (optionally) their extrapolation.

    Args:
        run: the run (solver.study.simulation.Run): its mechanism, films, clearances and crank speed.
        acceleration: ``"none"`` (plain cycles) or ``"mpe"`` (module docstring).
    """

    def __init__(self, run, acceleration: str = "none"):
        self.run, self.acceleration = run, acceleration
        models = {"small_end": run.model, "big_end": getattr(run, "big_model", None)}
        # the films with history (the small end first), whose states are parts of the map's
        films = {name: HistoryFilm.of(name, model) for name, model in models.items()}
        self.films = {name: film for name, film in films.items() if film is not None}
        # the last PAIRS cycles: (start vector, end vector, end state)
        self.pairs: list[tuple[np.ndarray, np.ndarray, EndState]] = []
        self.extrapolated = False  # the cycle being run started from an extrapolated state

    # -- the parts ------------------------------------------------------------------------------
    def _period_q(self, state: EndState) -> np.ndarray:
        """q with the crank angle taken modulo the cycle (4 pi)."""
        q = np.array(state.q, dtype=float)
        q[3 * CRANK + 2] = math.remainder(q[3 * CRANK + 2], 4 * math.pi)
        return q

    def parts(self, state: EndState) -> dict[str, np.ndarray]:
        """The state's parts, each divided by its scale (module docstring); the mechanism's by the pin's
        eccentricity in its bushing and its rate (the free coordinates: the others follow from the
        constraints, and weighed as coordinates the crank's and rod's angles would bring the
        integrator's angle tolerance, 1e-6 rad, in as 1e-2 clearance); each film's (small end, big end)
        from its last committed state."""
        joints = self.run.em.clearance_joints  # (the small end first, then the big end)
        pins = [(joints[name].kinematics(state.q, state.qd), c) for name, c in self.run.clearances.items()]
        velocity = [np.asarray(pin.ecc_rate, dtype=float) / (c * self.run.omega) for pin, c in pins]
        if self.run.em.floating_pin:  # its angular speed is free too (its angle is not: it may go on turning)
            velocity.append(np.array([state.qd[3 * PIN + 2] / self.run.omega]))
        parts = {
            "position": np.concatenate([np.asarray(pin.ecc, dtype=float) / c for pin, c in pins]),
            "velocity": np.concatenate(velocity),
        }
        for name, film in self.films.items():
            history = state.history(name)
            if history:
                parts.update(film.parts(history[-1][1]))
        if math.isfinite(state.temperature):
            parts["temperature"] = np.array([state.temperature / TEMPERATURE_SCALE])
        return parts

    def vector(self, state: EndState) -> np.ndarray:
        """The scaled state as one vector (the extrapolation's)."""
        return np.concatenate(list(self.parts(state).values()))

    def state_changes(self, start: EndState, end: EndState) -> dict[str, float]:
        """The change of each part over a cycle: ``position`` [clearance] and ``velocity`` [clearance x
        crank speed], of the pin's eccentricity in its bushing and of its rate (the free coordinates;
        the others follow from the constraints, and the crank's angle from its driver);
        ``film_fraction``, the largest change of theta at a film node; ``deformation``, the root mean
        square over the film's nodes of the change of the modal deformation / clearance (the small
        end's film; ``big_end_film_fraction``, ``big_end_deformation`` the big end's alike);
        ``temperature`` [K], the fixed point of the cycle's heat balance less the temperature it ran at
        (NaN for a part the state does not have)."""
        a, b = self.parts(start), self.parts(end)
        change = dict.fromkeys(STATE_PARTS, math.nan)
        for name in ("position", "velocity"):
            change[name] = float(np.linalg.norm(b[name] - a[name]))
        for film in self.films.values():
            change.update(film.changes(a, b))
        if "temperature" in a and "temperature" in b:
            change["temperature"] = float(b["temperature"][0] - a["temperature"][0]) * TEMPERATURE_SCALE
        return change

    # -- extrapolation --------------------------------------------------------------------------
    def record(self, start: EndState, end: EndState) -> None:
        """A finished cycle from ``start`` to ``end`` (plain and extrapolated starts alike: each is a
        pair of the map); the last PAIRS with states of one size are kept."""
        a, b = self.vector(start), self.vector(end)
        if a.size != b.size:  # (a start without the film's state)
            return
        self.pairs = [p for p in self.pairs if p[0].size == a.size]
        self.pairs = [*self.pairs, (a, b, end)][-PAIRS:]

    def coefficients(self) -> np.ndarray | None:
        """alpha of the kept pairs (:func:`mixing_coefficients`), or None: fewer than two pairs."""
        if len(self.pairs) < 2:
            return None
        return mixing_coefficients([end - start for start, end, _ in self.pairs])

    def next_start(self, end: EndState, extrapolate: bool = True) -> EndState:
        """The start of the next cycle after the cycle that ended at ``end`` (the last recorded):
        ``end`` itself (plain, not ``extrapolate``, or fewer than two pairs), or with acceleration the
        extrapolation of the kept pairs, made admissible."""
        self.extrapolated = False
        if self.acceleration != "mpe" or not extrapolate:
            return end
        alpha = self.coefficients()
        if alpha is None:
            return end
        start = self._combine(alpha, [e for _, _, e in self.pairs], end)
        if start is None:
            return end
        self.extrapolated = True
        moved = self.vector(start) - self.vector(end)
        last = np.linalg.norm(self.pairs[-1][1] - self.pairs[-1][0])
        log.info(
            "next cycle from the extrapolation of the last %d cycle ends (coefficients %s): %s",
            len(alpha),
            ", ".join(f"{a:.3g}" for a in alpha),
            ", ".join(
                f"{name.replace('_', ' ')} moved {value:.3g}"
                for name, value in self.state_changes(end, start).items()
                if math.isfinite(value)
            )
            + f" (|moved| / |last change| = {np.linalg.norm(moved) / max(last, 1e-300):.3g})",
        )
        return start

    def _combine(self, alpha: np.ndarray, ends: list[EndState], end: EndState) -> EndState | None:
        """sum alpha_j end_j at ``end``'s time, the correction applied alike to each film history's
        states; admissible (module docstring) or None."""
        q_period = sum(a * self._period_q(e) for a, e in zip(alpha, ends))
        qd = sum(a * np.asarray(e.qd, dtype=float) for a, e in zip(alpha, ends))
        temperature = sum(a * e.temperature for a, e in zip(alpha, ends))
        # each film's correction of its last state (the films whose history every end has)
        film_shift = {
            name: sum(a * e.history(name)[-1][1] for a, e in zip(alpha, ends)) - end.history(name)[-1][1]
            for name in self.films
            if end.history(name) and all(e.history(name) for e in ends)
        }
        plain_q = self._period_q(end)
        joints = self.run.em.clearance_joints
        # a finite-element film (small end, big end, bosses) has its own largest eccentricity ratio
        films = {
            "small_end": self.run.model,
            "big_end": getattr(self.run, "big_model", None),
            "pin_boss": getattr(self.run, "boss_model", None),
        }
        limits = {
            name: c * (films[name].max_eccentricity_ratio if films.get(name) is not None else 1.0)
            for name, c in self.run.clearances.items()
        }
        for _ in range(6):  # the step halved toward the plain start until the pin is inside
            q = np.array(end.q, dtype=float) + (q_period - plain_q)
            try:
                q, v = onto_constraints(self.run.em, q, qd, end.t)
            except Exception:  # noqa: BLE001 - a configuration that does not assemble: a shorter step
                q = None
            if q is not None:
                inside = all(
                    math.hypot(*joints[name].kinematics(q, v).ecc) < 0.98 * limit
                    for name, limit in limits.items()
                )
                if inside:
                    moved = {
                        name: [
                            (time_s, self.films[name].admissible(x + shift))
                            for time_s, x in end.history(name)
                        ]
                        for name, shift in film_shift.items()
                    }
                    return EndState(
                        end.t,
                        q,
                        v,
                        moved.get("small_end", end.film),
                        temperature,
                        moved.get("big_end", end.big_end_film),
                    )
            q_period = 0.5 * (q_period + plain_q)
            qd = 0.5 * (qd + np.asarray(end.qd, dtype=float))
            temperature = 0.5 * (temperature + end.temperature)
            film_shift = {name: 0.5 * shift for name, shift in film_shift.items()}
        return None
