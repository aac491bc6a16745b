"""Error-controlled time integration of a planar mechanism (numpy/scipy only).

The state is ``y = [q, qd]`` and the index-1 ODE is ``dy/dt = [qd, qdd(q, qd, t)]`` with ``qdd`` from the
augmented system with Baumgarte's terms (solver.dynamics.multibody eq. 1; DESIGN 3.6). Every method sets its
step size by a local error estimate (``rtol``, ``atol``), not by stability:

- explicit: scipy's ``RK45`` (Dormand-Prince 5(4)) or ``DOP853``, for non-stiff runs (ideal joints);
- implicit: ``ESDIRK32`` (default; L-stable ESDIRK3(2)4L[2]SA with full Newton, written here, see
  :class:`ESDIRK32`) for stiff force elements such as a clearance joint with a film (DESIGN 3.8);
  scipy's ``Radau`` and ``BDF`` are available too, but their simplified Newton (Jacobian frozen over a
  step) needs tiny steps when a stiff joint connects rotating bodies.

The implicit methods use the Jacobian of the ODE::

    d(dy/dt)/dy = [[0, I], [dqdd/dq, dqdd/dqd]],
    K [dqdd; dlambda] = [dQ/dq - d(Phi_q^T lambda)/dq ; dc/dq - d(Phi_q qdd)/dq]   (and likewise for qd)

with ``K`` the augmented matrix and ``c = gamma - 2 alpha dPhi/dt - beta^2 Phi``. ``dQ/dq`` and
``dQ/dqd`` come from the force elements, in the same call as Q (``Mechanism.forces(...,
jacobian=True)``), never from finite differences of forces; the constraint terms are differenced,
which costs constraint evaluations only (cheap closed forms) and no force evaluation.

Where force evaluations happen (each may be a film solve later): ``n_force_evaluations`` counts the
calls without Jacobian (scipy's right-hand sides; for ESDIRK32 only two at the start),
``n_jacobian_evaluations`` the calls with Jacobian (each Newton iteration of ESDIRK32; Jacobian
updates of Radau/BDF), ``n_output_evaluations`` the calls for qdd and lambda at output times that were
not the last evaluated state (dense output). Projection
costs one more call per step for RK45/DOP853/Radau/ESDIRK32 (they keep ``f = dy/dt`` of the current
state, which must be refreshed after the state is moved).

Drift control: Baumgarte (``alpha``, ``beta`` > 0) and/or projection of q and qd onto the constraint
manifold after every accepted step (``projection=True``; Eich 1993). With BDF the projected value
replaces the newest entry of the backward-difference history, the usual projected multistep scheme.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np
import scipy.linalg
from scipy.integrate import BDF, DOP853, RK45, Radau

from solver.dynamics.multibody import Mechanism, accelerations, project_positions, project_velocities

EXPLICIT_METHODS = {"RK45": RK45, "DOP853": DOP853}
IMPLICIT_METHODS = ("ESDIRK32", "Radau", "BDF")


class IntegrationError(RuntimeError):
    """The integrator stopped (step size too small, Newton failure)."""


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """Result of :func:`integrate`: histories at the output times and the work done.

    Attributes:
        t: s, output times, shape (N,).
        q: coordinates, shape (N, n_q).
        qd: velocities, shape (N, n_q).
        qdd: accelerations, shape (N, n_q).
        lam: multipliers, shape (N, n_lambda); joint reactions via solver.dynamics.multibody.joint_reactions.
        position_violation: max |Phi(q, t)| at each output (m or rad).
        velocity_violation: max |Phi_q qd + Phi_t| at each output (m/s or rad/s).
        method: integrator name.
        n_steps: accepted steps.
        n_force_evaluations: calls of ``Mechanism.forces`` without Jacobian by the integrator.
        n_jacobian_evaluations: calls with Jacobian (each also gives Q).
        n_output_evaluations: extra calls of ``Mechanism.forces`` for qdd and lambda at output times
            that were not the solver's last evaluated state (dense output).
        n_lu: LU decompositions of the Newton matrix (implicit methods).
        n_rejected: step attempts rejected by the error test or a Newton failure (ESDIRK32).
        wall_time: s.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray
    position_violation: np.ndarray
    velocity_violation: np.ndarray
    method: str
    n_steps: int
    n_force_evaluations: int
    n_jacobian_evaluations: int
    n_output_evaluations: int
    n_lu: int
    wall_time: float
    n_rejected: int = 0  # rejected step attempts (error test or Newton failure; ESDIRK32)
    next_step: float = float("nan")  # s, the step size ESDIRK32 proposes next
    jacobian: np.ndarray | None = None  # ESDIRK32 with jacobian_reuse: the latest ODE Jacobian
    #: ESDIRK32 with ``stage_values``: the sum over the accepted steps of ``h sum_j b_j v_j``, the
    #: method's own quadrature of the values v at the stages (e.g. powers: the work done over t_span)
    stage_integral: np.ndarray | None = None


class OdeSystem:
    """The ODE right-hand side and its Jacobian, with counters and a one-entry cache."""

    #: relative step of the forward differences of the constraint residual (sqrt of the machine epsilon)
    DIFFERENCE_STEP = 1.5e-8

    def __init__(self, mechanism: Mechanism, alpha: float, beta: float):
        self.mechanism = mechanism
        self.alpha, self.beta = alpha, beta
        self.n = mechanism.n_coordinates
        self.n_force_evaluations = 0
        self.n_jacobian_evaluations = 0
        self._cache_key: tuple | None = None
        self._cache_value: tuple[np.ndarray, np.ndarray] | None = None
        #: (t, y, qdd, lambda) of the latest force evaluation
        self.last_evaluation: tuple[float, np.ndarray, np.ndarray, np.ndarray] | None = None

    def forget(self) -> None:
        """Evaluate the forces anew at the next state asked, even the cached one (a force element
        with history may have committed a state meanwhile)."""
        self._cache_key = self._cache_value = None

    def solve(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(qdd, lambda)`` at (t, y); one force evaluation unless this state was the last one."""
        key = (float(t), y.tobytes())
        if key == self._cache_key:
            return self._cache_value
        q, qd = y[: self.n], y[self.n :]
        self.n_force_evaluations += 1
        Q = self.mechanism.forces(q, qd, t).Q
        value = accelerations(self.mechanism, q, qd, t, Q, alpha=self.alpha, beta=self.beta)
        self._cache_key, self._cache_value = key, value
        self.last_evaluation = (float(t), y.copy(), *value)
        return value

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """``dy/dt = [qd, qdd]``."""
        qdd, _ = self.solve(t, y)
        return np.concatenate([y[self.n :], qdd])

    def constraint_residual(self, q, qd, t, qdd, lam) -> np.ndarray:
        """[-Phi_q^T lambda ; c - Phi_q qdd] at fixed (qdd, lambda): the non-force part of the residual."""
        mech = self.mechanism
        jac = mech.jacobian(q, t)
        c = mech.gamma(q, qd, t)
        if self.alpha:
            c = c - 2.0 * self.alpha * (jac @ qd + mech.phi_t(q, t))
        if self.beta:
            c = c - self.beta**2 * mech.phi(q, t)
        return np.concatenate([-jac.T @ lam, c - jac @ qdd])

    def constraint_derivative(self, t: float, y: np.ndarray, qdd: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """d/dy of the constraint residual at fixed (qdd, lambda), shape (n+m, 2n); no force evaluation.

        The q columns are forward differences of the residual (n + 1 constraint evaluations; relative
        error ~1e-8, far below what a Newton matrix needs: central differences cost twice as much for
        nothing the iteration sees). The qd columns are exact: ``dc/dqd = dgamma/dqd - 2 alpha Phi_q``,
        and gamma is quadratic in qd, so its central difference is exact (2 n evaluations of gamma only).
        """
        n, mech = self.n, self.mechanism
        q, qd = y[:n], y[n:]
        part = np.zeros((n + lam.size, 2 * n))
        if lam.size == 0:
            return part
        base = self.constraint_residual(q, qd, t, qdd, lam)
        for k in range(n):
            step = self.DIFFERENCE_STEP * max(1.0, abs(q[k]))
            plus = q.copy()
            plus[k] += step
            part[:, k] = (self.constraint_residual(plus, qd, t, qdd, lam) - base) / step
        for k in range(n):
            plus, minus = qd.copy(), qd.copy()
            plus[k] += 1.0
            minus[k] -= 1.0
            part[n:, n + k] = 0.5 * (mech.gamma(q, plus, t) - mech.gamma(q, minus, t))
        if self.alpha:
            part[n:, n:] -= 2.0 * self.alpha * mech.jacobian(q, t)
        return part

    def rhs_and_jacobian(
        self, t: float, y: np.ndarray, constraint_part: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``dy/dt`` and ``d(dy/dt)/dy`` from ONE force evaluation with Jacobian (module docstring).

        Args:
            t: s.
            y: state [q, qd].
            constraint_part: a (possibly lagged) :meth:`constraint_derivative`; computed here if None.

        Returns:
            ``(dy/dt, Jacobian, constraint_part used)``.
        """
        n, mech = self.n, self.mechanism
        q, qd = y[:n], y[n:]
        self.n_jacobian_evaluations += 1
        forces = mech.forces(q, qd, t, jacobian=True)
        qdd, lam = accelerations(mech, q, qd, t, forces.Q, alpha=self.alpha, beta=self.beta)
        self._cache_key, self._cache_value = (float(t), y.tobytes()), (qdd, lam)
        self.last_evaluation = (float(t), y.copy(), qdd, lam)
        if constraint_part is None:
            constraint_part = self.constraint_derivative(t, y, qdd, lam)
        rhs = constraint_part.copy()
        rhs[:n, :n] += forces.dQ_dq
        rhs[:n, n:] += forces.dQ_dqd
        dqdd_dy = np.linalg.solve(mech.augmented_matrix(q, t), rhs)[:n]
        jac = np.zeros((2 * n, 2 * n))
        jac[:n, n:] = np.eye(n)
        jac[n:, :] = dqdd_dy
        return np.concatenate([qd, qdd]), jac, constraint_part

    def jacobian(self, t: float, y: np.ndarray) -> np.ndarray:
        """``d(dy/dt)/dy`` for scipy's Radau and BDF (one force evaluation with Jacobian)."""
        return self.rhs_and_jacobian(t, y)[1]


class _HermiteOutput:
    """Cubic Hermite interpolant of one step from the end values and derivatives (third order)."""

    def __init__(self, t0, y0, f0, t1, y1, f1):
        self.t0, self.h = t0, t1 - t0
        self.y0, self.y1, self.f0, self.f1 = y0, y1, f0, f1

    def __call__(self, t: float) -> np.ndarray:
        s = (t - self.t0) / self.h
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        return h00 * self.y0 + h10 * self.h * self.f0 + h01 * self.y1 + h11 * self.h * self.f1


class ESDIRK32:
    """L-stable ESDIRK3(2)4L[2]SA (Kennedy & Carpenter 2003) with full Newton iterations.

    Four stages, the first explicit (first same as last), three implicit with the same diagonal
    ``gamma``; third order, stiffly accurate and L-stable, with an embedded second-order solution for
    the error estimate. Each implicit stage ``Y = base + h gamma f(Y)`` is solved by Newton's method
    with a FRESH Jacobian at every iteration (``(I - h gamma J(Y_k)) dY = -R(Y_k)``): one force
    evaluation with Jacobian per iteration, no finite differences of forces. Full Newton matters when a
    stiff joint connects rotating bodies: the stiff direction turns within a step, and a Jacobian
    frozen at the start of the step (scipy's Radau and BDF) then makes Newton diverge unless the
    step is tiny. Newton starts the first implicit stage from the previous step's interpolant
    extrapolated to the stage time, and the other two from the cubic Hermite interpolant between the
    step start and the converged first stage (an interpolation for stage 2 at c = 0.6, a slight
    extrapolation for stage 3 at c = 1), which keeps it inside its (with stiffness shrinking) region
    of convergence; with these measures the step count is nearly independent of the joint stiffness.
    Far from the solution a full Newton step of a thin film may overshoot once before it contracts, so
    divergence is declared when the increment grows twice or by ``DIVERGENCE_RATE`` at once. The cheap
    constraint part of the Jacobian is computed once per step.

    ``jacobian_reuse=True`` switches to simplified Newton with an adaptive Jacobian: the latest
    Jacobian is kept (across iterations, stages, steps and the output times of a :class:`Stepper`) and
    refreshed as soon as an iteration contracts slower than
    ``REFRESH_RATE``; a step whose simplified Newton fails is retried with full Newton before it is
    shortened. Its Newton tolerance is ``REUSE_TOLERANCE_FACTOR`` times tighter, because
    simplified Newton stops just inside the tolerance where full Newton lands far inside it (the
    energy balance of the coupled engine needs the stage equations solved that well; 10 x is enough
    for it and for the accuracy test below, 100 x costs 15 % more film solves). On the coupled
    engine this cuts the film Jacobians from ~10 to ~3 per step for ~1.5 x the film solves; with
    1e10 N/m joints between fast-turning links it costs steps (tests/dynamics/test_double_pendulum.py).

    The error estimate ``h sum (b_j - b^_j) F_j`` is filtered by ``(I - h gamma J)^-1`` (Shampine's
    filter, as in Hairer & Wanner's RADAU5) so that stiff components do not inflate it; the stage
    derivatives are recovered from the stage equations (``F = (Y - base)/(h gamma)``), not by another
    force evaluation. Step size: ``h_new = h min(5, max(0.2, 0.9 err^(-1/3)))``. Dense output: cubic
    Hermite between the step ends.

    The interface follows scipy's OdeSolver where :class:`Stepper` uses it (``t``, ``y``, ``f``,
    ``t_bound``, ``status``, ``step()``, ``dense_output()``, ``fun``, ``nlu``); ``t_bound`` may be None at
    construction (the first step is then estimated when a :class:`Stepper` sets it).

    References: C. A. Kennedy, M. H. Carpenter, Appl. Numer. Math. 44 (2003) 139-181 (ARK3(2)4L[2]SA,
    implicit table); E. Hairer, G. Wanner, Solving ODEs II, Springer 1996, sec. IV.8.
    """

    GAMMA = 1767732205903.0 / 4055673282236.0
    A = np.array(
        [
            [0.0, 0.0, 0.0, 0.0],
            [GAMMA, GAMMA, 0.0, 0.0],
            [2746238789719.0 / 10658868560708.0, -640167445237.0 / 6845629431997.0, GAMMA, 0.0],
            [
                1471266399579.0 / 7840856788654.0,
                -4482444167858.0 / 7529755066697.0,
                11266239266428.0 / 11593286722821.0,
                GAMMA,
            ],
        ]
    )
    B = A[3].copy()
    B_EMBEDDED = np.array(
        [
            2756255671327.0 / 12835298489170.0,
            -10771552573575.0 / 22201958757719.0,
            9247589265047.0 / 10645013368117.0,
            2193209047091.0 / 5459859503100.0,
        ]
    )
    C = A.sum(axis=1)
    MAX_NEWTON_ITERATIONS = 12
    #: a full Newton iteration whose increment grows by this factor (or grows twice) diverges
    DIVERGENCE_RATE = 4.0
    NEWTON_FAILURE_FACTOR = 0.5  # step reduction after a Newton failure

    #: simplified Newton: a kept Jacobian is refreshed when an iteration contracts slower than this
    REFRESH_RATE = 0.25
    REUSE_TOLERANCE_FACTOR = 0.1

    def __init__(
        self,
        system: OdeSystem,
        t0: float,
        y0: np.ndarray,
        t_bound: float | None,
        *,
        rtol: float,
        atol,
        max_step: float = np.inf,
        first_step: float | None = None,
        jacobian_reuse: bool = False,
        stage_values: Callable[[float, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
    ):
        self.system = system
        #: values at a force evaluation (t, y, qdd, lambda), integrated by the stage quadrature
        self.stage_values = stage_values
        self.stage_integral: np.ndarray | None = None  # sum over the accepted steps of h sum_j b_j v_j
        self.jacobian_reuse = jacobian_reuse
        #: the latest ODE Jacobian (kept across iterations, stages and steps when reusing)
        self.jacobian: np.ndarray | None = None
        self.n_rejected = 0  # step attempts rejected (error test or Newton failure)
        self.t, self.y, self.t_bound = t0, np.array(y0, dtype=float), t_bound
        self.rtol, self.atol, self.max_step = rtol, np.asarray(atol, dtype=float), max_step
        self.newton_tolerance = max(10.0 * np.finfo(float).eps / rtol, min(0.03, rtol**0.5))
        self.f = system.rhs(t0, self.y)
        self._anchor = system.last_evaluation
        self._anchor_value = self._values()
        self.status = "running" if t_bound is None or t_bound > t0 else "finished"
        self.nlu = 0
        # the first step: given, or estimated once the bound is known (it limits the estimate)
        self.h = first_step
        if first_step is None and t_bound is not None:
            self.h = self._initial_step()
        self._dense: _HermiteOutput | None = None  # the last step's interpolant
        self._constraint_part: np.ndarray | None = None
        self._full_newton = False  # set for the retry of a step whose simplified Newton failed

    def fun(self, t: float, y: np.ndarray) -> np.ndarray:
        """dy/dt at a new current state (one force evaluation unless the system's cache holds it; used
        after a projection)."""
        result = self.system.rhs(t, y)
        self._anchor = self.system.last_evaluation
        self._anchor_value = self._values()
        return result

    def _values(self) -> np.ndarray | None:
        """``stage_values`` at the latest force evaluation (None without them)."""
        return (
            None if self.stage_values is None else np.asarray(self.stage_values(*self.system.last_evaluation))
        )

    def _norm(self, x: np.ndarray, reference: np.ndarray) -> float:
        return float(np.sqrt(np.mean((x / (self.atol + self.rtol * np.abs(reference))) ** 2)))

    def _initial_step(self) -> float:
        """Hairer, Norsett & Wanner (1993, sec. II.4) starting step, for order 3 (one force evaluation)."""
        d0, d1 = self._norm(self.y, self.y), self._norm(self.f, self.y)
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = min(h0, self.max_step, self.t_bound - self.t)
        f1 = self.system.rhs(self.t + h0, self.y + h0 * self.f)
        d2 = self._norm(f1 - self.f, self.y) / h0
        h1 = max(1e-6, h0 * 1e-3) if max(d1, d2) <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / 4.0)
        if not np.isfinite(h1):  # the trial evaluation failed (e.g. a film solve): start small
            h1 = h0
        return min(100.0 * h0, h1, self.max_step)

    def _stage(self, t: float, base: np.ndarray, guess: np.ndarray, h: float):
        """Newton's method for Y = base + h gamma f(t, Y); returns (Y, LU of the last matrix) or None.

        Converged when the scaled increment is below the Newton tolerance, or when the observed rate
        ``theta`` predicts the remaining error ``theta / (1 - theta) |dY|`` below it; diverging
        (``theta >= 1``) or too many iterations return None (the step is then retried shorter).

        With ``jacobian_reuse`` (simplified Newton) the latest Jacobian is kept, from iteration to
        iteration, stage to stage and step to step, and refreshed only when an iteration contracts
        slower than ``REFRESH_RATE`` (or diverges): iterations then cost a force evaluation without
        Jacobian. Otherwise every iteration takes a fresh Jacobian (full Newton).
        """
        Y = guess.copy()
        previous = None
        size = Y.size
        reuse = self.jacobian_reuse and not self._full_newton
        refresh = not reuse or self.jacobian is None
        lu = None
        # full Newton lands far inside its tolerance (quadratic convergence), simplified Newton just
        # inside it: with a kept Jacobian it aims at a tighter target, so that the stage errors are as
        # small (energy balance), but accepts the usual tolerance when the iteration stalls at the
        # noise level of the force evaluations (film solves)
        tolerance = self.newton_tolerance
        target = tolerance * (self.REUSE_TOLERANCE_FACTOR if reuse else 1.0)
        increment = np.inf
        grew = False
        # MAX_NEWTON_ITERATIONS in all, plus as many again for refreshes of a kept Jacobian
        for _ in range(self.MAX_NEWTON_ITERATIONS * (2 if reuse else 1)):
            if refresh:
                if self._constraint_part is None:  # once per step, at the first refresh it needs
                    self._constraint_part = self.system.constraint_derivative(*self._step_anchor)
                f, self.jacobian, _ = self.system.rhs_and_jacobian(t, Y, self._constraint_part)
                lu = None
            else:
                f = self.system.rhs(t, Y)
            fresh = refresh
            if lu is None:
                lu = scipy.linalg.lu_factor(np.eye(size) - h * self.GAMMA * self.jacobian, check_finite=False)
                self.nlu += 1
            delta = scipy.linalg.lu_solve(lu, -(Y - base - h * self.GAMMA * f), check_finite=False)
            Y = Y + delta
            increment = self._norm(delta, Y)
            if not np.isfinite(increment):
                return None
            if increment <= target:
                return Y, lu
            refresh = not reuse
            if previous is not None:
                rate = increment / previous
                if rate < 1.0 and rate / (1.0 - rate) * increment <= target:
                    return Y, lu
                if rate >= 0.9 and fresh and increment <= tolerance:
                    return Y, lu  # stalled at the noise level, inside the usual tolerance
                if rate >= 1.0 and fresh:
                    # far from the solution a full Newton step may overshoot once before it contracts
                    # (the film force is very nonlinear in a thin film); a second growth is divergence
                    if grew or rate >= self.DIVERGENCE_RATE:
                        return None
                    grew = True
                if rate > self.REFRESH_RATE and not fresh:
                    # the kept Jacobian is too old: a new one next iteration (from the last good iterate)
                    refresh = True
                    if rate >= 1.0:
                        Y = Y - delta
            previous = None if refresh and reuse else increment
        if increment <= tolerance:
            return Y, lu  # out of iterations inside the usual tolerance
        return None

    def step(self) -> str | None:
        """Advance one accepted step; returns an error message on failure (status "failed")."""
        t, y, f0 = self.t, self.y, self.f
        if self.h is None:
            self.h = self._initial_step()
        h = min(self.h, self.max_step, self.t_bound - t)
        # the constraint part of the Jacobian, differenced once per step at the latest consistent force
        # evaluation (the last Newton iterate of the previous step, within the Newton tolerance of y)
        # (differenced only when this step refreshes its Jacobian: a step that keeps the last one does not
        # need it, and it costs 4 n constraint evaluations)
        self._constraint_part, self._step_anchor = None, self._anchor
        rejected = False
        while True:
            if not h >= 10.0 * np.abs(np.nextafter(t, np.inf) - t):  # also catches NaN
                self.status = "failed"
                return f"step size {h:.3g} s below the minimum (Newton failures or error test)"
            stages = [f0]
            values = [self._anchor_value]  # stage_values at the stages (at their last Newton iterates)
            first_stage = None  # the converged first stage, for the guesses of stages 2 and 3
            result = None
            for i in range(1, 4):
                base = y + h * sum(self.A[i, j] * stages[j] for j in range(i))
                if i > 1:
                    # interpolate (stage 2, c = 0.6) or barely extrapolate (stage 3, c = 1) between the
                    # step start and the converged first stage (c = 0.87): closer than the last step's
                    # interpolant, extrapolated a whole step, which can even leave the clearance
                    guess = _HermiteOutput(t, y, f0, t + self.C[1] * h, first_stage, stages[1])(
                        t + self.C[i] * h
                    )
                elif self._dense is not None:  # extrapolate the last step's interpolant: Newton starts close
                    guess = self._dense(t + self.C[i] * h)
                else:
                    guess = base + h * self.GAMMA * stages[-1]
                result = self._stage(t + self.C[i] * h, base, guess, h)
                if result is None:
                    break
                stages.append((result[0] - base) / (h * self.GAMMA))
                values.append(self._values())
                if i == 1:
                    first_stage = result[0]
            if result is None:
                if self.jacobian_reuse and not self._full_newton:
                    self._full_newton = True  # retry the same step with full Newton first
                    continue
                h *= self.NEWTON_FAILURE_FACTOR
                rejected = True
                self.n_rejected += 1
                continue
            y_new, lu = result
            error = h * sum((self.B[j] - self.B_EMBEDDED[j]) * stages[j] for j in range(4))
            error = scipy.linalg.lu_solve(lu, error, check_finite=False)
            scale = self.atol + self.rtol * np.maximum(np.abs(y), np.abs(y_new))
            error_norm = float(np.sqrt(np.mean((error / scale) ** 2)))
            factor = 0.9 * error_norm ** (-1.0 / 3.0) if error_norm > 0.0 else 5.0
            if error_norm <= 1.0:
                break
            h *= max(0.2, factor)
            rejected = True
            self.n_rejected += 1
        self._full_newton = False
        self._dense = _HermiteOutput(t, y, f0, t + h, y_new, stages[3])
        self.h = h * min(1.0 if rejected else 5.0, max(0.2, factor))
        self.t = t + h if self.t_bound - (t + h) > 1e-14 * abs(self.t_bound) else self.t_bound
        self.y, self.f = y_new, stages[3]
        self._anchor = self.system.last_evaluation
        if self.stage_values is not None:
            quadrature = h * sum(self.B[j] * values[j] for j in range(4))
            self.stage_integral = (
                quadrature if self.stage_integral is None else self.stage_integral + quadrature
            )
        self._anchor_value = values[3]
        if self.t >= self.t_bound:
            self.status = "finished"
        return None

    def dense_output(self) -> _HermiteOutput:
        """Interpolant of the last step."""
        return self._dense


def _check_method(method: str, stage_values) -> None:
    if method not in EXPLICIT_METHODS and method not in IMPLICIT_METHODS:
        allowed = ", ".join([*EXPLICIT_METHODS, *IMPLICIT_METHODS])
        raise ValueError(f"method = {method!r} (allowed: {allowed})")
    if stage_values is not None and method != "ESDIRK32":
        raise ValueError(f"stage_values needs method = 'ESDIRK32' (got {method!r})")


class Stepper:
    """Integrates a mechanism forward from a state and keeps what the method carries from step to step.

    The method's state (for ESDIRK32: the proposed step size, the kept Jacobian, the last step's
    interpolant that starts Newton) stays in this object, so a caller that stops at output times only
    says where to go (:meth:`advance_to`) and, if it moves the state there (a projection of the
    velocities), from where to go on (:meth:`restart`). Every method sets its step by the local error
    estimate (module docstring); ``on_step`` and ``stage_values`` as in :func:`integrate`.

    Counters (since construction): ``steps`` (accepted), ``rejected`` (ESDIRK32's rejected attempts),
    ``force_evaluations`` (without Jacobian), ``jacobian_evaluations`` (with Jacobian), ``lu``
    (factorisations of the Newton matrix).

    Args:
        mechanism: the mechanism.
        t0: s, the start time.
        q0: coordinates at t0 (used as given: project them first if needed).
        qd0: velocities at t0.
        method: ``"ESDIRK32"`` (default), ``"RK45"``, ``"DOP853"``, ``"Radau"`` or ``"BDF"``.
        rtol: relative tolerance of the local error estimate.
        atol: absolute tolerance (scalar or per state component).
        alpha: 1/s, Baumgarte velocity feedback.
        beta: 1/s, Baumgarte position feedback.
        t_bound: s, the end of the integration (scipy's methods need it here; ESDIRK32 may take it
            from the first :meth:`advance_to`, which also bounds its first step's estimate).
        max_step: s, largest step.
        first_step: s, the first step (default: the method's own estimate).
        jacobian_reuse: ESDIRK32: simplified Newton with a kept Jacobian (:class:`ESDIRK32`).
        on_step: called with the time after every accepted step (:func:`integrate`).
        stage_values: ESDIRK32: values at its force evaluations integrated by its stage quadrature
            (:func:`integrate`); ``stage_integral`` holds their integral since the last advance.
    """

    def __init__(
        self,
        mechanism: Mechanism,
        t0: float,
        q0: np.ndarray,
        qd0: np.ndarray,
        *,
        method: str = "ESDIRK32",
        rtol: float = 1e-6,
        atol: float | np.ndarray = 1e-9,
        alpha: float = 0.0,
        beta: float = 0.0,
        t_bound: float | None = None,
        max_step: float = np.inf,
        first_step: float | None = None,
        jacobian_reuse: bool = False,
        on_step: Callable[[float], None] | None = None,
        stage_values: Callable[[float, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
    ):
        _check_method(method, stage_values)
        if t_bound is None and method != "ESDIRK32":
            raise ValueError(f"method = {method!r} needs t_bound")
        self.mechanism, self.method, self.on_step = mechanism, method, on_step
        self.system = OdeSystem(mechanism, alpha, beta)
        self.steps = 0
        self._moved: np.ndarray | None = None  # a state given by restart, evaluated at the next step
        y0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float)])
        if method == "ESDIRK32":
            self._solver = ESDIRK32(
                self.system,
                float(t0),
                y0,
                t_bound,
                rtol=rtol,
                atol=atol,
                max_step=max_step,
                first_step=first_step,
                jacobian_reuse=jacobian_reuse,
                stage_values=stage_values,
            )
        else:
            options = {"rtol": rtol, "atol": atol, "max_step": max_step}
            if first_step is not None:
                options["first_step"] = first_step
            if method in IMPLICIT_METHODS:
                options["jac"] = self.system.jacobian
            scipy_class = EXPLICIT_METHODS.get(method) or {"Radau": Radau, "BDF": BDF}[method]
            self._solver = scipy_class(self.system.rhs, float(t0), y0, t_bound, **options)

    @property
    def t(self) -> float:
        """s, the time reached."""
        return self._solver.t

    @property
    def y(self) -> np.ndarray:
        """The state ``[q, qd]`` reached (the solver's own array: copy it to keep it)."""
        return self._solver.y if self._moved is None else self._moved

    @property
    def running(self) -> bool:
        """False once the bound is reached."""
        return self._solver.status == "running"

    @property
    def rejected(self) -> int:
        return int(getattr(self._solver, "n_rejected", 0))

    @property
    def force_evaluations(self) -> int:
        return self.system.n_force_evaluations

    @property
    def jacobian_evaluations(self) -> int:
        return self.system.n_jacobian_evaluations

    @property
    def lu(self) -> int:
        return int(getattr(self._solver, "nlu", 0))

    @property
    def next_step(self) -> float:
        """s, the step ESDIRK32 proposes next (NaN for scipy's methods)."""
        h = getattr(self._solver, "h", None) if self.method == "ESDIRK32" else None
        return float("nan") if h is None else float(h)

    @property
    def jacobian(self) -> np.ndarray | None:
        """ESDIRK32: the latest ODE Jacobian (None for the other methods)."""
        return self._solver.jacobian if self.method == "ESDIRK32" else None

    @property
    def stage_integral(self) -> np.ndarray | None:
        """ESDIRK32 with ``stage_values``: their stage quadrature since the last :meth:`advance_to`
        began (since construction without one); None before the first accepted step."""
        return getattr(self._solver, "stage_integral", None)

    def interpolant(self):
        """The dense output of the last step (a callable of t)."""
        return self._solver.dense_output()

    def step(self) -> None:
        """One accepted step towards the bound, then ``on_step``.

        Raises:
            IntegrationError: the method failed (e.g. the step size collapsed).
        """
        solver = self._solver
        if self._moved is not None:
            solver.y, self._moved = self._moved, None
            self.system.forget()
            solver.f = solver.fun(solver.t, solver.y)
        message = solver.step()
        if solver.status == "failed":
            raise IntegrationError(f"{self.method} failed at t = {solver.t:.6g} s: {message}")
        self.steps += 1
        if self.on_step is not None:
            self.on_step(solver.t)

    def advance_to(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Step until exactly t (the last step ends there); returns copies of (q, qd) at t.

        Raises:
            IntegrationError: the method failed.
        """
        solver = self._solver
        solver.t_bound = float(t)
        if solver.t < solver.t_bound:
            solver.status = "running"
        if self.method == "ESDIRK32":
            solver.stage_integral = None
        while solver.status == "running":
            self.step()
        n = self.system.n
        return solver.y[:n].copy(), solver.y[n:].copy()

    def restart(self, q: np.ndarray, qd: np.ndarray) -> None:
        """The state at the current time is (q, qd) from now on (e.g. the caller projected its
        velocities): the next step starts from it, with its derivative from a new force evaluation made
        then, and keeps the method's step size, Jacobian and interpolant."""
        self._moved = np.concatenate([np.asarray(q, dtype=float), np.asarray(qd, dtype=float)])

    def project(self, refresh: bool = True) -> None:
        """Move the current state onto the constraint manifold (after an accepted step; Eich 1993).

        ``refresh``: also update the method's stored derivative / history for the next step (one force
        evaluation for the one-step methods); not needed after the last step.
        """
        solver, system, mechanism = self._solver, self.system, self.mechanism
        n, t, y = system.n, solver.t, solver.y
        q = project_positions(mechanism, y[:n], t)
        qd = project_velocities(mechanism, q, y[n:], t)
        y_new = np.concatenate([q, qd])
        if self.method == "BDF":
            # replace y_n in the backward-difference history: every difference nabla^k y_n shifts by delta
            solver.D[: solver.order + 1] += y_new - y
        solver.y = y_new
        if refresh and self.method != "BDF":
            solver.f = solver.fun(t, y_new)


def integrate(
    mechanism: Mechanism,
    q0: np.ndarray,
    qd0: np.ndarray,
    t_span: tuple[float, float],
    *,
    method: str = "RK45",
    rtol: float = 1e-6,
    atol: float | np.ndarray = 1e-9,
    alpha: float = 0.0,
    beta: float = 0.0,
    projection: bool = False,
    t_eval: np.ndarray | None = None,
    max_step: float = np.inf,
    first_step: float | None = None,
    assemble_initial_state: bool = True,
    jacobian_reuse: bool = False,
    accelerations: bool = True,
    on_step: Callable[[float], None] | None = None,
    stage_values: Callable[[float, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> Trajectory:
    """Integrate the mechanism from (q0, qd0) over t_span with error control (a :class:`Stepper`).

    Args:
        mechanism: the mechanism.
        q0: initial coordinates.
        qd0: initial velocities.
        t_span: s, (t0, t_end).
        method: ``"RK45"`` or ``"DOP853"`` (explicit); ``"ESDIRK32"``, ``"Radau"`` or ``"BDF"``
            (implicit, with the force elements' Jacobians; ESDIRK32 for stiff clearance joints).
        rtol: relative tolerance of the local error estimate.
        atol: absolute tolerance (scalar or per state component, in the units of q and qd).
        alpha: 1/s, Baumgarte velocity feedback in (1) of solver.dynamics.multibody.
        beta: 1/s, Baumgarte position feedback. Choose alpha, beta of the order of the inverse of the
            mechanism's fastest time scale of interest (e.g. the crank speed); 0 disables.
        projection: project q and qd onto the constraint manifold after every accepted step.
        t_eval: output times (dense output); default: every accepted step.
        max_step: s, largest step.
        first_step: s, initial step (default: the solver's own estimate).
        assemble_initial_state: project (q0, qd0) onto the manifold first.
        jacobian_reuse: ESDIRK32 only: simplified Newton that keeps the Jacobian while Newton
            contracts fast (:meth:`ESDIRK32._stage`); the last one is returned in the Trajectory.
        accelerations: False skips qdd and lambda at the outputs (NaN in the Trajectory): a force
            evaluation less per output for a caller that evaluates its outputs itself.
        on_step: called with the time after every accepted step, before anything else is evaluated
            (the last force evaluation was then the step's last stage, at that time): a force element
            with history (an elastic bushing's deformation) commits its state there; a rejected step
            never calls it.
        stage_values: ESDIRK32: a function of a force evaluation ``(t, y, qdd, lambda)`` returning an
            array (e.g. powers), called right after the evaluation at the start (and after a
            projection) and at the last Newton iterate of each stage (the state the force elements were
            last evaluated at, so their caches answer without a new solve; a step's start is the last
            stage of the step before); ``Trajectory.stage_integral`` is then the sum over the accepted
            steps of ``h sum_j b_j v_j``, the method's third-order quadrature along its own stages
            (rejected attempts do not count).

    Returns:
        The :class:`Trajectory`.

    Raises:
        IntegrationError: the solver failed (e.g. the step size fell below scipy's minimum).
    """
    _check_method(method, stage_values)
    start = time.perf_counter()
    t0, t_end = float(t_span[0]), float(t_span[1])
    q0 = np.asarray(q0, dtype=float)
    qd0 = np.asarray(qd0, dtype=float)
    if assemble_initial_state:
        q0 = project_positions(mechanism, q0, t0)
        qd0 = project_velocities(mechanism, q0, qd0, t0)
    stepper = Stepper(
        mechanism,
        t0,
        q0,
        qd0,
        method=method,
        rtol=rtol,
        atol=atol,
        alpha=alpha,
        beta=beta,
        t_bound=t_end,
        max_step=max_step,
        first_step=first_step,
        jacobian_reuse=jacobian_reuse,
        on_step=on_step,
        stage_values=stage_values,
    )
    system = stepper.system
    n = mechanism.n_coordinates
    records: list[tuple] = []
    output_evaluations = [0]

    def record(t_k: float, y_k: np.ndarray) -> None:
        # evaluated now, while the solver's last right-hand side is usually this very state (cache hit)
        before = system.n_force_evaluations
        if accelerations:
            qdd_k, lam_k = system.solve(t_k, y_k)
        else:
            qdd_k, lam_k = np.full(n, np.nan), np.full(mechanism.n_constraints, np.nan)
        output_evaluations[0] += system.n_force_evaluations - before
        q_k, qd_k = y_k[:n], y_k[n:]
        phi = mechanism.phi(q_k, t_k)
        phi_dot = mechanism.jacobian(q_k, t_k) @ qd_k + mechanism.phi_t(q_k, t_k)
        violations = (np.max(np.abs(phi), initial=0.0), np.max(np.abs(phi_dot), initial=0.0))
        records.append((t_k, y_k.copy(), qdd_k, lam_k, *violations))

    pending = None if t_eval is None else np.asarray(t_eval, dtype=float)
    if pending is not None:
        if pending.size == 0 or np.any(np.diff(pending) < 0) or pending[0] < t0 or pending[-1] > t_end:
            raise ValueError("t_eval must be non-empty, sorted and inside t_span")
        for t_k in pending[pending <= t0]:
            record(float(t_k), stepper.y)
        pending = pending[pending > t0]
    else:
        record(t0, stepper.y)

    while stepper.running:
        stepper.step()
        if pending is not None and pending.size and pending[0] <= stepper.t:
            dense = stepper.interpolant()
            inside = pending <= stepper.t
            for t_k in pending[inside]:
                record(float(t_k), stepper.y if t_k == stepper.t else dense(t_k))
            pending = pending[~inside]
        if projection:
            stepper.project(refresh=stepper.running)
        if pending is None:
            record(stepper.t, stepper.y)

    t_out = np.array([r[0] for r in records])
    y_out = np.array([r[1] for r in records])
    return Trajectory(
        t=t_out,
        q=y_out[:, :n],
        qd=y_out[:, n:],
        qdd=np.array([r[2] for r in records]),
        lam=np.array([r[3] for r in records]).reshape(len(records), -1),
        position_violation=np.array([r[4] for r in records]),
        velocity_violation=np.array([r[5] for r in records]),
        method=method,
        n_steps=stepper.steps,
        n_force_evaluations=system.n_force_evaluations - output_evaluations[0],
        n_jacobian_evaluations=system.n_jacobian_evaluations,
        n_output_evaluations=output_evaluations[0],
        n_lu=stepper.lu,
        wall_time=time.perf_counter() - start,
        n_rejected=stepper.rejected,
        next_step=stepper.next_step,
        jacobian=stepper.jacobian,
        stage_integral=stepper.stage_integral,
    )
