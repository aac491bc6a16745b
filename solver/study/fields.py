"""ParaView fields of a coupled run's last cycle (finite-element film only).

The film is solved again at the chosen output states from the cycle's columns, as the run solved it: an
elastic bushing (or a JFO film) takes its history's rate from the states committed in the run
(``committed``, per output state), the last of them also its warm start.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from solver.errors import FilmNotConverged
from solver.study import io

log = logging.getLogger(__name__)


def write_fields(
    directory: Path,
    model,
    columns: dict[str, np.ndarray],
    committed: list,
    *,
    step_deg: float,
    field_step: float,
    field_angles,
) -> list[Path]:
    """The time series ``film_series.xdmf`` every ``field_step`` and single snapshots at
    ``field_angles`` (rad, as the case's ``solver.field_step_deg`` and ``solver.field_angles_deg``);
    returns the paths written. A state whose film cannot be solved again is left out with a warning
    (the results do not depend on the fields).

    Args:
        directory: results directory.
        model: the film model (its ``solve``, ``commit_history``, ``start_from``, ``fields_si``).
        columns: the last cycle's columns (crank_angle, time, ecc_x, ecc_y, ecc_rate_x, ecc_rate_y,
            omega_rel).
        committed: per output state of the cycle, the committed (time, history state) its history's
            rate was taken from, or None (no history, or quasi-static).
        step_deg: deg, the output step of the columns.
        field_step: rad, the series' step (0: none).
        field_angles: rad, the snapshots' crank angles.
    """
    from solver.film.types import Kinematics  # (numpy only)

    angles = columns["crank_angle"]

    def solve_at(k: int) -> bool:
        """The film at output k as in the run; False (with a warning) if it cannot be solved again."""
        kin = Kinematics(
            (float(columns["ecc_x"][k]), float(columns["ecc_y"][k])),
            (float(columns["ecc_rate_x"][k]), float(columns["ecc_rate_y"][k])),
            float(columns["omega_rel"][k]),
            0.0,
        )
        try:
            if k < len(committed) and committed[k] is not None:
                # elastic bushing: the deformation's rate from the states it was taken from in the run;
                # the last of them is also the warm start (one integrator step away)
                for time_s, state in committed[k]:
                    model.commit_history(state, time_s)
                model.start_from(committed[k][-1][1])
                model.solve(kin, float(columns["time"][k]))
            else:
                model.solve(kin)
        except FilmNotConverged as err:
            log.warning("ParaView fields at %.1f deg left out: %s", angles[k], err)
            return False
        return True

    paths = []
    field_step_deg = math.degrees(field_step)
    if field_step_deg > 0:
        every = max(1, int(round(field_step_deg / step_deg)))  # a multiple of the output step
        series = io.FilmSeries(directory, "film_series", model)
        try:
            for k in range(0, len(angles), every):
                if solve_at(k):
                    series.write(angles[k])
            paths.append(series.close())
        except BaseException:
            series.abort()
            raise
    for angle in field_angles:
        k = int(np.argmin(np.abs(angles - math.degrees(angle))))
        if solve_at(k):
            paths.append(io.write_film_fields(directory, f"film_{angles[k]:05.1f}deg", model))
    if paths:
        log.info(
            "ParaView fields: %s in %s (%s, metres)",
            ", ".join(path.name for path in paths),
            directory,
            "the half film z >= 0 of the symmetric film: mirror it about z = 0 for the whole width"
            if model.mesh_spec.half
            else "the whole width",
        )
    return paths
