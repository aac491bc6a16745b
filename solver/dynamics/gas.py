"""Cylinder pressure over the four-stroke cycle: a single-zone model or a measured trace.

Crank angle ``theta`` (rad here; degrees in files and outputs): 0 = TDC at the start of intake, pi = BDC,
2 pi = firing TDC, 4 pi = end of the cycle; every pressure is periodic in 4 pi and absolute (Pa).

Single-zone model (Heywood 1988, sec. 9.2.1 with the ratio of specific heats replaced by the
polytropic exponent n; Wiebe 1970)::

    intake     0   <= theta < pi      p = p_intake
    closed     pi  <= theta < theta_e d(p V^n)/dtheta = (n - 1) V^(n-1) Q_tot dx_b/dtheta           (1)
    exhaust    theta_e <= theta < 4 pi p = p_exhaust

Gas exchange without jumps (``exhaust_opening`` theta_e, ``blowdown_duration`` D_b, ``valve_overlap``
D_o; all zero-width with theta_e = 3 pi gives the step model above, the seed's)::

    blowdown   theta_e <= theta < theta_e + D_b:  p = p_exhaust + (p_closed - p_exhaust) (1 - S(u)),
               u = (theta - theta_e) / D_b, p_closed from (3) continued (combustion is over)
    overlap    |theta - 4 pi| < D_o / 2 (mod 4 pi):  p = p_exhaust + (p_intake - p_exhaust) S(v),
               v = (theta - 4 pi + D_o/2) / D_o
    S(u) = 10 u^3 - 15 u^4 + 6 u^5  (S(0) = 0, S(1) = 1, S' and S'' zero at both ends)

so the pressure and its derivative are continuous over the whole cycle.

    x_b = (1 - exp(-a u^(m+1))) / (1 - exp(-a)),  u = (theta - theta_s) / Delta_theta in [0, 1]      (2)

Equation (1) is the first law of a closed single zone, ``dp/dtheta = (n-1)/V dQ/dtheta - n p/V
dV/dtheta``, multiplied by V^n. It integrates to::

    p V^n = p_intake V(pi)^n + (n - 1) Q_tot I(theta),   I(theta) = int_pi^theta V^(n-1) dx_b          (3)

so without heat release the compression and expansion follow ``p V^n = const`` exactly, and the net
work of the closed cycle has the closed form (integration by parts of (3))::

    W = C0 (V_evo^(1-n) - V_ivc^(1-n)) / (1 - n) + Q_tot (1 - I_end V_evo^(1-n))
        + p_intake (V(pi) - V(0)) + p_exhaust (V(4 pi) - V(3 pi)),   C0 = p_intake V_ivc^n          (4)

(with V_evo = V(theta_e); the blowdown and overlap pieces, linear in Q_tot too, are integrated by
Gauss-Legendre quadrature on fine panels).

``IMEP = W / V_d`` (net, over 720 deg). ``Q_tot`` is set by a target IMEP (linear in (4)) or a target
peak pressure (monotone in Q_tot, solved by Brent's method). The Wiebe function (2) is normalised so
that x_b goes exactly from 0 to 1. The volume ``V = V_c + A (x_TDC - x(theta))`` uses the piston pin
position of the offset slider-crank, ``x = r cos(theta) + sqrt(l^2 - (a - r sin(theta))^2)``, and the
compression ratio ``(V_c + V_d)/V_c`` with ``V_d = A (x_TDC - x_BDC)``.

Traces: CSV files with a header ``crank_angle_deg,pressure_bar`` (or ``pressure_Pa``, ``pressure_MPa``),
crank angles strictly increasing in [0, 720], interpolated periodically (monotone cubic, PCHIP).

References: J. B. Heywood, Internal Combustion Engine Fundamentals, McGraw-Hill 1988; I. I. Wiebe,
Brennverlauf und Kreisprozess von Verbrennungsmotoren, VEB Verlag Technik 1970.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Protocol

import numpy as np
from scipy.interpolate import CubicHermiteSpline, PchipInterpolator
from scipy.optimize import brentq, minimize_scalar

from solver.errors import InputError, out_of_range, read_text_file

CYCLE = 4.0 * math.pi  # rad, one four-stroke cycle
BAR = 1e5  # Pa

#: accepted pressure columns of a trace file -> factor to Pa
PRESSURE_COLUMNS = {"pressure_bar": BAR, "pressure_Pa": 1.0, "pressure_MPa": 1e6}


class CylinderPressure(Protocol):
    """A periodic cylinder pressure ``p(theta)`` (Pa, absolute) and ``dp/dtheta`` (Pa/rad)."""

    def pressure(self, theta: np.ndarray | float) -> np.ndarray: ...  # noqa: D102

    def derivative(self, theta: np.ndarray | float) -> np.ndarray: ...  # noqa: D102


@dataclasses.dataclass(frozen=True, kw_only=True)
class CylinderGeometry:
    """Cylinder and offset slider-crank geometry.

    Attributes:
        bore: m.
        crank_radius: m, r (stroke = 2 r without pin offset).
        rod_length: m, l, big-end to small-end centres.
        pin_offset: m, a, lateral (+y) offset of the pin from the cylinder axis.
        compression_ratio: (V_c + V_d) / V_c, > 1.
    """

    bore: float
    crank_radius: float
    rod_length: float
    pin_offset: float = 0.0
    compression_ratio: float

    def __post_init__(self) -> None:
        if not self.rod_length > self.crank_radius + abs(self.pin_offset):
            raise out_of_range("rod_length", f"{self.rod_length:g} m", "> crank_radius + |pin_offset|")
        if not self.compression_ratio > 1.0:
            raise out_of_range("compression_ratio", f"{self.compression_ratio:g}", "> 1")

    @property
    def piston_area(self) -> float:
        """m^2, pi bore^2 / 4."""
        return math.pi * self.bore**2 / 4.0

    def pin_position(self, theta: np.ndarray | float) -> np.ndarray:
        """m, x of the piston pin: ``r cos(theta) + sqrt(l^2 - (a - r sin(theta))^2)``."""
        r, l, a = self.crank_radius, self.rod_length, self.pin_offset
        return r * np.cos(theta) + np.sqrt(l**2 - (a - r * np.sin(theta)) ** 2)

    @property
    def stroke(self) -> float:
        """m, ``x_TDC - x_BDC`` (= 2 r without pin offset)."""
        r, l, a = self.crank_radius, self.rod_length, self.pin_offset
        return math.sqrt((l + r) ** 2 - a**2) - math.sqrt((l - r) ** 2 - a**2)

    @property
    def displacement(self) -> float:
        """m^3, swept volume V_d."""
        return self.piston_area * self.stroke

    @property
    def clearance_volume(self) -> float:
        """m^3, V_c = V_d / (compression_ratio - 1)."""
        return self.displacement / (self.compression_ratio - 1.0)

    def volume(self, theta: np.ndarray | float) -> np.ndarray:
        """m^3, cylinder volume ``V_c + A (x_TDC - x(theta))``."""
        r, l, a = self.crank_radius, self.rod_length, self.pin_offset
        x_tdc = math.sqrt((l + r) ** 2 - a**2)
        return self.clearance_volume + self.piston_area * (x_tdc - self.pin_position(theta))

    def volume_derivative(self, theta: np.ndarray | float) -> np.ndarray:
        """m^3/rad, dV/dtheta = -A dx/dtheta."""
        r, l, a = self.crank_radius, self.rod_length, self.pin_offset
        s = a - r * np.sin(theta)
        dx = -r * np.sin(theta) + s * r * np.cos(theta) / np.sqrt(l**2 - s**2)
        return -self.piston_area * dx


def wiebe_fraction(theta, start: float, duration: float, a: float = 5.0, m: float = 2.0) -> np.ndarray:
    """Burned (heat-release) fraction x_b(theta), eq. (2); 0 before start, 1 after start + duration."""
    u = np.clip((np.asarray(theta, dtype=float) - start) / duration, 0.0, 1.0)
    return -np.expm1(-a * u ** (m + 1.0)) / -math.expm1(-a)


def wiebe_rate(theta, start: float, duration: float, a: float = 5.0, m: float = 2.0) -> np.ndarray:
    """dx_b/dtheta (1/rad) of eq. (2); zero outside the combustion interval."""
    theta = np.asarray(theta, dtype=float)
    u = (theta - start) / duration
    inside = (u >= 0.0) & (u <= 1.0)
    u = np.clip(u, 0.0, 1.0)
    rate = a * (m + 1.0) * u**m * np.exp(-a * u ** (m + 1.0)) / (-math.expm1(-a) * duration)
    return np.where(inside, rate, 0.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class SingleZoneModel:
    """Single-zone pressure model of the module docstring, for a given total heat release.

    Use :func:`single_zone_model` to set ``heat_release`` from a target peak pressure or IMEP.

    Attributes:
        geometry: cylinder geometry.
        polytropic_exponent: n of eq. (1), 1 < n < 5/3.
        intake_pressure: Pa, absolute, during intake and at the start of compression (theta = pi).
        exhaust_pressure: Pa, absolute, during exhaust (3 pi to 4 pi).
        combustion_start: rad, theta_s, in (pi, 3 pi).
        combustion_duration: rad, Delta_theta, theta_s + Delta_theta < 3 pi.
        wiebe_a: Wiebe efficiency parameter a (> 0).
        wiebe_m: Wiebe form factor m (> -1).
        heat_release: J, Q_tot >= 0 (0 = motored).
    """

    geometry: CylinderGeometry
    polytropic_exponent: float = 1.32
    intake_pressure: float = 1.0 * BAR
    exhaust_pressure: float = 1.1 * BAR
    combustion_start: float = math.radians(350.0)
    combustion_duration: float = math.radians(50.0)
    wiebe_a: float = 5.0
    wiebe_m: float = 2.0
    heat_release: float = 0.0
    exhaust_opening: float = 3.0 * math.pi  # rad, theta_e (absolute crank angle of the cycle)
    blowdown_duration: float = 0.0  # rad, D_b (0: the pressure drops at theta_e)
    valve_overlap: float = 0.0  # rad, D_o, centred on 4 pi (0: the pressure steps there)

    def __post_init__(self) -> None:
        n = self.polytropic_exponent
        if not 1.0 < n < 5.0 / 3.0:
            raise out_of_range("polytropic_exponent", f"{n:g}", "(1, 5/3)")
        if not self.combustion_start > math.pi:
            start = math.degrees(self.combustion_start)
            raise out_of_range("combustion_start", f"{start:g} deg", "> 180 deg")
        if not self.combustion_duration > 0.0:
            duration = math.degrees(self.combustion_duration)
            raise out_of_range("combustion_duration", f"{duration:g} deg", "> 0")
        if not 0.0 <= self.valve_overlap < math.pi:
            raise out_of_range("valve_overlap", f"{math.degrees(self.valve_overlap):g} deg", "[0, 180)")
        if not 0.0 <= self.blowdown_duration:
            raise out_of_range("blowdown_duration", f"{math.degrees(self.blowdown_duration):g} deg", ">= 0")
        if (
            not 2.0 * math.pi
            < self.exhaust_opening
            <= CYCLE - self.valve_overlap / 2 - self.blowdown_duration
        ):
            raise out_of_range(
                "exhaust_opening",
                f"{math.degrees(self.exhaust_opening):g} deg",
                "(360, 720 - overlap/2 - blowdown] deg",
            )
        if not self.combustion_start + self.combustion_duration < self.exhaust_opening:
            raise out_of_range(
                "combustion_start + combustion_duration",
                f"{math.degrees(self.combustion_start + self.combustion_duration):g} deg",
                f"< {math.degrees(self.exhaust_opening):g} deg (exhaust valve opening)",
            )
        if not (self.heat_release >= 0.0 and math.isfinite(self.heat_release)):
            raise out_of_range("heat_release", f"{self.heat_release:g} J", ">= 0")
        # I(theta) of eq. (3) for unit heat release: composite 6-point Gauss-Legendre on fine panels,
        # then cubic Hermite interpolation with the exact derivative V^(n-1) dx_b/dtheta (error ~ h^4).
        start, duration = self.combustion_start, self.combustion_duration
        nodes = np.linspace(start, start + duration, 801)
        abscissae, weights = np.polynomial.legendre.leggauss(6)
        half = 0.5 * np.diff(nodes)
        mid = 0.5 * (nodes[1:] + nodes[:-1])
        points = mid[:, None] + half[:, None] * abscissae[None, :]
        panels = half * (self._heat_integrand(points) @ weights)
        values = np.concatenate([[0.0], np.cumsum(panels)])
        slopes = self._heat_integrand(nodes)
        slopes[-1] = self._heat_integrand(np.nextafter(nodes[-1], -np.inf))  # left limit at the kink
        object.__setattr__(self, "_heat_table", CubicHermiteSpline(nodes, values, slopes))
        object.__setattr__(self, "_heat_integral_end", float(values[-1]))

    def _heat_integrand(self, theta):
        n = self.polytropic_exponent
        rate = wiebe_rate(theta, self.combustion_start, self.combustion_duration, self.wiebe_a, self.wiebe_m)
        return self.geometry.volume(theta) ** (n - 1.0) * rate

    def _heat_integral(self, theta: np.ndarray) -> np.ndarray:
        """I(theta) of eq. (3) for unit heat release (m^(3(n-1)))."""
        start, end = self.combustion_start, self.combustion_start + self.combustion_duration
        inside = np.clip(theta, start, end)
        values = self._heat_table(inside)
        return np.where(theta <= start, 0.0, np.where(theta >= end, self._heat_integral_end, values))

    def burn_fraction(self, theta: np.ndarray | float) -> np.ndarray:
        """Heat-release fraction x_b, eq. (2), for theta in one cycle."""
        theta = np.mod(theta, CYCLE)
        return wiebe_fraction(
            theta, self.combustion_start, self.combustion_duration, self.wiebe_a, self.wiebe_m
        )

    def _closed(self, theta, heat=None) -> np.ndarray:
        """p of eq. (3) (closed cylinder), also continued into the blowdown; ``heat``: I(theta) if known."""
        n, V = self.polytropic_exponent, self.geometry.volume
        c0 = self.intake_pressure * V(math.pi) ** n
        heat = self._heat_integral(theta) if heat is None else heat
        return (c0 + (n - 1.0) * self.heat_release * heat) / V(theta) ** n

    def _closed_scalar(self, theta: float) -> float:
        """``_closed`` of one angle in [0, 4 pi) with I(theta) taken without arrays (the same value to
        round-off: numpy's scalar and array kernels may differ in the last bit), in a tenth of the time
        (one call per force evaluation of the mechanism)."""
        start, end = self.combustion_start, self.combustion_start + self.combustion_duration
        if theta <= start:
            heat = 0.0
        elif theta >= end:
            heat = self._heat_integral_end
        else:
            heat = float(self._heat_table(theta))
        return self._closed(theta, heat)

    def _closed_derivative(self, theta) -> np.ndarray:
        n, V = self.polytropic_exponent, self.geometry.volume(theta)
        return (n - 1.0) * self.heat_release * self._heat_integrand(theta) / V**n - n * self._closed(
            theta
        ) * (self.geometry.volume_derivative(theta) / V)

    def _overlap_phase(self, theta: np.ndarray) -> np.ndarray:
        """v of the valve overlap (module docstring), in [0, 1] inside it (theta in [0, 4 pi))."""
        half = self.valve_overlap / 2
        shifted = np.where(theta >= CYCLE - half, theta - CYCLE, theta)
        return (shifted + half) / self.valve_overlap if self.valve_overlap > 0 else np.full_like(theta, 2.0)

    def pressure(self, theta: np.ndarray | float) -> np.ndarray:
        """Pa, absolute cylinder pressure over the cycle (module docstring)."""
        if np.ndim(theta) == 0:  # scalar fast path (one call per force evaluation in the mechanism)
            t = float(theta) % CYCLE
            half = self.valve_overlap / 2
            if half <= t < math.pi:
                return np.float64(self.intake_pressure)
            if self.exhaust_opening + self.blowdown_duration <= t < CYCLE - half:
                return np.float64(self.exhaust_pressure)
            if math.pi <= t < self.exhaust_opening:  # closed: eq. (3) with the same operations on a float
                return np.float64(self._closed_scalar(t))
        scalar = np.ndim(theta) == 0
        theta = np.mod(np.atleast_1d(np.asarray(theta, dtype=float)), CYCLE)
        p_in, p_ex = self.intake_pressure, self.exhaust_pressure
        half, evo, blowdown = self.valve_overlap / 2, self.exhaust_opening, self.blowdown_duration
        p = np.where(theta < math.pi, p_in, p_ex).astype(float)
        closed = (theta >= math.pi) & (theta < evo)
        p[closed] = self._closed(theta[closed])
        if blowdown > 0:
            inside = (theta >= evo) & (theta < evo + blowdown)
            u = (theta[inside] - evo) / blowdown
            p[inside] = p_ex + (self._closed(theta[inside]) - p_ex) * (1.0 - _smoothstep(u))
        if half > 0:
            inside = (theta < half) | (theta >= CYCLE - half)
            p[inside] = p_ex + (p_in - p_ex) * _smoothstep(self._overlap_phase(theta[inside]))
        return np.float64(p[0]) if scalar else p

    def derivative(self, theta: np.ndarray | float) -> np.ndarray:
        """Pa/rad, dp/dtheta (with zero-width blowdown or overlap the steps there are not included)."""
        scalar = np.ndim(theta) == 0
        theta = np.mod(np.atleast_1d(np.asarray(theta, dtype=float)), CYCLE)
        p_in, p_ex = self.intake_pressure, self.exhaust_pressure
        half, evo, blowdown = self.valve_overlap / 2, self.exhaust_opening, self.blowdown_duration
        dp = np.zeros_like(theta)
        closed = (theta >= math.pi) & (theta < evo)
        dp[closed] = self._closed_derivative(theta[closed])
        if blowdown > 0:
            inside = (theta >= evo) & (theta < evo + blowdown)
            t = theta[inside]
            u = (t - evo) / blowdown
            dp[inside] = (
                self._closed_derivative(t) * (1.0 - _smoothstep(u))
                - (self._closed(t) - p_ex) * _smoothstep_slope(u) / blowdown
            )
        if half > 0:
            inside = (theta < half) | (theta >= CYCLE - half)
            dp[inside] = (
                (p_in - p_ex) * _smoothstep_slope(self._overlap_phase(theta[inside])) / self.valve_overlap
            )
        return np.float64(dp[0]) if scalar else dp

    def work(self) -> float:
        """J, net indicated work per cycle, eq. (4) (closed integral of p dV)."""
        return self._work_motored() + self.heat_release * self._work_per_heat()

    def _work_motored(self) -> float:
        n, V = self.polytropic_exponent, self.geometry.volume
        half, evo, blowdown = self.valve_overlap / 2, self.exhaust_opening, self.blowdown_duration
        v_ivc, v_evo = V(math.pi), V(evo)
        c0 = self.intake_pressure * v_ivc**n
        closed = c0 * (v_evo ** (1.0 - n) - v_ivc ** (1.0 - n)) / (1.0 - n)
        gas_exchange = self.intake_pressure * (v_ivc - V(half)) + self.exhaust_pressure * (
            V(CYCLE - half) - V(evo + blowdown)
        )
        p_in, p_ex = self.intake_pressure, self.exhaust_pressure
        pieces = _integral_p_dV(
            self.geometry,
            lambda t: (
                p_ex * _smoothstep((t - evo) / blowdown)
                + c0 / V(t) ** n * (1.0 - _smoothstep((t - evo) / blowdown))
            ),
            evo,
            evo + blowdown,
        )
        overlap = lambda t: p_ex + (p_in - p_ex) * _smoothstep((t - CYCLE + half) / self.valve_overlap)  # noqa: E731
        pieces += _integral_p_dV(self.geometry, overlap, CYCLE - half, CYCLE + half)
        return float(closed + gas_exchange + pieces)

    def _work_per_heat(self) -> float:
        n, V = self.polytropic_exponent, self.geometry.volume
        evo, blowdown = self.exhaust_opening, self.blowdown_duration
        closed = 1.0 - self._heat_integral_end * V(evo) ** (1.0 - n)
        blow = _integral_p_dV(
            self.geometry,
            lambda t: (
                (n - 1.0) * self._heat_integral_end / V(t) ** n * (1.0 - _smoothstep((t - evo) / blowdown))
            ),
            evo,
            evo + blowdown,
        )
        return float(closed + blow)

    def imep(self) -> float:
        """Pa, net indicated mean effective pressure ``W / V_d``."""
        return self.work() / self.geometry.displacement

    def peak(self) -> tuple[float, float]:
        """(Pa, rad): maximum pressure and the crank angle where it occurs."""
        grid = np.radians(np.arange(180.0, 540.0, 0.25))
        values = self.pressure(grid)
        k = int(np.argmax(values))
        low, high = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
        best = minimize_scalar(
            lambda theta: -float(self.pressure(theta)),
            bounds=(low, high),
            method="bounded",
            options={"xatol": 1e-10},
        )
        if -best.fun >= values[k]:
            return float(-best.fun), float(best.x)
        return float(values[k]), float(grid[k])


def _smoothstep(u):
    """S(u) = 10 u^3 - 15 u^4 + 6 u^5 on [0, 1] (0 below, 1 above)."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u**2)


def _smoothstep_slope(u):
    u = np.clip(u, 0.0, 1.0)
    return 30.0 * u**2 * (1.0 - u) ** 2


def _integral_p_dV(
    geometry: CylinderGeometry, pressure, start: float, end: float, panels: int = 400
) -> float:
    """integral of p dV = p dV/dtheta dtheta over [start, end] (6-point Gauss-Legendre on equal panels;
    the integrands are smooth there: ~1e-14 relative)."""
    if not end > start:
        return 0.0
    abscissae, weights = np.polynomial.legendre.leggauss(6)
    nodes = np.linspace(start, end, panels + 1)
    half = 0.5 * np.diff(nodes)
    points = (0.5 * (nodes[1:] + nodes[:-1]))[:, None] + half[:, None] * abscissae[None, :]
    values = pressure(points) * geometry.volume_derivative(np.mod(points, CYCLE))
    return float(np.sum(half * (values @ weights)))


def single_zone_model(
    geometry: CylinderGeometry,
    *,
    peak_pressure: float | None = None,
    imep: float | None = None,
    **parameters,
) -> SingleZoneModel:
    """A :class:`SingleZoneModel` whose heat release gives the target peak pressure or IMEP.

    Args:
        geometry: cylinder geometry.
        peak_pressure: Pa, absolute target maximum pressure (give this or ``imep``; neither = motored).
        imep: Pa, target net IMEP.
        **parameters: the other fields of :class:`SingleZoneModel` (not ``heat_release``).

    Raises:
        InputError: both targets given, or a target below the motored value.
    """
    motored = SingleZoneModel(geometry=geometry, **parameters)
    if peak_pressure is not None and imep is not None:
        raise InputError("give either gas.peak_pressure_bar or gas.imep_bar, not both")
    if imep is not None:
        heat = (imep * geometry.displacement - motored._work_motored()) / motored._work_per_heat()
        if not heat >= 0.0:
            allowed = f">= the motored IMEP {motored.imep() / BAR:.4g}"
            raise out_of_range("gas.imep_bar", f"{imep / BAR:g}", allowed)
        return dataclasses.replace(motored, heat_release=heat)
    if peak_pressure is None:
        return motored
    motored_peak = motored.peak()[0]
    if not peak_pressure > motored_peak:
        raise out_of_range(
            "gas.peak_pressure_bar",
            f"{peak_pressure / BAR:g}",
            f"> the motored peak {motored_peak / BAR:.4g}",
        )

    def excess(heat: float) -> float:
        return dataclasses.replace(motored, heat_release=heat).peak()[0] - peak_pressure

    # a first guess from eq. (3) at the motored peak volume, then widen until the root is bracketed
    n = motored.polytropic_exponent
    high = max((peak_pressure - motored_peak) * geometry.clearance_volume / (n - 1.0), 1.0)
    while excess(high) < 0.0:
        high *= 2.0
    heat = brentq(excess, 0.0, high, xtol=1e-12 * high, rtol=1e-13)
    return dataclasses.replace(motored, heat_release=heat)


@dataclasses.dataclass(frozen=True)
class ConstantPressure:
    """A constant pressure (Pa), e.g. equal to the crankcase pressure: no gas force."""

    value: float

    def pressure(self, theta):  # noqa: D102
        return np.full(np.shape(theta), self.value, dtype=float)

    def derivative(self, theta):  # noqa: D102
        return np.zeros(np.shape(theta))


@dataclasses.dataclass(frozen=True)
class PressureTrace:
    """Periodic interpolation of a measured pressure trace (monotone cubic, Fritsch-Carlson PCHIP).

    Attributes:
        crank_angle: rad, strictly increasing in [0, 4 pi).
        values: Pa, absolute pressure at those angles.
    """

    crank_angle: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        theta, p = np.asarray(self.crank_angle, float), np.asarray(self.values, float)
        extended_theta = np.concatenate([theta - CYCLE, theta, theta + CYCLE])
        object.__setattr__(self, "_spline", PchipInterpolator(extended_theta, np.tile(p, 3)))

    def pressure(self, theta):  # noqa: D102
        return self._spline(np.mod(np.asarray(theta, dtype=float), CYCLE))

    def derivative(self, theta):  # noqa: D102
        return self._spline.derivative()(np.mod(np.asarray(theta, dtype=float), CYCLE))


def read_crank_angle_csv(
    path: str | Path, value_columns: Mapping[str, float], *, field: str
) -> tuple[np.ndarray, np.ndarray]:
    """Read a two-column CSV trace over one cycle: crank angle (deg) and one value column.

    The first non-comment line is the header ``crank_angle_deg,<column>`` with ``<column>`` one of
    ``value_columns`` (name -> factor to SI). Lines starting with ``#`` and blank lines are skipped.
    Crank angles must be finite, strictly increasing and in [0, 720]; a point at 720 deg must repeat
    the value at 0 deg and is dropped (the trace is periodic).

    Args:
        path: the CSV file.
        value_columns: accepted value column names and their factors to SI units.
        field: the case field that named the file, used in error messages (e.g. ``gas.pressure_file``).

    Returns:
        ``(crank_angle rad, values SI)``.

    Raises:
        InputError: missing or unreadable file, wrong header, bad numbers, non-monotone angles.
    """
    path = Path(path)
    where = f"{field} = {str(path)!r}"
    text = read_text_file(path, field)
    header, angles, values = None, [], []
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        cells = [cell.strip() for cell in stripped.split(",")]
        if header is None:
            header = cells
            expected = " or ".join(f"crank_angle_deg,{name}" for name in value_columns)
            if len(cells) != 2 or cells[0] != "crank_angle_deg" or cells[1] not in value_columns:
                raise InputError(f"{where}: line {number}: header is {stripped!r}, expected {expected}")
            continue
        if len(cells) != 2:
            raise InputError(f"{where}: line {number}: expected 2 columns, found {len(cells)}")
        try:
            angle, value = float(cells[0]), float(cells[1])
        except ValueError:
            raise InputError(f"{where}: line {number}: {stripped!r} is not two numbers") from None
        for name, number_value in ((header[0], angle), (header[1], value)):
            if not math.isfinite(number_value):
                text = cells[header.index(name)]
                raise InputError(f"{where}: line {number}: {name} = {text} is not finite")
        if angles and not angle > angles[-1][0]:
            raise InputError(
                f"{where}: line {number}: crank angles must be strictly increasing "
                f"({angle:g} deg after {angles[-1][0]:g} deg)"
            )
        if not 0.0 <= angle <= 720.0:
            raise InputError(
                f"{where}: line {number}: crank_angle_deg = {angle:g} is out of range (allowed: [0, 720])"
            )
        angles.append((angle, number))
        values.append(value)
    if header is None:
        raise InputError(f"{where}: the file is empty")
    if len(angles) < 2:
        raise InputError(f"{where}: needs at least 2 data lines, found {len(angles)}")
    angle_deg = np.array([a for a, _ in angles])
    data = np.array(values)
    if angle_deg[-1] == 720.0:
        if angle_deg[0] != 0.0 or data[-1] != data[0]:
            raise InputError(
                f"{where}: line {angles[-1][1]}: the point at 720 deg must repeat the point at 0 deg "
                "(periodic trace)"
            )
        angle_deg, data = angle_deg[:-1], data[:-1]
    return np.radians(angle_deg), data * value_columns[header[1]]


def load_pressure_trace(path: str | Path, *, field: str = "gas.pressure_file") -> PressureTrace:
    """Read a cylinder-pressure CSV (see :func:`read_crank_angle_csv`) into a :class:`PressureTrace`.

    Raises:
        InputError: as :func:`read_crank_angle_csv`, or a negative (absolute) pressure.
    """
    theta, pressure = read_crank_angle_csv(path, PRESSURE_COLUMNS, field=field)
    if np.any(pressure < 0.0):
        k = int(np.argmax(pressure < 0.0))
        raise InputError(
            f"{field} = {str(path)!r}: pressure at {math.degrees(theta[k]):g} deg is negative "
            "(absolute pressure expected, allowed: >= 0)"
        )
    return PressureTrace(theta, pressure)
