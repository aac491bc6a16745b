"""Patir & Cheng flow and shear-stress factors and the Wu & Zheng contact factor.

Every law takes Hs = h/sigma (film thickness over composite roughness, sigma = sqrt(sigma1^2 + sigma2^2))
and ``mod=numpy`` (arrays) or ``mod=ufl`` (inside forms): the same expression serves both, so the
numpy tests check what the forms use.

Sources (DESIGN 3.2, 3.4):
- pressure flow factors phi_x, phi_y: N. Patir, H. S. Cheng, ASME J. Lubr. Technol. 100 (1978) 12-17,
  Table 1: ``phi_x = 1 - C exp(-r Hs)`` (gamma <= 1), ``1 + C Hs^-r`` (gamma > 1); phi_y(H, gamma) =
  phi_x(H, 1/gamma).
- shear flow factor Phi_s and shear-stress factors Phi_f, Phi_fs, Phi_fp: N. Patir, H. S. Cheng,
  ASME J. Lubr. Technol. 101 (1979) 220-230, Tables 1-3 and eqs. for Phi_f.
- contact factor phi_c: C. Wu, L. Zheng, ASME J. Tribol. 111 (1989) 30-35.

Roughness orientation (Peklenik gamma) is taken from the fitted values gamma in {1/9, 1/6, 1/3, 1, 3,
6, 9}; between them the factors are interpolated linearly in log(gamma). Subscript 1 is the bushing
(surface 1 of DESIGN 3.2, speed U1), 2 the journal.

Below each fit's range (Hs < 0.5 for gamma = 1, see ``H_MIN``) the factors are held at their value
at the range's lower end, which keeps them continuous; the film is then in heavy asperity contact
and the load is carried by Greenwood-Tripp contact (solver.film.contact). For Hs -> infinity every factor
tends to its smooth value (phi_x = phi_y = phi_c = Phi_f = Phi_fp = 1, phi_s = Phi_fs = 0).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from solver.errors import out_of_range

GAMMAS = (1 / 9, 1 / 6, 1 / 3, 1.0, 3.0, 6.0, 9.0)
# Patir & Cheng 1978, Table 1: gamma -> (C, r, lowest Hs of the fit)
PRESSURE_FLOW = {
    1 / 9: (1.48, 0.42, 1.0),
    1 / 6: (1.38, 0.42, 1.0),
    1 / 3: (1.18, 0.42, 0.75),
    1.0: (0.90, 0.56, 0.5),
    3.0: (0.225, 1.5, 0.5),
    6.0: (0.520, 1.5, 0.5),
    9.0: (0.870, 1.5, 0.5),
}
# Patir & Cheng 1979, Table 1: gamma -> (A1, alpha1, alpha2, alpha3, A2) for Phi_s
SHEAR_FLOW = {
    1 / 9: (2.046, 1.12, 0.78, 0.03, 1.856),
    1 / 6: (1.962, 1.08, 0.77, 0.03, 1.754),
    1 / 3: (1.858, 1.01, 0.76, 0.03, 1.561),
    1.0: (1.899, 0.98, 0.92, 0.05, 1.126),
    3.0: (1.560, 0.85, 1.13, 0.08, 0.556),
    6.0: (1.290, 0.62, 1.09, 0.08, 0.388),
    9.0: (1.011, 0.54, 1.07, 0.08, 0.295),
}
# Patir & Cheng 1979, Table 2: gamma -> (A3, alpha4, alpha5, alpha6) for Phi_fs (Hs <= 7, else 0)
SHEAR_STRESS = {
    1 / 9: (14.1, 2.45, 2.30, 0.10),
    1 / 6: (13.4, 2.42, 2.30, 0.10),
    1 / 3: (12.3, 2.32, 2.30, 0.10),
    1.0: (11.1, 2.31, 2.38, 0.11),
    3.0: (9.8, 2.25, 2.80, 0.18),
    6.0: (10.1, 2.25, 2.90, 0.18),
    9.0: (8.7, 2.15, 2.97, 0.18),
}
# Patir & Cheng 1979, Table 3: gamma -> (D, s) for Phi_fp = 1 - D exp(-s Hs) (Hs > 0.5)
PRESSURE_SHEAR = {
    1 / 9: (1.51, 0.52),
    1 / 6: (1.51, 0.54),
    1 / 3: (1.47, 0.58),
    1.0: (1.40, 0.66),
    3.0: (0.98, 0.79),
    6.0: (0.97, 0.91),
    9.0: (0.73, 0.91),
}
H_MIN = 0.5  # lowest Hs of the gamma = 1 fits; below it the factors are held
SHEAR_FLOW_HOLD_WIDTH = 0.2  # Phi_s below H_MIN: its slope falls to zero over this width (C1), then held
PHI_F_EPSILON = 1 / 300  # Patir & Cheng 1979: cut-off of the gap distribution in Phi_f (Hs <= 3)
CONTACT_FACTOR_H = 3.0  # Wu & Zheng: phi_c = 1 for Hs >= 3


def _clamp(Hs: Any, low: float, mod: Any) -> Any:
    """max(Hs, low), continuous, for numpy arrays and UFL."""
    if mod is np:
        return np.maximum(Hs, low)
    return mod.max_value(Hs, low)


def _where(condition: Any, a: Any, b: Any, mod: Any) -> Any:
    if mod is np:
        return np.where(condition, a, b)
    return mod.conditional(condition, a, b)


def _lt(a: Any, b: float, mod: Any) -> Any:
    return a < b if mod is np else mod.lt(a, b)


def _bracket(gamma: float) -> tuple[float, float, float]:
    """Neighbouring tabulated gammas and the log-linear weight of the upper one."""
    if not GAMMAS[0] <= gamma <= GAMMAS[-1]:
        raise out_of_range("peklenik_gamma", gamma, f"[{GAMMAS[0]:.4g}, {GAMMAS[-1]:g}] (Patir-Cheng fits)")
    for low, high in zip(GAMMAS[:-1], GAMMAS[1:]):
        if math.isclose(gamma, low, rel_tol=1e-9):
            return low, high, 0.0
        if low < gamma <= high:
            return low, high, math.log(gamma / low) / math.log(high / low)
    raise AssertionError("unreachable")


def _interpolated(law, gamma: float, Hs: Any, mod: Any) -> Any:
    low, high, w = _bracket(gamma)
    if w == 0.0:
        return law(low, Hs, mod)
    if w == 1.0:
        return law(high, Hs, mod)
    return (1.0 - w) * law(low, Hs, mod) + w * law(high, Hs, mod)


def _pressure_flow_tabulated(gamma: float, Hs: Any, mod: Any) -> Any:
    C, r, H_low = PRESSURE_FLOW[gamma]
    H = _clamp(Hs, H_low, mod)
    if gamma <= 1.0:
        return 1.0 - C * mod.exp(-r * H)
    return 1.0 + C * H ** (-r)


def pressure_flow(Hs: Any, gamma: float = 1.0, mod: Any = np) -> Any:
    """Patir-Cheng pressure flow factor phi_x along the direction of the roughness parameter gamma."""
    return _interpolated(_pressure_flow_tabulated, gamma, Hs, mod)


def _shear_flow_edge(gamma: float) -> tuple[float, float]:
    """Phi_s and d Phi_s / d Hs of the low fit at Hs = H_MIN."""
    A1, a1, a2, a3, _ = SHEAR_FLOW[gamma]
    value = A1 * H_MIN**a1 * math.exp(-a2 * H_MIN + a3 * H_MIN**2)
    return value, value * (a1 / H_MIN - a2 + 2.0 * a3 * H_MIN)


def _shear_flow_tabulated(gamma: float, Hs: Any, mod: Any) -> Any:
    A1, a1, a2, a3, A2 = SHEAR_FLOW[gamma]
    H = _clamp(Hs, H_MIN, mod)
    H_low = np.minimum(H, 5.0) if mod is np else mod.min_value(H, 5.0)  # each fit only inside its range
    low = A1 * H_low**a1 * mod.exp(-a2 * H_low + a3 * H_low**2)
    high = A2 * mod.exp(-0.25 * H)
    fit = _where(_lt(H, 5.0, mod), low, high, mod) if mod is not np else np.where(H <= 5.0, low, high)
    # below H_MIN the slope falls linearly to zero over SHEAR_FLOW_HOLD_WIDTH (C1: a step in the slope
    # made the coupled Newton cycle between two iterates where a loaded film crosses H_MIN)
    value, slope = _shear_flow_edge(gamma)
    x = _clamp(Hs, H_MIN - SHEAR_FLOW_HOLD_WIDTH, mod) - H_MIN
    ramp = value + slope * x * (1.0 + x / (2.0 * SHEAR_FLOW_HOLD_WIDTH))
    return _where(_lt(Hs, H_MIN, mod), ramp, fit, mod)


def _shear_flow_slope_tabulated(gamma: float, Hs: np.ndarray, mod: Any = np) -> np.ndarray:
    """d Phi_s / d Hs of one tabulated gamma (numpy), as UFL differentiates _shear_flow_tabulated: the
    clamp max(Hs, H_MIN) passes the slope where Hs > H_MIN, and the fits are differentiated inside
    their branches."""
    A1, a1, a2, a3, A2 = SHEAR_FLOW[gamma]
    Hs = np.atleast_1d(Hs)
    H = np.maximum(Hs, H_MIN)
    inside = Hs > H_MIN  # UFL: d max_value(f, g) = conditional(f > g, df, dg)
    low = H < 5.0
    slope = np.empty_like(H)
    Hl = H[low]
    slope[low] = A1 * Hl**a1 * np.exp(-a2 * Hl + a3 * Hl**2) * (a1 / Hl - a2 + 2.0 * a3 * Hl)
    slope[~low] = -0.25 * A2 * np.exp(-0.25 * H[~low])
    edge_slope = _shear_flow_edge(gamma)[1]
    x = np.maximum(Hs, H_MIN - SHEAR_FLOW_HOLD_WIDTH) - H_MIN
    ramp = np.where(x > -SHEAR_FLOW_HOLD_WIDTH, edge_slope * (1.0 + x / SHEAR_FLOW_HOLD_WIDTH), 0.0)
    return np.where(inside, slope, ramp)


def shear_flow_function(Hs: Any, gamma: float = 1.0, mod: Any = np) -> Any:
    """Phi_s(Hs, gamma) of Patir & Cheng 1979 (the shear flow factor of one rough surface)."""
    return _interpolated(_shear_flow_tabulated, gamma, Hs, mod)


def contact_factor(Hs: Any, mod: Any = np) -> Any:
    """Wu & Zheng contact factor phi_c = exp(-0.6912 + 0.782 H - 0.304 H^2 + 0.0401 H^3), H < 3; else 1."""
    H = _clamp(Hs, 0.0, mod)
    H_fit = np.minimum(H, CONTACT_FACTOR_H) if mod is np else mod.min_value(H, CONTACT_FACTOR_H)
    fit = mod.exp(-0.6912 + 0.782 * H_fit - 0.304 * H_fit**2 + 0.0401 * H_fit**3)
    if mod is np:
        return np.where(H < CONTACT_FACTOR_H, fit, 1.0)
    return mod.conditional(mod.lt(H, CONTACT_FACTOR_H), fit, 1.0)


#: Gauss-Legendre rule of the mean gap's integral (smooth integrand on at most [0, 3]: ~1e-12)
_MEAN_GAP_RULE = np.polynomial.legendre.leggauss(10)


def mean_gap(Hs: Any, mod: Any = np) -> Any:
    """The mean gap h_T / sigma whose derivative is the contact factor, d(h_T/sigma)/dHs = phi_c(Hs):
    ``Hs + integral_{Hs}^{3} (1 - phi_c(x)) dx`` below Hs = 3 (10-point Gauss-Legendre), Hs above.

    It is the gap the mass-conserving film stores and carries (solver.film.jfo), so that with a full
    film its Couette and squeeze terms are those of the averaged Reynolds equation, phi_c dH/dtheta
    and phi_c dH/dT; the constant is fixed by h_T = h for Hs >= 3 (phi_c = 1 there)."""
    low = _clamp(Hs, 0.0, mod)
    low = np.minimum(low, CONTACT_FACTOR_H) if mod is np else mod.min_value(low, CONTACT_FACTOR_H)
    half = (CONTACT_FACTOR_H - low) / 2
    nodes, weights = _MEAN_GAP_RULE
    deficit = sum(
        float(w) * (1.0 - contact_factor(low + half * (1.0 + float(x)), mod)) for x, w in zip(nodes, weights)
    )
    # below Hs = 0 phi_c is held at phi_c(0): the mean gap goes on with that slope
    below = _clamp(-Hs, 0.0, mod)
    return Hs + below * (1.0 - contact_factor(0.0 * Hs, mod)) + half * deficit


def shear_stress_phi_f(Hs: Any, mod: Any = np) -> Any:
    """Phi_f of Patir & Cheng 1979 (mean of h/h_T over the polynomial gap distribution), z = Hs/3.

    Hs > 3: ``35/32 z [(1 - z^2)^3 ln((z + 1)/(z - 1)) + z/15 (66 + z^2 (30 z^2 - 80))]``;
    Hs <= 3: ``35/32 z [(1 - z^2)^3 ln((z + 1)/eps*)
    + (-55 + z(132 + z(345 + z(-160 + z(-405 + z(60 + 147 z))))))/60]``
    with eps* = 1/300. For Hs > 30 the closed form loses digits to cancellation, and its series
    ``1 + m2/Hs^2 + m4/Hs^4`` (m2 = 1, m4 = 27/11 are moments of the gap distribution) is used
    instead (truncation < 1e-8 there).
    """
    if mod is np:
        return _shear_stress_phi_f_numpy(np.asarray(Hs, dtype=float))
    H = _clamp(Hs, H_MIN, mod)
    series = 1.0 + 1.0 / H**2 + (27.0 / 11.0) / H**4
    z = H / 3.0
    z_high = mod.max_value(z, 1.0 + 1e-12)
    high = (
        35
        / 32
        * z_high
        * (
            (1 - z_high**2) ** 3 * mod.ln((z_high + 1) / (z_high - 1))
            + z_high / 15 * (66 + z_high**2 * (30 * z_high**2 - 80))
        )
    )
    poly = -55 + z * (132 + z * (345 + z * (-160 + z * (-405 + z * (60 + 147 * z)))))
    low = 35 / 32 * z * ((1 - z**2) ** 3 * mod.ln((z + 1) / PHI_F_EPSILON) + poly / 60)
    return mod.conditional(mod.gt(H, 30.0), series, mod.conditional(mod.gt(H, 3.0), high, low))


def _shear_stress_phi_f_numpy(Hs: np.ndarray) -> np.ndarray:
    """shear_stress_phi_f in numpy, each branch evaluated on its own entries only (the same
    expressions; the film's cells are mostly in the closed form's range and the series')."""
    shape = np.shape(Hs)
    H = np.maximum(np.atleast_1d(Hs), H_MIN)
    out = np.empty_like(H)
    series, low = H > 30.0, H <= 3.0
    high = ~(series | low)
    Hq = H[series]
    Hq2 = Hq * Hq
    out[series] = 1.0 + 1.0 / Hq2 + (27.0 / 11.0) / (Hq2 * Hq2)
    z = np.maximum(H[high] / 3.0, 1.0 + 1e-12)
    z2 = z * z
    a = 1 - z2
    out[high] = 35 / 32 * z * (a * a * a * np.log((z + 1) / (z - 1)) + z / 15 * (66 + z2 * (30 * z2 - 80)))
    if low.any():
        z = H[low] / 3.0
        poly = -55 + z * (132 + z * (345 + z * (-160 + z * (-405 + z * (60 + 147 * z)))))
        a = 1 - z * z
        out[low] = 35 / 32 * z * (a * a * a * np.log((z + 1) / PHI_F_EPSILON) + poly / 60)
    return out.reshape(shape)


def _shear_stress_fs_tabulated(gamma: float, Hs: Any, mod: Any) -> Any:
    A3, a4, a5, a6 = SHEAR_STRESS[gamma]
    H = _clamp(Hs, H_MIN, mod)
    H_fit = np.minimum(H, 7.0) if mod is np else mod.min_value(H, 7.0)  # the fit grows again beyond 7
    fit = A3 * H_fit**a4 * mod.exp(-a5 * H_fit + a6 * H_fit**2)
    if mod is np:
        return np.where(H < 7.0, fit, 0.0)
    return mod.conditional(mod.lt(H, 7.0), fit, 0.0)


def _pressure_shear_tabulated(gamma: float, Hs: Any, mod: Any) -> Any:
    D, s = PRESSURE_SHEAR[gamma]
    return 1.0 - D * mod.exp(-s * _clamp(Hs, H_MIN, mod))


@dataclasses.dataclass(frozen=True, kw_only=True)
class PatirCheng:
    """Flow and shear-stress factors of two rough surfaces (implements solver.film.reynolds.Roughness).

    Attributes:
        sigma_bushing: Rq of surface 1 (bushing) [m].
        sigma_journal: Rq of surface 2 (journal, pin) [m].
        gamma: Peklenik surface pattern parameter (1: isotropic; > 1: longitudinal ridges along x).
    """

    sigma_bushing: float  # m
    sigma_journal: float  # m
    gamma: float = 1.0

    def __post_init__(self) -> None:
        if not self.sigma_bushing >= 0:
            raise out_of_range("sigma_bushing", self.sigma_bushing, ">= 0 m")
        if not self.sigma_journal >= 0:
            raise out_of_range("sigma_journal", self.sigma_journal, ">= 0 m")
        if not self.sigma > 0:
            raise out_of_range("composite roughness sigma", self.sigma, "> 0 m (at least one rough surface)")
        if not self.gamma > 0:
            raise out_of_range("peklenik_gamma", self.gamma, "> 0")
        _bracket(self.gamma)

    @property
    def sigma(self) -> float:
        """Composite roughness sqrt(sigma1^2 + sigma2^2) [m]."""
        return math.hypot(self.sigma_bushing, self.sigma_journal)

    @property
    def variance_ratio(self) -> float:
        """(sigma1^2 - sigma2^2)/sigma^2: +1 when only the bushing is rough, -1 when only the journal is."""
        return (self.sigma_bushing**2 - self.sigma_journal**2) / self.sigma**2

    def pressure_flow_x(self, Hs, mod=np):
        return pressure_flow(Hs, self.gamma, mod)

    def pressure_flow_y(self, Hs, mod=np):
        return pressure_flow(Hs, 1.0 / self.gamma, mod)

    def shear_flow(self, Hs, mod=np):
        """phi_s = (sigma1^2 - sigma2^2)/sigma^2 Phi_s(Hs, gamma) (both surfaces of the same gamma)."""
        return self.variance_ratio * shear_flow_function(Hs, self.gamma, mod)

    def shear_flow_slope(self, Hs):
        """d phi_s / d Hs (numpy), what the forms get from ufl.diff of shear_flow (solver.film.reynolds)."""
        return self.variance_ratio * _interpolated(
            _shear_flow_slope_tabulated, self.gamma, np.asarray(Hs, float), np
        )

    def contact_factor(self, Hs, mod=np):
        return contact_factor(Hs, mod)

    def mean_gap(self, Hs, mod=np):
        return mean_gap(Hs, mod)

    def shear_stress_factors(self, Hs, mod=np):
        """(Phi_f, Phi_fs, Phi_fp); Phi_fs carries the variance ratio like phi_s."""
        return (
            shear_stress_phi_f(Hs, mod),
            self.variance_ratio * _interpolated(_shear_stress_fs_tabulated, self.gamma, Hs, mod),
            self.pressure_shear_factor(Hs, mod),
        )

    def pressure_shear_factor(self, Hs, mod=np):
        """Phi_fp alone (the third of shear_stress_factors)."""
        return _interpolated(_pressure_shear_tabulated, self.gamma, Hs, mod)
