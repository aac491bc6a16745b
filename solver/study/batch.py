"""Batch runs: many operating points across the ranks of a communicator.

The batch layer is the only place besides solver.cli that sees the world communicator: it splits it
into groups of ``ranks_per_case`` ranks (``world.Split``; when the world size is not a multiple, the
last group takes the remainder) and every case runs on its group's communicator
(solver.study.simulation.run_case), so a large case can be distributed while many small ones run side by
side.

Scheduling is dynamic by default: a shared counter in an MPI one-sided window on world rank 0
(``MPI.Win.Allocate`` + atomic ``Fetch_and_op``) hands out the next case index to whichever group
asks first, so a long case does not hold up the others and world rank 0 runs cases too (no idle
master). ``schedule="static"`` gives group g the cases g, g + G, g + 2G, ... instead (for MPI
libraries without working passive-target one-sided communication).

Per case, on every rank of its group:

- a finished case is skipped: ``results/results.nc`` opens with xarray and has ``status =
  "complete"``, and the case's ``results/case_status.json`` (if any) records a complete run of the
  same ``case.toml`` (SHA-256), so editing a case makes it run again;
- otherwise the case runs; an exception is caught on every rank of the group (the ranks agree with
  an allgather), recorded, and the group goes on with the next case (``InputError`` -> ``invalid``,
  anything else -> ``failed``, with the message and the traceback);
- rank 0 of the group writes ``results/case_status.json`` (status, error, wall time, ranks, host,
  metrics). Each case has exactly one group, so no two ranks ever write the same file.

Each record says whether the case ran in this invocation (``ran_this_invocation``; a case finished
before is ``skipped`` in the records and ``complete`` in the summary).

At the end world rank 0 gathers the records and writes ``<output>/batch_status.json`` and the summary
(solver.study.summary: ``summary.nc`` and ``summary_<metric>.png``). A shard (``shard=(i, n)``: the cases
i, i + n, ... of the list, for Slurm job arrays) writes ``batch_status.shard-<i>-of-<n>.json`` and no
summary; :func:`collect` makes the status and the summary of the whole batch afterwards from the
per-case files. Every file is written under a temporary name and renamed into place.

Results files themselves are written by run_case (atomically, on rank 0 of the case communicator).

Interruptions (KeyboardInterrupt on a rank: Ctrl-C, or the SIGTERM that ``mpirun`` sends every rank
when it is interrupted, which the command line turns into one; ``mpirun`` kills the ranks 1 s later):
no collective call is made any more (the other ranks may be anywhere). Rank 0 of an interrupted case's
group writes its ``case_status.json`` (status ``interrupted``, where it stopped, the checkpoint kept),
and world rank 0 writes ``batch_status.json`` at once from its own records and the cases' files
(finished cases complete; the others ``interrupted``, a rerun runs or resumes them), no summary;
:func:`run_batch` then raises :class:`BatchInterrupted`. The wait for the other groups at the end
polls a non-blocking barrier, so that a rank that has finished its cases still sees the interruption.
"""

from __future__ import annotations

import dataclasses
import datetime
import hashlib
import json
import logging
import math
import os
import socket
import time
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from solver import __version__
from solver.errors import InputError
from solver.study import io
from solver.study import summary as summaries
from solver.study import sweep as sweeps
from solver.study.cycles import RunInterrupted
from solver.study.results import is_complete
from solver.study.simulation import run_case

log = logging.getLogger(__name__)

CASE_STATUS = "case_status.json"
BATCH_STATUS = "batch_status.json"
# missing: not run (collect only); interrupted: not finished when the batch was interrupted
STATES = ("complete", "skipped", "failed", "invalid", "missing", "interrupted")
PASSED = ("complete", "skipped")

Runner = Callable[[Path, Any], Any]


@dataclasses.dataclass(frozen=True)
class BatchPlan:
    """What a batch runs.

    Attributes:
        cases: the case directories, in order (their names are unique).
        output: the batch directory (batch_status.json, summary.nc, the summary plot).
        parameters: the keys varied by the sweep files, in order (first in the summary).
    """

    cases: tuple[Path, ...]
    output: Path
    parameters: tuple[str, ...] = ()

    def shard(self, index: int, count: int) -> BatchPlan:
        """The cases index, index + count, ... (disjoint shards that together cover the plan)."""
        return dataclasses.replace(self, cases=self.cases[index::count])


# -- discovery ------------------------------------------------------------------------------------


def discover(
    paths: Sequence[str | Path], *, cases_dir: str | Path | None = None, output: str | Path | None = None
) -> BatchPlan:
    """Case directories from PATHs: case directories, directories of case directories, sweep files.

    A sweep file (a TOML file with a ``[sweep]`` table) is expanded (solver.study.sweep; this writes the
    case directories, so call it on one rank). A directory with ``case.toml`` is one case; a
    directory without one stands for its sub-directories that have one (sorted by name; if it is the
    cases directory of a sweep, the keys of its ``sweep.json`` come first in the summary).

    Args:
        paths: the PATH arguments.
        cases_dir: where sweep files put their case directories (default: per sweep file).
        output: the batch directory (default: the cases directory of a single sweep, else the
            common parent directory of the cases).

    Raises:
        InputError: a PATH does not exist or holds no case, a case TOML file instead of a
            directory, a bad sweep file, or two cases with the same directory name.
    """
    if not paths:
        raise InputError("no PATH given (case directories or sweep files)")
    cases: list[Path] = []
    parameters: list[str] = []
    sweep_dirs: list[Path] = []
    for raw in paths:
        path = Path(raw)
        if path.is_file():
            if sweeps.is_sweep_file(path):
                sweep = sweeps.load_sweep(path, cases_dir=cases_dir)
                cases += sweeps.expand(sweep)
                parameters += [key for key in sweep.keys if key not in parameters]
                sweep_dirs.append(sweep.cases_dir)
            elif path.suffix == ".toml":
                raise InputError(
                    f"{raw}: a TOML file without a [sweep] table; batch takes case directories "
                    f"(with case.toml) or sweep files"
                )
            else:
                raise InputError(
                    f"{raw}: not a case directory or a sweep file (to run every case directory "
                    f"in a directory, give the directory)"
                )
        elif path.is_dir():
            if (path / "case.toml").is_file():
                cases.append(path.resolve())
            else:
                found = sorted(p.parent.resolve() for p in path.glob("*/case.toml"))
                if not found:
                    raise InputError(f"{raw}: no case.toml in the directory or in its sub-directories")
                cases += found
                try:  # the cases directory of a sweep: its varied keys come first in the summary
                    keys = json.loads((path / "sweep.json").read_text())["parameters"]
                    parameters += [key for key in keys if isinstance(key, str) and key not in parameters]
                except (OSError, ValueError, KeyError, TypeError):
                    pass
        else:
            raise InputError(f"{raw}: no such file or directory")
    unique: dict[Path, None] = dict.fromkeys(cases)  # keeps the first occurrence
    names: dict[str, Path] = {}
    for case in unique:
        if case.name in names:
            raise InputError(
                f"two cases are both named {case.name}: {names[case.name]} and {case} "
                f"(case names, the directory names, must be unique in a batch)"
            )
        names[case.name] = case
    if output is not None:
        out = Path(output).resolve()
    elif len(sweep_dirs) == 1 and len(paths) == 1:
        out = sweep_dirs[0]
    else:
        out = Path(os.path.commonpath([str(case.parent) for case in unique]))
    return BatchPlan(cases=tuple(unique), output=out, parameters=tuple(parameters))


def discover_collective(world, paths: Sequence[str | Path], **kwargs) -> BatchPlan:
    """:func:`discover` on world rank 0, the plan (or the InputError) broadcast to every rank."""
    outcome: tuple[str, Any] | None = None
    if world.rank == 0:
        try:
            outcome = ("ok", discover(paths, **kwargs))
        except InputError as err:
            outcome = ("error", str(err))
        except OSError as err:  # e.g. a cases directory that cannot be written: bad input, on every rank
            outcome = ("error", f"{err.filename or ''}: {err.strerror or err}".lstrip(": "))
    kind, value = world.bcast(outcome, root=0)
    if kind == "error":
        raise InputError(value)
    return value


# -- per-case state ---------------------------------------------------------------------------------


def case_toml_sha256(case_dir: Path) -> str | None:
    """SHA-256 of the case's case.toml (None if unreadable)."""
    try:
        return hashlib.sha256((Path(case_dir) / "case.toml").read_bytes()).hexdigest()
    except OSError:
        return None


def results_complete(path: Path) -> bool:
    """True for a results file of a finished run (the data contract's test, solver.study.results)."""
    return is_complete(path)


def read_case_status(case_dir: Path) -> dict | None:
    """The case's ``results/case_status.json`` (None if absent or unreadable)."""
    try:
        return json.loads((Path(case_dir) / "results" / CASE_STATUS).read_text())
    except (OSError, ValueError):
        return None


def is_finished(case_dir: Path) -> bool:
    """A valid results file for the current case.toml (see the module docstring)."""
    case_dir = Path(case_dir)
    if not results_complete(case_dir / "results" / "results.nc"):
        return False
    status = read_case_status(case_dir)
    if status is None:  # results from `solver run`: trust them
        return True
    return status.get("status") in PASSED and status.get("case_toml_sha256") == case_toml_sha256(case_dir)


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def _metrics(summary: Any) -> dict[str, Any]:
    out = {}
    for name in (
        "h_min_min",
        "p_max_max",
        "F_asperity_max",
        "friction_power_mean",
        "cycles",
        "periodic",
        "wall_time",
        "film_temperature",
        "film_viscosity",
        "thermal_closure",
        "heat_generated",
        "heat_to_oil",
        "heat_carried",
        "big_end_h_min_min",
        "big_end_p_max_max",
        "big_end_F_asperity_max",
        "big_end_friction_power_mean",
        "pin_boss_h_min_min",
        "pin_boss_p_max_max",
        "pin_boss_friction_power_mean",
        "pin_speed_mean",
    ):
        value = getattr(summary, name, None)
        if isinstance(value, (bool, np.bool_)):
            out[name] = bool(value)
        elif isinstance(value, (int, float, np.integer, np.floating)):
            value = value.item() if hasattr(value, "item") else value
            out[name] = value if math.isfinite(float(value)) else None
    return out


def _default_runner(case_dir: Path, comm) -> Any:
    return run_case(case_dir, comm, progress=False)


def run_one(case_dir: Path, group, *, runner: Runner | None = None, force: bool = False) -> dict | None:
    """Run (or skip) one case on the group's communicator; the record on group rank 0, else None.

    Collective on ``group``. Exceptions (``Exception``, not ``KeyboardInterrupt``) of the case are
    caught on every rank and recorded; group rank 0 writes ``results/case_status.json``.
    """
    case_dir = Path(case_dir)
    runner = runner or _default_runner
    record: dict[str, Any] = {"case": case_dir.name, "directory": str(case_dir)}
    skip = group.bcast(None if group.rank else (not force and is_finished(case_dir)), root=0)
    if skip:
        if group.rank == 0:
            previous = read_case_status(case_dir) or {}
            record.update(
                status="skipped",
                error="",
                finished=previous.get("finished", ""),
                wall_time_s=previous.get("wall_time_s"),
                ran_this_invocation=False,
            )
            return record
        return None

    sha = case_toml_sha256(case_dir) if group.rank == 0 else None
    started, start = _now(), time.perf_counter()
    error: tuple[str, str, str] | None = None
    summary = None
    try:
        summary = runner(case_dir, group)
    except KeyboardInterrupt as err:  # the batch stops: record where (no collective call any more)
        checkpoint = case_dir / "results" / "checkpoint.npz"
        if group.rank == 0:
            record.update(
                status="interrupted",
                error=f"interrupted: {interruption_text(err, case_dir.name, checkpoint)}",
                started=started,
                finished=_now(),
                wall_time_s=time.perf_counter() - start,
                case_toml_sha256=sha,
                ranks=group.size,
                host=socket.gethostname(),
                solver_version=__version__,
                ran_this_invocation=True,
            )
            _write_case_status(case_dir, record)
        raise BatchInterrupted(record if group.rank == 0 else None) from None
    except InputError as err:
        error = ("invalid", str(err), traceback.format_exc())
    except Exception as err:  # noqa: BLE001 - a failing case must not stop the batch
        error = ("failed", f"{type(err).__name__}: {err}", traceback.format_exc())
    wall = time.perf_counter() - start
    errors = group.allgather(error)  # a case fails if it failed on any rank of its group
    error = next((e for e in errors if e is not None), None)
    if group.rank != 0:
        return None
    record.update(
        status=error[0] if error else "complete",
        error=error[1] if error else "",
        started=started,
        finished=_now(),
        wall_time_s=wall,
        case_toml_sha256=sha,
        ranks=group.size,
        host=socket.gethostname(),
        solver_version=__version__,
        ran_this_invocation=True,
    )
    if error:
        record["traceback"] = error[2]
    elif summary is not None:
        record["metrics"] = _metrics(summary)
    _write_case_status(case_dir, record)
    return record


def interruption_text(err: BaseException, name: str, checkpoint: Path) -> str:
    """Where case ``name`` stopped (solver.study.cycles.RunInterrupted; else from its ``checkpoint``
    file) and what a rerun does."""
    if isinstance(err, RunInterrupted):
        if err.checkpoint is None:
            return f"{err}; a rerun starts it again"
        return f"{err}; a rerun resumes it after cycle {err.checkpoint_cycles}"
    cycles = io.checkpoint_cycles(checkpoint)
    text = f"case {name} outside its cycles (setting up, or writing its results)"
    if cycles:
        return f"{text}; a rerun resumes it after cycle {cycles} ({checkpoint})"
    return f"{text}; a rerun starts it again"


class BatchInterrupted(KeyboardInterrupt):
    """The batch was interrupted on this rank (a KeyboardInterrupt).

    Attributes:
        record: the record of the case this rank's group was running (group rank 0), or None.
        status_file: on world rank 0, the batch status written (None if it could not be).
        records: on world rank 0, the records of the status file.
    """

    def __init__(self, record: dict | None):
        super().__init__()
        self.record = record
        self.status_file: Path | None = None
        self.records: list[dict] = []

    def __str__(self) -> str:
        return self.record["error"] if self.record else "interrupted"


def _write_case_status(case_dir: Path, record: dict) -> None:
    results = case_dir / "results"
    try:
        results.mkdir(parents=True, exist_ok=True)
        io.write_json(results / CASE_STATUS, record)
    except OSError as err:  # a read-only or vanished case directory must not stop the batch
        log.error("case %s: cannot write %s (%s)", case_dir.name, CASE_STATUS, err)


# -- groups and scheduling ----------------------------------------------------------------------------


def split_groups(world, ranks_per_case: int):
    """(group communicator, group index, number of groups). Collective on ``world``.

    Ranks ``g k ... g k + k - 1`` form group g; the last group also takes the ``size mod k`` ranks
    left over.
    """
    if isinstance(ranks_per_case, bool) or not isinstance(ranks_per_case, int) or ranks_per_case < 1:
        raise InputError(f"--ranks-per-case = {ranks_per_case!r} is out of range (allowed: an integer >= 1)")
    if ranks_per_case > world.size:
        raise InputError(
            f"--ranks-per-case = {ranks_per_case} is out of range "
            f"(allowed: <= the number of MPI ranks, {world.size})"
        )
    n_groups = world.size // ranks_per_case
    color = min(world.rank // ranks_per_case, n_groups - 1)
    return world.Split(color=color, key=world.rank), color, n_groups


class DynamicCounter:
    """A shared counter on world rank 0 (MPI one-sided window); :meth:`next` is atomic.

    Creating and freeing it are collective on ``world``; :meth:`next` is called by one rank of a
    group and needs no action of rank 0 (passive target).
    """

    def __init__(self, world):
        self._MPI = MPI
        itemsize = MPI.INT64_T.Get_size()
        self.win = MPI.Win.Allocate(itemsize if world.rank == 0 else 0, itemsize, comm=world)
        if world.rank == 0:
            self.win.Lock(0, MPI.LOCK_EXCLUSIVE)
            self.win.Put([np.zeros(1, dtype=np.int64), MPI.INT64_T], 0)
            self.win.Unlock(0)
        world.Barrier()

    def next(self) -> int:
        MPI = self._MPI
        one, result = np.ones(1, dtype=np.int64), np.empty(1, dtype=np.int64)
        self.win.Lock(0, MPI.LOCK_SHARED)
        self.win.Fetch_and_op([one, MPI.INT64_T], [result, MPI.INT64_T], 0, 0, MPI.SUM)
        self.win.Unlock(0)
        return int(result[0])

    def free(self) -> None:
        self.win.Free()


class StaticCounter:
    """Group g takes g, g + G, g + 2G, ..."""

    def __init__(self, group_index: int, n_groups: int):
        self._next, self._step = group_index, n_groups

    def next(self) -> int:
        value, self._next = self._next, self._next + self._step
        return value

    def free(self) -> None:
        pass


# -- the batch -------------------------------------------------------------------------------------


@dataclasses.dataclass
class BatchResult:
    """Outcome of a batch (``records`` and ``files`` on world rank 0 only; ``exit_status`` everywhere)."""

    exit_status: int
    records: list[dict]
    files: list[Path]


def _counts(records: list[dict]) -> dict[str, int]:
    return {
        state: sum(r["status"] == state for r in records)
        for state in STATES
        if any(r["status"] == state for r in records) or state in ("complete", "failed")
    }


def _status_document(plan: BatchPlan, records: list[dict], info: dict) -> dict:
    return {
        "solver_version": __version__,
        **info,
        "output": str(plan.output),
        "n_cases": len(records),
        "counts": _counts(records),
        "all_passed": all(r["status"] in PASSED for r in records),
        "cases": records,
    }


def run_batch(
    plan: BatchPlan,
    world,
    *,
    ranks_per_case: int = 1,
    schedule: str = "dynamic",
    force: bool = False,
    runner: Runner | None = None,
    shard: tuple[int, int] | None = None,
    summary: bool = True,
    plot_metric: str = "h_min_min",
) -> BatchResult:
    """Run every case of the plan over the ranks of ``world``. Collective on ``world``.

    Args:
        plan: the cases (from :func:`discover_collective`).
        world: the communicator of the whole batch (MPI.COMM_WORLD from the CLI).
        ranks_per_case: ranks of each case's communicator.
        schedule: ``dynamic`` (shared counter) or ``static`` (round robin).
        force: run finished cases again.
        runner: ``runner(case_dir, comm)`` runs one case (default: solver.study.simulation.run_case).
        shard: ``(i, n)``: run only the i-th of n disjoint shards; no summary.
        summary: write the summary (world rank 0).
        plot_metric: the metric of the summary plot.

    Returns:
        The exit status (0: every case complete or skipped; 1: a case failed or the summary could
        not be written) on every rank; the records and written files on world rank 0.
    """
    if schedule not in ("dynamic", "static"):
        raise InputError(f"--schedule = {schedule!r} is out of range (allowed: 'dynamic', 'static')")
    if shard is not None:
        index, count = shard
        if not (isinstance(index, int) and isinstance(count, int) and count >= 1 and 0 <= index < count):
            raise InputError(f"--shard = {index}/{count} is out of range (allowed: I/N with 0 <= I < N)")
        plan = plan.shard(index, count)
    group, group_index, n_groups = split_groups(world, ranks_per_case)
    if world.rank == 0:
        log.info(
            "batch: %d case(s) on %d rank(s): %d group(s) of %d rank(s), %s schedule%s",
            len(plan.cases),
            world.size,
            n_groups,
            ranks_per_case,
            schedule,
            f", shard {shard[0]}/{shard[1]}" if shard else "",
        )
        if world.size % ranks_per_case:
            log.warning(
                "world size %d is not a multiple of --ranks-per-case %d: the last group has %d ranks",
                world.size,
                ranks_per_case,
                ranks_per_case + world.size % ranks_per_case,
            )
    started, start = _now(), time.perf_counter()
    counter = DynamicCounter(world) if schedule == "dynamic" else StaticCounter(group_index, n_groups)
    records: list[tuple[int, dict]] = []
    # No try/finally with collectives here: an error of the batch layer itself (not of a case) must
    # propagate so that `python3 -m mpi4py` aborts every rank instead of leaving them waiting.
    try:
        while True:
            index = group.bcast(counter.next() if group.rank == 0 else None, root=0)
            if index >= len(plan.cases):
                break
            record = run_one(plan.cases[index], group, runner=runner, force=force)
            if record is not None:
                record.update(group=group_index, world_rank=world.rank)
                records.append((index, record))
                _log_record(record, index, len(plan.cases))
        _wait_for_all(world)  # the counter lives until every group is done
    except KeyboardInterrupt as err:
        interrupted = err if isinstance(err, BatchInterrupted) else BatchInterrupted(None)
        if world.rank == 0:
            info = {
                "started": started,
                "finished": _now(),
                "wall_time_s": time.perf_counter() - start,
                "world_size": world.size,
                "ranks_per_case": ranks_per_case,
                "schedule": schedule,
                "shard": f"{shard[0]}/{shard[1]}" if shard else None,
                "interrupted": True,
            }
            own = dict(records)
            if interrupted.record is not None:
                own[plan.cases.index(Path(interrupted.record["directory"]))] = interrupted.record
            interrupted.records = _interrupted_records(plan, own, started)
            name = BATCH_STATUS if shard is None else f"batch_status.shard-{shard[0]}-of-{shard[1]}.json"
            try:
                plan.output.mkdir(parents=True, exist_ok=True)
                io.write_json(plan.output / name, _status_document(plan, interrupted.records, info))
                interrupted.status_file = plan.output / name
            except OSError as err:
                log.error("cannot write %s in %s: %s", name, plan.output, err)
        raise interrupted from None
    counter.free()
    group.Free()
    gathered = world.gather(records, root=0)
    wall = time.perf_counter() - start

    outcome: tuple[int, list[dict], list[Path]] = (0, [], [])
    if world.rank == 0:
        ordered = [record for _, record in sorted(item for part in gathered for item in part)]
        info = {
            "started": started,
            "finished": _now(),
            "wall_time_s": wall,
            "world_size": world.size,
            "ranks_per_case": ranks_per_case,
            "groups": n_groups,
            "schedule": schedule,
            "shard": f"{shard[0]}/{shard[1]}" if shard else None,
        }
        outcome = _finish(
            plan, ordered, info, shard=shard, summary=summary and shard is None, plot_metric=plot_metric
        )
    exit_status = world.bcast(outcome[0], root=0)
    return BatchResult(exit_status=exit_status, records=outcome[1], files=outcome[2])


def _wait_for_all(world) -> None:
    """A barrier that sees a KeyboardInterrupt meanwhile (a blocking one would not return to Python,
    and the signal's handler would wait for it for ever: the interrupted ranks never arrive)."""
    request = world.Ibarrier()
    while not request.Test():
        time.sleep(0.01)


def _interrupted_records(plan: BatchPlan, own: dict[int, dict], started: str) -> list[dict]:
    """World rank 0 after an interruption: its own records, else what the case files say (not
    collective, and quick: ``case_status.json`` alone, results files only without one). ``started``:
    this invocation's start (the time stamps of the case files tell what ran in it)."""
    records = []
    for index, case_dir in enumerate(plan.cases):
        if index in own:
            records.append(own[index])
            continue
        record: dict[str, Any] = {"case": case_dir.name, "directory": str(case_dir)}
        status = read_case_status(case_dir) or {}
        current = bool(status) and status.get("case_toml_sha256") == case_toml_sha256(case_dir)
        now = current and str(status.get("finished", "")) >= started  # recorded in this invocation
        if now or (current and status.get("status") == "complete"):  # or finished before it
            record.update({k: v for k, v in status.items() if k not in ("case", "directory", "traceback")})
            record.update(status=status["status"] if now else "skipped", ran_this_invocation=now)
            records.append(record)
            continue
        results = case_dir / "results" / "results.nc"
        if not status and results_complete(results):
            # finished in this invocation if written after its start (its rank may not have written
            # case_status.json yet when the interruption came)
            now = results.stat().st_mtime >= datetime.datetime.fromisoformat(started).timestamp()
            record.update(status="complete" if now else "skipped", error="", ran_this_invocation=now)
        else:
            cycles = io.checkpoint_cycles(case_dir / "results" / "checkpoint.npz")
            record.update(
                status="interrupted",
                error=(
                    f"interrupted: not finished; a rerun resumes it after cycle {cycles}"
                    if cycles
                    else "interrupted: not run before the interruption; a rerun runs it"
                ),
                ran_this_invocation=False,
            )
        records.append(record)
    return records


def _log_record(record: dict, index: int, total: int) -> None:
    name, status = record["case"], record["status"]
    if status == "skipped":
        log.info("[%d/%d] %s: finished before, skipped", index + 1, total, name)
    elif status == "complete":
        metrics = record.get("metrics", {})
        h = metrics.get("h_min_min")
        extra = f", h_min min {h * 1e6:.4g} um" if isinstance(h, float) else ""
        log.info(
            "[%d/%d] %s: complete in %.1f s on %d rank(s)%s",
            index + 1,
            total,
            name,
            record["wall_time_s"],
            record["ranks"],
            extra,
        )
    else:
        log.error("[%d/%d] %s: %s: %s", index + 1, total, name, status, record["error"])


def _finish(
    plan: BatchPlan, records: list[dict], info: dict, *, shard, summary: bool, plot_metric: str
) -> tuple[int, list[dict], list[Path]]:
    """World rank 0: status file, summary, exit status."""
    files: list[Path] = []
    exit_status = 0 if all(r["status"] in PASSED for r in records) else 1
    name = BATCH_STATUS if shard is None else f"batch_status.shard-{shard[0]}-of-{shard[1]}.json"
    try:
        plan.output.mkdir(parents=True, exist_ok=True)
        path = plan.output / name
        io.write_json(path, _status_document(plan, records, info))
        files.append(path)
    except OSError as err:
        log.error("cannot write %s in %s: %s", name, plan.output, err)
        exit_status = 1
    if summary:
        try:
            files += summaries.write_summary(
                records, plan.output, metric=plot_metric, parameters=plan.parameters
            )
        except Exception as err:  # noqa: BLE001 - the cases are done; report and fail the exit status
            log.error("summary failed: %s: %s", type(err).__name__, err)
            exit_status = 1
    counts = _counts(records)
    log.info(
        "batch: %s; %s",
        ", ".join(f"{n} {state}" for state, n in counts.items()),
        ", ".join(str(f) for f in files) or "no files written",
    )
    return exit_status, records, files


def collect(plan: BatchPlan, *, plot_metric: str = "h_min_min", summary: bool = True) -> BatchResult:
    """Status and summary of a whole batch from the per-case files, without running anything.

    For the final step after sharded runs (Slurm job arrays), or to redo the summary. Not collective:
    call it on one rank. A case is ``complete`` when it is finished (:func:`is_finished`), else it
    has the status recorded in its ``case_status.json``, else ``missing``.
    """
    records = []
    for case_dir in plan.cases:
        status = read_case_status(case_dir) or {}
        record = {"case": case_dir.name, "directory": str(case_dir), "ran_this_invocation": False}
        if is_finished(case_dir):
            record.update(status="complete", error="")
            for key in ("finished", "wall_time_s", "ranks", "host", "metrics"):
                if key in status:
                    record[key] = status[key]
        elif status.get("status") in ("failed", "invalid") and status.get(
            "case_toml_sha256"
        ) == case_toml_sha256(case_dir):
            record.update({k: v for k, v in status.items() if k not in record})
        else:
            record.update(status="missing", error="not run (or interrupted) since case.toml last changed")
        records.append(record)
    info = {"finished": _now(), "collected": True}
    exit_status, records, files = _finish(
        plan, records, info, shard=None, summary=summary, plot_metric=plot_metric
    )
    return BatchResult(exit_status=exit_status, records=records, files=files)


__all__ = [
    "BatchPlan",
    "BatchResult",
    "discover",
    "discover_collective",
    "run_batch",
    "run_one",
    "BatchInterrupted",
    "interruption_text",
    "collect",
    "split_groups",
    "is_finished",
    "results_complete",
    "DynamicCounter",
    "StaticCounter",
]
