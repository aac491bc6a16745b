"""Greenwood-Tripp asperity contact: pressure, real contact area and asperity friction.

Greenwood & Tripp, Proc. IMechE 185 (1970) 625-633 (DESIGN 3.3), with Hs = h/sigma::

    p_c = K E' F_5/2(Hs),      K = (16 sqrt(2) pi / 15) (eta beta sigma)^2 sqrt(sigma / beta)
    A_c / A = pi^2 (eta beta sigma)^2 F_2(Hs)
    F_n(Hs) = 1/sqrt(2 pi) integral_Hs^inf (s - Hs)^n exp(-s^2 / 2) ds
    1/E' = (1 - nu1^2)/E1 + (1 - nu2^2)/E2,    tau_c = mu_f p_c

F_5/2 and F_2 are computed by adaptive quadrature (scipy) on a table of Hs in [0, HS_MAX] and
interpolated: a cubic spline of log F in numpy, and inside UFL forms an exponential of a Chebyshev
polynomial least-squares fitted to the same table (``fit_error`` reports its largest relative error,
below 1e-5). Beyond HS_MAX = 6 the values (< 1e-12 of F(0)) are taken as 0. Below 0 (the nominal gap
of a rigid journal is positive, but a pin pressed into an elastic bushing can close it locally: the
asperities then carry more) a second table and fit cover Hs in [HS_MIN, 0], with the same accuracy; below
HS_MIN = -4 the value at HS_MIN is held. The common fit
``F_5/2 ~ 4.4086e-5 (4 - Hs)^6.804`` (Hs < 4) is available as ``method="fit"``; it is 11 % low at Hs = 0.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np
from scipy.integrate import quad
from scipy.interpolate import CubicSpline

from solver.errors import out_of_range

HS_MAX = 6.0
HS_MIN = -4.0
_CHEBYSHEV_DEGREE = 16
COMMON_FIT = (4.4086e-5, 4.0, 6.804)  # F_5/2 ~ a (b - Hs)^c for Hs < b


def gt_integral(n: float, Hs: float) -> float:
    """F_n(Hs) by adaptive quadrature of its definition (reference values)."""
    value, _ = quad(
        lambda s: (s - Hs) ** n * math.exp(-0.5 * s * s), Hs, math.inf, epsabs=0.0, epsrel=1e-12, limit=200
    )
    return value / math.sqrt(2 * math.pi)


@functools.lru_cache(maxsize=None)
def _table(n: float, negative: bool = False) -> tuple[np.ndarray, np.ndarray]:
    H = np.linspace(HS_MIN, 0.0, 161) if negative else np.linspace(0.0, HS_MAX, 241)
    return H, np.log(np.array([gt_integral(n, h) for h in H]))


@functools.lru_cache(maxsize=None)
def _spline(n: float, negative: bool = False):
    return CubicSpline(*_table(n, negative))


@functools.lru_cache(maxsize=None)
def _chebyshev(n: float, negative: bool = False) -> np.ndarray:
    H, logF = _table(n, negative)
    low, high = (HS_MIN, 0.0) if negative else (0.0, HS_MAX)
    return np.polynomial.chebyshev.chebfit((2 * H - low - high) / (high - low), logF, _CHEBYSHEV_DEGREE)


def fit_error(n: float, negative: bool = False) -> float:
    """Largest relative error of the UFL representation against quadrature, on a fine grid."""
    H = np.linspace(HS_MIN, 0.0, 65) if negative else np.linspace(0.0, HS_MAX, 97)
    exact = np.array([gt_integral(n, h) for h in H])
    return float(np.max(np.abs(_chebyshev_exp(n, H, np, negative) / exact - 1)))


def _chebyshev_exp(n: float, Hs: Any, mod: Any, negative: bool = False) -> Any:
    """exp(sum c_k T_k(x)), x the position of Hs in its table's range, by the Clenshaw recurrence
    (works for UFL)."""
    c = _chebyshev(n, negative)
    low, high = (HS_MIN, 0.0) if negative else (0.0, HS_MAX)
    x = (2.0 * Hs - low - high) / (high - low)
    b1, b2 = 0.0, 0.0
    for ck in c[:0:-1]:
        b1, b2 = 2.0 * x * b1 - b2 + float(ck), b1
    return mod.exp(x * b1 - b2 + float(c[0]))


def gt_function(n: float, Hs: Any, mod: Any = np, method: str = "exact") -> Any:
    """F_n(Hs) for n = 5/2 or 2: tabulated quadrature (``exact``) or the common fit (``fit``, n = 5/2
    only)."""
    if method == "fit":
        if n != 2.5:
            raise out_of_range("method", "'fit'", "'exact' for F_2 (the common fit is for F_5/2)")
        a, b, c = COMMON_FIT
        if mod is np:
            H = np.asarray(Hs, float)
            return np.where(H < b, a * np.abs(b - np.minimum(H, b)) ** c, 0.0)
        return mod.conditional(mod.lt(Hs, b), a * (b - mod.min_value(Hs, b)) ** c, 0.0)
    if method != "exact":
        raise out_of_range("asperity method", repr(method), "'exact' or 'fit'")
    if mod is np:
        Hs = np.asarray(Hs, float)
        H = np.clip(Hs, 0.0, HS_MAX)
        positive = np.where(Hs < HS_MAX, np.exp(_spline(n)(H)), 0.0)
        return np.where(Hs < 0.0, np.exp(_spline(n, True)(np.clip(Hs, HS_MIN, 0.0))), positive)
    H = mod.max_value(mod.min_value(Hs, HS_MAX), 0.0)
    positive = mod.conditional(mod.lt(Hs, HS_MAX), _chebyshev_exp(n, H, mod), 0.0)
    negative = _chebyshev_exp(n, mod.max_value(mod.min_value(Hs, 0.0), HS_MIN), mod, True)
    return mod.conditional(mod.lt(Hs, 0.0), negative, positive)


def composite_modulus(E1: float, nu1: float, E2: float, nu2: float) -> float:
    """E' from 1/E' = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 [Pa]."""
    return 1.0 / ((1 - nu1**2) / E1 + (1 - nu2**2) / E2)


@dataclasses.dataclass(frozen=True, kw_only=True)
class GreenwoodTripp:
    """Asperity contact of two rough surfaces (SI).

    Attributes:
        sigma: composite roughness Rq [m].
        eta_beta_sigma: asperity density x radius x sigma (dimensionless, typically 0.03-0.07).
        sigma_over_beta: sigma over asperity radius (dimensionless, typically 1e-4-1e-2).
        modulus: composite elastic modulus E' [Pa].
        friction: asperity friction coefficient mu_f.
        method: "exact" (quadrature) or "fit" (the common F_5/2 fit).
    """

    sigma: float
    eta_beta_sigma: float = 0.05
    sigma_over_beta: float = 0.001
    modulus: float
    friction: float = 0.1
    method: str = "exact"

    def __post_init__(self) -> None:
        for name, allowed in (
            ("sigma", "> 0 m"),
            ("eta_beta_sigma", "> 0"),
            ("sigma_over_beta", "> 0"),
            ("modulus", "> 0 Pa"),
        ):
            if not getattr(self, name) > 0:
                raise out_of_range(name, getattr(self, name), allowed)
        if not 0 <= self.friction < 2:
            raise out_of_range("asperity_friction", self.friction, "[0, 2)")
        if self.method not in ("exact", "fit"):
            raise out_of_range("asperity method", repr(self.method), "'exact' or 'fit'")

    @property
    def support(self) -> float:
        """Hs at and above which the contact pressure and area are exactly 0 (HS_MAX; the fit's 4 < it)."""
        return HS_MAX

    @property
    def K(self) -> float:
        """K = (16 sqrt(2) pi / 15) (eta beta sigma)^2 sqrt(sigma / beta)."""
        return 16 * math.sqrt(2) * math.pi / 15 * self.eta_beta_sigma**2 * math.sqrt(self.sigma_over_beta)

    def pressure(self, Hs: Any, mod: Any = np) -> Any:
        """Asperity contact pressure p_c(Hs) [Pa]."""
        return self.K * self.modulus * gt_function(2.5, Hs, mod, self.method)

    def area_ratio(self, Hs: Any, mod: Any = np) -> Any:
        """Real contact area over nominal area, pi^2 (eta beta sigma)^2 F_2(Hs)."""
        return math.pi**2 * self.eta_beta_sigma**2 * gt_function(2.0, Hs, mod, "exact")
