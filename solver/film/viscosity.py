"""Pressure-viscosity laws of the oil (piezoviscosity, DESIGN 7) and the film's reduced pressure.

Barus: ``mu(p) = mu0 exp(alpha p)``. Roelands (1966), with the initial slope alpha::

    mu(p) = mu0 exp((ln(mu0 / mu_inf)) ((1 + p / p_r)^Z - 1)),   mu_inf = 6.31e-5 Pa s, p_r = 1.96e8 Pa
    Z = alpha p_r / ln(mu0 / mu_inf)                 (so that d ln(mu)/dp = alpha at p = 0)

The viscosity enters the Reynolds equation only through the Poiseuille flow ``h^3/(12 mu) grad p``;
the Couette, shear-flow and squeeze terms do not contain it. With the reduced pressure

    q(p) = integral from 0 to p of mu0 / mu(s) ds,        grad q = (mu0 / mu) grad p

the piezoviscous equation in p is the iso-viscous one in q, exactly: the film is solved for q with
the iso-viscous operator, and the pressure follows node by node from p = p(q) (Barus: q = (1 -
exp(-alpha p)) / alpha, p = -ln(1 - alpha q) / alpha). The cavitation bound maps to q >= q(p_cav)
(q is increasing in p). q stays below ``q_limit`` = q(infinity) (Barus 1/alpha): a rigid film that
needs more carries an unbounded pressure, which the elastic bushing prevents. Shear stresses use
the true pressure and mu(p) (solver.film.bearing).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.interpolate

from solver.errors import out_of_range

ROELANDS_PRESSURE = 1.96e8  # Pa, p_r
ROELANDS_VISCOSITY = 6.31e-5  # Pa s, mu_inf
#: Pa, the lowest gauge pressure a film can have (absolute vacuum; the cavitation pressure's bound): the
#: table of q(p) starts there (from 0 its end cubic, extrapolated to the JFO cases' -0.9 bar, gave q 29 %
#: off and p(q(p)) 29 % off p: the cavitation bound in q did not map back, and the elastic JFO film's
#: first solve at 0.067 R did not converge)
ATMOSPHERE = 1.01325e5


@dataclasses.dataclass(frozen=True)
class Barus:
    """mu = mu0 exp(alpha p)."""

    alpha: float  # 1/Pa

    def __post_init__(self) -> None:
        if not 0 < self.alpha < 1e-7:
            raise out_of_range("pressure-viscosity coefficient", self.alpha, "(0, 1e-7) 1/Pa (oils: 1-3e-8)")

    @property
    def q_limit(self) -> float:
        return 1.0 / self.alpha

    def ratio(self, p, mod=np):
        """mu(p) / mu0 (numpy arrays, or UFL expressions with ``mod=ufl``)."""
        return mod.exp(self.alpha * p)

    def reduced(self, p):
        return -np.expm1(-self.alpha * np.asarray(p, float)) / self.alpha

    def pressure(self, q):
        """p(q) [Pa]; inf where q >= q_limit."""
        x = self.alpha * np.asarray(q, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(x < 1.0, -np.log1p(-np.minimum(x, 1.0)) / self.alpha, np.inf)


class Roelands:
    """Roelands' law with the initial slope alpha (module docstring); q(p) tabulated and inverted."""

    def __init__(self, alpha: float, viscosity: float, *, p_min: float = -ATMOSPHERE, p_max: float = 20e9):
        if not 0 < alpha < 1e-7:
            raise out_of_range("pressure-viscosity coefficient", alpha, "(0, 1e-7) 1/Pa (oils: 1-3e-8)")
        if not viscosity > ROELANDS_VISCOSITY:
            raise out_of_range("viscosity (Roelands)", viscosity, f"> {ROELANDS_VISCOSITY:g} Pa s")
        self.alpha, self.viscosity = alpha, viscosity
        self.log_ratio = math.log(viscosity / ROELANDS_VISCOSITY)
        self.Z = alpha * ROELANDS_PRESSURE / self.log_ratio
        # q(p) on a graded grid (fine near 0, where the slope changes fastest); beyond p_max the
        # integrand exp(-...) is below 1e-30 of its start for any oil, so q_limit = q(p_max)
        low = min(p_min, 0.0)
        grid = np.concatenate(
            [
                np.linspace(low, 0.0, 200)[:-1] if low < 0 else np.zeros(0),
                p_max * np.linspace(0.0, 1.0, 20001) ** 3,
            ]
        )
        # f = dq/dp = 1/ratio, integrated by the trapezoidal rule with its end correction
        # (Euler-Maclaurin, fourth order); q(p) and p(q) are cubic Hermite splines with the exact
        # slopes, so the round trip and the slope dq/dp = mu0/mu hold to ~1e-10
        f = 1.0 / self.ratio(grid)
        df = -f * self.log_slope(grid)
        dp = np.diff(grid)
        steps = dp / 2 * (f[:-1] + f[1:]) + dp**2 / 12 * (df[:-1] - df[1:])
        q = np.concatenate([[0.0], np.cumsum(steps)])
        # (the tail where f has underflowed adds nothing: q must increase strictly for p(q))
        keep = np.concatenate([[True], (dp > 0) & (np.diff(q) > 1e-14 * q[-1])])
        grid, q, f = grid[keep], q[keep], f[keep]
        q -= scipy.interpolate.CubicHermiteSpline(grid, q, f)(0.0)
        self._reduced = scipy.interpolate.CubicHermiteSpline(grid, q, f)
        self._pressure = scipy.interpolate.CubicHermiteSpline(q, grid, 1.0 / f)
        self.q_limit = float(q[-1])

    def ratio(self, p, mod=np):
        return mod.exp(self.log_ratio * ((1.0 + p / ROELANDS_PRESSURE) ** self.Z - 1.0))

    def log_slope(self, p):
        """d ln(mu)/dp [1/Pa]."""
        return self.log_ratio * self.Z * (1.0 + p / ROELANDS_PRESSURE) ** (self.Z - 1.0) / ROELANDS_PRESSURE

    def reduced(self, p):
        return self._reduced(p)

    def pressure(self, q):
        q = np.asarray(q, float)
        return np.where(q < self.q_limit, self._pressure(np.minimum(q, self.q_limit)), np.inf)


def viscosity_law(kind: str, alpha: float, viscosity: float):
    """``FilmModel(piezoviscosity=...)`` of a case or command: None, Barus or Roelands."""
    if kind == "none":
        return None
    if kind == "barus":
        return Barus(alpha)
    if kind == "roelands":
        return Roelands(alpha, viscosity)
    raise out_of_range("piezoviscosity", repr(kind), "'none', 'barus' or 'roelands'")
