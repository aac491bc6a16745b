"""The film's oil over a coupled run: its temperature and viscosity, iterated with the cycles.

With ``oil.thermal = "effective"`` cycle k runs at T_k, its heat balance (cycle means of
``dissipated_power`` and ``side_flow``) gives T_(k+1) (solver.study.thermal), and the joint's viscosity
is set to the oil's at T_(k+1) before the next cycle (:func:`set_film_temperature`). Isothermal runs keep
the case's temperature (NaN when the case gives a fixed viscosity) and viscosity.
"""

from __future__ import annotations

import dataclasses
import math

from solver.study.thermal import EffectiveTemperature, HeatBalance, ThermalModel, cycle_mean


class FilmOil:
    """The film's oil in the cycles run now: ``temperature`` [C], ``viscosity`` [Pa s], and with
    oil.thermal = "effective" the iteration that sets them (``thermal``; None when isothermal)."""

    def __init__(self, oil):
        self.oil = oil
        data = oil.data()
        self.temperature = oil.temperature if data is not None else math.nan
        self.viscosity = oil.viscosity
        self.thermal: EffectiveTemperature | None = None
        if oil.thermal == "effective":
            model = ThermalModel(data, oil.specific_heat, oil.heat_to_solids, oil.temperature)
            self.thermal = EffectiveTemperature(model, oil.thermal_tolerance)

    def resume(self, state: list[dict] | None) -> None:
        """Go on with the iteration of a checkpoint (EffectiveTemperature.state), if any."""
        if self.thermal is not None and state:
            thermal = self.thermal
            self.thermal = EffectiveTemperature.from_state(thermal.model, thermal.tolerance, state)

    def heat_balance(self, columns) -> HeatBalance:
        """The heat balance of a cycle (its columns) at the film temperature it ran at."""
        heat, flow = (
            cycle_mean(columns[name], columns["time"]) for name in ("dissipated_power", "side_flow")
        )
        return self.thermal.model.balance(self.temperature, heat, flow)

    def record(self, columns) -> dict[str, float]:
        """The film's oil and heat balance in the last cycle, its columns (solver.study.results.
        FILM_VARIABLES).

        Isothermal: the case's temperature (NaN with a fixed viscosity) and viscosity, the heat
        generated, and NaN for the balance's other terms and its closure.
        """
        nan, data = math.nan, self.oil.data()
        record = {
            "film_temperature": self.temperature,
            "film_viscosity": self.viscosity,
            "film_density": float(data.density(self.temperature)) if data is not None else nan,
            "heat_generated": cycle_mean(columns["dissipated_power"], columns["time"]),
            "side_flow_mean": cycle_mean(columns["side_flow"], columns["time"]),
            "heat_to_oil": nan,
            "heat_carried": nan,
            "thermal_closure": nan,
        }
        if self.thermal is not None and self.thermal.history:
            balance = self.thermal.history[-1]
            record.update(
                heat_to_oil=balance.heat_to_oil,
                heat_carried=balance.heat_carried,
                thermal_closure=balance.closure,
            )
        return record


def set_film_temperature(run, temperature: float) -> None:
    """The film's oil at ``temperature`` [C] from the next cycle on: the run's joint viscosity
    becomes the oil's there (oil.thermal = "effective"; the density enters the heat balance only).

    The joint takes the new viscosity in place (``set_viscosity``): a finite-element film keeps its
    forms, its history and its warm start (solver.film.model.Film.set_viscosity), with no rebuild and
    no compilation.

    ``run``: solver.study.simulation.Run (its joint and oil are updated).
    """
    oil = dataclasses.replace(run.case.oil, temperature=temperature)
    run.joint.set_viscosity(oil.viscosity)
    run.oil.temperature, run.oil.viscosity = temperature, oil.viscosity
