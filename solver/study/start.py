"""The start's cycles on a coarser film (``solver.start_mesh_size``): a cheaper model's periodic state.

A run from the centred pin in a full film spends its first cycles carrying the start to the periodic
state: the oil the film holds, the pin's place under the loaded strokes, the bushing's deformation.
With ``solver.start_mesh_size`` the run first integrates the same case on a film of that (larger)
element size until its min h_min is periodic (the case's ``periodic_tolerance``, ``max_cycles`` and
``periodic_acceleration``; its friction is left to the case's film, whose test has it), then
maps that run's end state onto the case's film and integrates the case's film from there: the
mechanism's coordinates and velocities as they are, the film's committed history (film fraction,
deformation) interpolated node by node (solver.film.model.Film.state_from). The periodic test then
counts and compares the case's own cycles only (at least two), so the answer is the case's film's
periodic state; the coarse film decides only where the search starts.

The start's cycles checkpoint in ``results/start/`` (a rerun resumes them there); once the case's film
has written its own checkpoint a rerun resumes that and skips the start. Serial (one rank per case).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import shutil
from pathlib import Path

from solver.errors import InputError
from solver.study import cycles, io

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class StartRecord:
    """What the start's cycles leave for the results: their element size / R, their count, whether
    they reached their periodic state, and their per-cycle histories (solver.study.cycles)."""

    mesh_size: float
    cycles: int
    periodic: bool
    history: dict[str, list[float]]


def coarser_case(case):
    """The case with the start's film: ``solver.mesh_size = start_mesh_size``, no start of its own and
    no friction test (its min h_min's test decides: the case's film tests its own friction)."""
    solver = dataclasses.replace(
        case.solver,
        mesh_size=case.solver.start_mesh_size,
        start_mesh_size=None,
        periodic_friction_tolerance=None,
    )
    return dataclasses.replace(case, solver=solver)


def start_from_coarser_film(run, out_dir: Path, make_run, fingerprint, progress: bool, resume: bool):
    """Integrate ``run``'s case on the coarser film until periodic and make its end state ``run``'s start
    (module docstring): ``run.initial`` (time, coordinates, velocities), the film's committed history
    mapped onto ``run``'s film, the effective temperature's iteration. ``make_run(case)`` builds a
    solver.study.simulation.Run; ``fingerprint(case)`` its checkpoint's fingerprint. Returns the
    StartRecord (``run.start``)."""
    case, comm = run.case, run.comm
    if comm.size > 1:
        raise InputError(
            f"solver.start_mesh_size = {case.solver.start_mesh_size:g} maps the film between meshes on one "
            f"rank (allowed: one rank per case, e.g. the batch command; got {comm.size} ranks)"
        )
    coarse_case = coarser_case(case)
    coarse = make_run(coarse_case)
    coarse.started = run.started
    directory = out_dir / "start"
    directory.mkdir(parents=True, exist_ok=True)
    try:
        log.info(
            "start: the case on a film of %.3g R (the case's: %.3g R) until periodic",
            coarse.model.mesh_spec.element_size,
            run.model.mesh_spec.element_size,
        )
        _, count, periodic = cycles.run_cycles(coarse, directory, fingerprint(coarse_case), progress, resume)
        end = coarse.next_start
        if run.model is not None and coarse.model is not None and end.film:
            for time_s, state in end.film:
                run.model.commit_history(run.model.state_from(coarse.model, state), time_s)
            run.model.start_from(run.model.state_from(coarse.model, end.film[-1][1]))
        if coarse.oil.thermal is not None:
            run.oil.resume(coarse.oil.thermal.state())
        run.initial = end
        run.earlier_wall_time += coarse.earlier_wall_time
        run.start = StartRecord(case.solver.start_mesh_size, count, periodic, dict(coarse.cycle_history))
        write_record(directory, run.start)
        log.info(
            "start: %d cycles on the coarser film (periodic: %s); the case's film goes on from their end",
            count,
            "yes" if periodic else "no",
        )
        return run.start
    finally:
        if coarse.model is not None:
            coarse.model.close()


def write_record(directory: Path, record: StartRecord) -> None:
    """``start.json`` in the start's directory (a run resumed on the case's film reads it back)."""
    text = json.dumps(dataclasses.asdict(record), default=float)
    temporary = directory / "start.json.tmp"
    temporary.write_text(text)
    temporary.replace(directory / "start.json")


def read_record(out_dir: Path) -> StartRecord | None:
    """The StartRecord of the run in ``out_dir`` (None: none written)."""
    path = out_dir / "start" / "start.json"
    if not path.is_file():
        return None
    return StartRecord(**json.loads(path.read_text()))


def start_checkpoint_done(out_dir: Path, fingerprint: str, resume: bool) -> bool:
    """Whether the case's film has a checkpoint to resume (then the start's cycles are skipped)."""
    return resume and io.read_checkpoint(out_dir / "checkpoint.npz", fingerprint) is not None


def remove_start(out_dir: Path) -> None:
    """The start's checkpoint directory, after the run has finished."""
    shutil.rmtree(out_dir / "start", ignore_errors=True)
