"""Static equilibrium of the journal under a load: Newton's method on the two eccentricity components
with the film's exact Jacobian (solver.film.model.Film.jacobian)."""

from __future__ import annotations

import math
import time

import numpy as np

from solver.errors import FilmNotConverged, InputError, out_of_range
from solver.film.types import MAX_ECCENTRICITY, STALL_TOLERANCE, Equilibrium, Kinematics

#: the bounds of the largest change of the eccentricity [c] of a Newton step with an elastic bushing
ELASTIC_STEP = (0.02, 0.5)
#: failed film solves in one step after which the film is taken as unsolvable a step further (each
#: costs 230 iterations, 20-35 s on the reference small end; on the way to an equilibrium up to 4 came
#: in a row)
FAILED_SOLVES = 6
#: a failed film solve within this distance [c] of an earlier failed one ends the search: the film
#: cannot be solved there (the reference small end, rough, under 33 kN: the search stepped to eps =
#: 4.70646 from eps = 4.7002, 4.7033, 4.7049, ... and every film solve there failed, 20-27 s each)
BARRIER_DISTANCE = 1e-2
#: wall time [s] of the failed film solves of one search after which it ends (the film is taken as
#: unsolvable a step further); on the way to an equilibrium 2 failed solves took up to 70 s
FAILED_SECONDS = 150.0


def equilibrium(
    model,
    load: tuple[float, float],
    *,
    omega_journal: float,
    omega_bushing: float = 0.0,
    load_frame: str = "bushing",
    tol: float = 1e-7,
    max_iterations: int = 60,
    guess: tuple[float, float] | None = None,
) -> Equilibrium:
    """Find the eccentricity at which the film (and asperity) force balances the load on the journal.

    Newton's method with the film's exact Jacobian, in the coordinates ``s = -ln(1 - eps/eps_lim)`` and
    the angle ``phi`` of the eccentricity: near eps = 1 the film force grows like (1 - eps)^-2 and the
    asperity force exponentially in h/sigma, both far more linear in s than in eps. Each step is
    halved until the force residual decreases. eps_lim is the model's reach under the load
    (solver.film.model.Film.reach): 1 when rigid; an elastic bushing lets the pin go further, into the
    deformed bushing, by what its compliance gives under the load.

    With an elastic bushing each film solve starts from the last iterate's solution moved along its
    sensitivities (Film.start_near), and the step is held in a trust region of the eccentricity (from
    h_min / c, within ELASTIC_STEP; doubled after a step it cut, shrunk to a step the halving left): a
    far step leaves the film's Newton a start it cannot finish (a failed solve costs 2-40 s, a
    followed one 0.1-1 s).

    Args:
        load: external load on the journal, bushing frame [N].
        load_frame: "bushing": the load and the journal centre are fixed in the bushing frame (they
            turn with the bushing; the wedge is driven by omega_journal - omega_bushing); "space": they
            are fixed in space and the bushing turns through them (in the bushing frame the eccentricity
            turns at -omega_bushing, Kinematics.from_global; the wedge is driven by omega_journal +
            omega_bushing). ``load`` and the result's eccentricity are then in the bushing frame at
            the instant its axes coincide with the fixed ones.
        tol: relative tolerance on the force residual, |F + W| <= tol |W|.
        guess: starting eccentricity [m]; default eps = 0.5, 50 deg ahead of the load line.

    A film that cannot be solved a step further ends the search (FilmNotConverged): FAILED_SOLVES
    failed solves in one step, a failed solve near an earlier failed one (BARRIER_DISTANCE: the
    search came back to where the film could not be solved), or FAILED_SECONDS of failed solves.

    Raises:
        InputError: the load cannot be carried below MAX_ECCENTRICITY, or Newton's method stalls.
        FilmNotConverged: the film cannot be solved at the first iterate, or a step further from one.
    """
    W = np.asarray(load, float)
    W_norm = float(np.linalg.norm(W))
    if not W_norm > 0:
        raise out_of_range("load", W_norm, "> 0 N")
    if load_frame not in ("bushing", "space"):
        raise out_of_range("load_frame", repr(load_frame), "'bushing' or 'space'")
    turning = omega_bushing if load_frame == "space" else 0.0  # the eccentricity turns at -turning
    wedge = omega_journal + omega_bushing if load_frame == "space" else omega_journal - omega_bushing
    c, limit = model.bearing.clearance, model.reach(W)
    elastic = limit > 1.0
    s_max = -math.log(1 - MAX_ECCENTRICITY)
    if guess is None:
        angle = math.atan2(W[1], W[0]) + math.copysign(math.radians(50), wedge or 1.0)
        guess = (0.5 * c * math.cos(angle), 0.5 * c * math.sin(angle))
    eps0 = min(max(math.hypot(*guess) / c, 1e-3), MAX_ECCENTRICITY * limit)
    x = np.array([-math.log(1 - eps0 / limit), math.atan2(guess[1], guess[0])])  # (s, phi)

    def ecc(x_vec):
        eps = limit * (1 - math.exp(-x_vec[0]))
        return eps, c * eps * np.array([math.cos(x_vec[1]), math.sin(x_vec[1])])

    def residual(x_vec):
        _, e_vec = ecc(x_vec)
        rate = (turning * float(e_vec[1]), -turning * float(e_vec[0]))  # -omega S e (from_global)
        kin = Kinematics((float(e_vec[0]), float(e_vec[1])), rate, omega_journal, omega_bushing)
        model.start_near(kin)
        res = model.solve(kin)
        return kin, res, np.asarray(res.force) + W

    kin, res, r = residual(x)
    radius = None
    failed_at: list[np.ndarray] = []  # the eccentricities [c] of the failed film solves
    failed_seconds = 0.0
    for iteration in range(max_iterations):
        if np.linalg.norm(r) <= tol * W_norm:
            return Equilibrium(kin, res, iteration, float(np.linalg.norm(r)))
        eps, _ = ecc(x)
        # d e / d(s, phi) = c [(eps_lim - eps) u, eps u_perp]
        u, u_perp = np.array([math.cos(x[1]), math.sin(x[1])]), np.array([-math.sin(x[1]), math.cos(x[1])])
        jac = model.jacobian()
        dF_de = jac.force_ecc + turning * jac.matrix[:2, 2:4] @ np.array([[0.0, 1.0], [-1.0, 0.0]])
        J = dF_de @ (c * np.column_stack([(limit - eps) * u, eps * u_perp]))
        step = -np.linalg.solve(J, r)
        lam = 1.0
        moved = math.hypot((limit - eps) * step[0], eps * step[1])  # |delta e| / c (linearised)
        if elastic:  # a trust region: the film's warm start stays near
            if radius is None:
                radius = min(max(res.h_min / c, ELASTIC_STEP[0]), ELASTIC_STEP[1])
            lam = min(1.0, radius / moved) if moved > 0 else 1.0
        first, failures = lam, 0
        while True:
            trial = x + lam * step
            trial[0] = min(max(trial[0], 1e-4), s_max)
            started = time.perf_counter()
            try:
                kin_t, res_t, r_t = residual(trial)
                failure, barrier = None, False
            except FilmNotConverged as err:  # too far a step for the film (an elastic one): shorter
                r_t, failure = np.full(2, np.inf), err
                failures += 1
                failed_seconds += time.perf_counter() - started
                here = ecc(trial)[1] / c
                barrier = any(np.linalg.norm(here - e) <= BARRIER_DISTANCE for e in failed_at)
                barrier = barrier or failed_seconds >= FAILED_SECONDS
                failed_at.append(here)
            if np.linalg.norm(r_t) < np.linalg.norm(r):
                break
            lam *= 0.5
            if lam < 1e-3 * first or failures == FAILED_SOLVES or barrier:
                if x[0] >= s_max * (1 - 1e-9) and np.dot(res.force, W) < 0 and res.load < W_norm:
                    raise InputError(
                        f"load = {W_norm:g} N cannot be carried (eccentricity ratio reaches "
                        f"{MAX_ECCENTRICITY * limit:g})"
                    )
                # The discrete VI force is only piecewise smooth (the active set moves node by node);
                # very near eps = 1 its kinks put a floor of ~1e-4 |W| under the residual.
                if np.linalg.norm(r) <= STALL_TOLERANCE * W_norm:
                    return Equilibrium(kin, res, iteration, float(np.linalg.norm(r)))
                if failure is not None:  # the film, not the search: it cannot be solved a step further
                    raise _unsolvable(W_norm, eps, res, failure)
                raise InputError(
                    f"load = {W_norm:g} N: the equilibrium search stalled at eccentricity ratio "
                    f"{eps:.6f} (residual {np.linalg.norm(r):.3g} N)"
                )
        if elastic:  # grown after a step the region cut, shrunk to the step a failure left
            radius = min(2 * radius, ELASTIC_STEP[1]) if lam == first < 1.0 else min(radius, lam * moved)
        x, kin, res, r = trial, kin_t, res_t, r_t
    raise InputError(f"load = {W_norm:g} N: no equilibrium found in {max_iterations} Newton iterations")


def _unsolvable(load: float, eps: float, res, failure: FilmNotConverged) -> FilmNotConverged:
    """The search's end where the film cannot be solved a step further than eccentricity ratio ``eps``
    (its last solution ``res``)."""
    return FilmNotConverged(
        f"load = {load:g} N: the film cannot be solved past eccentricity ratio {eps:.6f} "
        f"(h_min {res.h_min:.3g} m, it carries {res.load:.6g} N)",
        failure.reason,
        failure.iterations,
    )
