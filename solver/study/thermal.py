"""Effective film temperature: the heat balance of a cycle and its iteration over the cycles.

With ``oil.thermal = "effective"`` the small end's film is taken at one effective temperature T (the
same over the film and over the cycle: a bulk temperature, as in the effective-temperature method of
journal-bearing design, Raimondi & Boyd 1958), at which the oil's viscosity and density are evaluated
(solver.oil). T follows from the heat balance of a cycle, with cycle means (time means over 720 deg)::

    (1 - s) P_diss(T)  =  rho(T) c_p Q_side(T) (T - T_supply)

- ``P_diss`` [W]: the power dissipated in the joint (friction + squeeze, the ``dissipated_power``
  output of solver.study.outputs);
- ``s``: the share of it conducted away through the pin and the rod rather than carried by the oil
  (``oil.heat_to_solids``). It is an assumption, not computed: 0.2 by default (Raimondi and Boyd's
  adiabatic bearing is s = 0);
- ``Q_side`` [m^3/s]: the oil's volume flow out of the bushing's edges (the ``side_flow`` output),
  which leaves at T and is replaced by oil at the supply temperature ``T_supply``
  (``oil.temperature_C``);
- ``rho(T)`` [kg/m^3]: the oil's density at T (solver.oil); ``c_p`` [J/(kg K)] its specific heat
  (``oil.specific_heat_J_kgK``, 2000 by default).

The residual of a cycle run at T is ``R(T) = (1 - s) P_diss(T) - rho(T) c_p Q_side(T) (T - T_supply)``
and its closure ``|R| / ((1 - s) P_diss)``. R(T_supply) = (1 - s) P_diss > 0, so a root lies above
T_supply if R turns negative below the limit. In a full film R falls as T rises (the oil thins and
dissipates less); in mixed lubrication P_diss can rise with T (the film thins and the asperities carry
more: 3.1 W at 90 C, 5.6 W at 116 C, 8.2 W at 146 C in the reference engine's mixed-fem small end
on a coarse film mesh), so R need not be monotonic and the bracket below keeps the iteration on a sign
change. ``P_diss`` and ``Q_side`` come from whole cycles, so the iteration runs across the cycles
(:class:`EffectiveTemperature`): cycle k runs at T_k, and T_(k+1) is

1. after the first cycle: the balance solved for T with that cycle's P_diss and Q_side held
   (a fixed-point step, ``T = T_supply + (1 - s) P_diss / (rho(T_k) c_p Q_side)``);
2. then the secant through the last two cycles' (T, R), safeguarded: it must fall inside the bracket
   known so far (the highest T with R > 0 and the lowest with R < 0), else the fixed-point step of the
   last cycle is taken if it does, else the bracket's midpoint;
3. never above ``temperature_limit`` (where the oil's viscosity falls to the 2 mm^2/s limit of ASTM
   D341's plain Walther form, or 250 C); if the balance still has R > 0 there, the run fails.

Once a cycle's closure is within the tolerance the temperature is kept, so that the mechanics settle
at it (solver.study.cycles stops when both the closure and the cycle-to-cycle change of h_min are
within their tolerances). Numpy only: no files, no MPI.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from solver.oil import KELVIN, MIN_KINEMATIC_VISCOSITY, WALTHER_OFFSET, OilData

#: C, the highest film temperature tried: the upper bound of the case's ``oil.temperature_C``
MAX_TEMPERATURE = 250.0


class ThermalError(RuntimeError):
    """The heat balance cannot be closed (no side flow, no heat, or a film temperature beyond the limit)."""


def cycle_mean(values: np.ndarray, time: np.ndarray) -> float:
    """The time mean of values over the cycle (trapezoidal rule); NaN if any value is not finite."""
    values, time = np.asarray(values, dtype=float), np.asarray(time, dtype=float)
    if not np.all(np.isfinite(values)):
        return math.nan
    return float(np.trapz(values, time) / (time[-1] - time[0]))


@dataclasses.dataclass(frozen=True)
class HeatBalance:
    """The heat balance of one cycle run at ``temperature`` (module docstring; SI, temperatures in C)."""

    temperature: float  # C, film temperature T the cycle ran at
    dissipated_power: float  # W, cycle mean P_diss
    side_flow: float  # m^3/s, cycle mean Q_side
    density: float  # kg/m^3, rho(T)
    heat_to_oil: float  # W, (1 - s) P_diss
    heat_carried: float  # W, rho(T) c_p Q_side (T - T_supply)

    @property
    def residual(self) -> float:
        """R = heat into the oil - heat carried out by the side flow [W]."""
        return self.heat_to_oil - self.heat_carried

    @property
    def closure(self) -> float:
        """|R| / ((1 - s) P_diss)."""
        return abs(self.residual) / self.heat_to_oil


@dataclasses.dataclass(frozen=True)
class ThermalModel:
    """The oil and the assumptions of the balance (module docstring).

    Attributes:
        oil: the oil's data sheet (viscosity and density against temperature).
        specific_heat: c_p [J/(kg K)].
        heat_to_solids: s, the share of the dissipated power conducted away through pin and rod.
        supply_temperature: T_supply [C], the temperature of the oil that replaces the side flow.
    """

    oil: OilData
    specific_heat: float
    heat_to_solids: float
    supply_temperature: float

    @property
    def temperature_limit(self) -> float:
        """C: where the oil's kinematic viscosity reaches MIN_KINEMATIC_VISCOSITY (Walther inverted),
        or MAX_TEMPERATURE if lower."""
        A, B = self.oil.walther_constants()
        log_T = (A - math.log10(math.log10(MIN_KINEMATIC_VISCOSITY + WALTHER_OFFSET))) / B
        return min(10.0**log_T - KELVIN, MAX_TEMPERATURE)

    def balance(self, temperature: float, dissipated_power: float, side_flow: float) -> HeatBalance:
        """The balance of a cycle run at ``temperature`` [C] with these cycle means [W, m^3/s].

        Raises:
            ThermalError: P_diss or Q_side not finite and positive.
        """
        if not (math.isfinite(dissipated_power) and dissipated_power > 0):
            raise ThermalError(
                f"the cycle's mean dissipated power is {dissipated_power:g} W (the balance needs > 0)"
            )
        if not (math.isfinite(side_flow) and side_flow > 0):
            raise ThermalError(f"the cycle's mean side flow is {side_flow:g} m^3/s (the balance needs > 0)")
        rho = float(self.oil.density(temperature))
        carried = rho * self.specific_heat * side_flow * (temperature - self.supply_temperature)
        return HeatBalance(
            temperature=temperature,
            dissipated_power=dissipated_power,
            side_flow=side_flow,
            density=rho,
            heat_to_oil=(1.0 - self.heat_to_solids) * dissipated_power,
            heat_carried=carried,
        )

    def fixed_point(self, balance: HeatBalance) -> float:
        """T from the balance with that cycle's P_diss, Q_side and rho held [C]."""
        return self.supply_temperature + balance.heat_to_oil / (
            balance.density * self.specific_heat * balance.side_flow
        )


class EffectiveTemperature:
    """The safeguarded secant iteration of the film temperature over the cycles (module docstring).

    Args:
        model: the balance's oil and assumptions.
        tolerance: closure |R| / ((1 - s) P_diss) at which the temperature is kept.
        history: the balances of the cycles run so far (from ``state()``, to resume).
    """

    def __init__(self, model: ThermalModel, tolerance: float, history: list[HeatBalance] | None = None):
        self.model, self.tolerance = model, tolerance
        self.history: list[HeatBalance] = list(history or [])

    @property
    def temperature(self) -> float:
        """C: the temperature of the next cycle (T_supply before the first)."""
        return self._next if self.history else self.model.supply_temperature

    @property
    def converged(self) -> bool:
        """The last cycle's closure is within the tolerance."""
        return bool(self.history) and self.history[-1].closure <= self.tolerance

    def record(self, balance: HeatBalance) -> float:
        """Add a cycle's balance; returns the temperature of the next cycle [C].

        Raises:
            ThermalError: the balance needs a temperature above ``model.temperature_limit``.
        """
        self.history.append(balance)
        self._next = self._update()
        return self._next

    def _update(self) -> float:
        last = self.history[-1]
        if self.converged:
            return last.temperature
        limit = self.model.temperature_limit
        if last.residual > 0 and last.temperature >= limit:
            raise ThermalError(
                f"the heat balance needs a film temperature above {limit:.1f} C (the limit of "
                f"the oil's viscosity data): at {last.temperature:.1f} C the side flow "
                f"carries {last.heat_carried:.4g} W of the {last.heat_to_oil:.4g} W into the "
                "oil"
            )
        supply = self.model.supply_temperature
        low = max([b.temperature for b in self.history if b.residual > 0], default=supply)
        high = min([b.temperature for b in self.history if b.residual < 0], default=None)
        upper = limit if high is None else high

        def inside(t: float) -> bool:
            return low < t < upper if high is not None else low < t

        candidates = []
        if len(self.history) >= 2:
            before = self.history[-2]
            if before.residual != last.residual and before.temperature != last.temperature:
                slope = (last.residual - before.residual) / (last.temperature - before.temperature)
                candidates.append(last.temperature - last.residual / slope)
        candidates.append(self.model.fixed_point(last))
        for candidate in candidates:
            if math.isfinite(candidate) and inside(candidate):
                return min(candidate, limit)
        if high is not None:
            return 0.5 * (low + high)
        return limit  # every cycle so far below the root, every step beyond the limit: try the limit

    def propose(self, temperature: float) -> None:
        """Run the next cycle at ``temperature`` [C] instead of this iteration's choice (the cycle map's
        extrapolation, solver.study.periodic), kept within (T_supply, temperature_limit]; nothing once
        converged (the temperature is kept). The balances recorded stay the secant's data."""
        if self.history and not self.converged and math.isfinite(temperature):
            low, high = self.model.supply_temperature, self.model.temperature_limit
            self._next = min(max(temperature, low + 1e-6 * (high - low)), high)

    def state(self) -> list[dict[str, float]]:
        """The history as plain data (a checkpoint's JSON); ``from_state`` rebuilds the iteration."""
        return [dataclasses.asdict(b) for b in self.history]

    @classmethod
    def from_state(
        cls, model: ThermalModel, tolerance: float, state: list[dict[str, float]]
    ) -> EffectiveTemperature:
        """The iteration after the cycles of ``state`` (from ``state()``): the same next temperature."""
        iteration = cls(model, tolerance)
        for values in state:
            iteration.record(HeatBalance(**values))
        return iteration
