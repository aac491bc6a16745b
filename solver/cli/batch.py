"""``python3 -m solver batch PATH...``: many operating points across the MPI ranks.

PATH is a case directory (with ``case.toml``), a directory of case directories, or a sweep file
(solver.study.sweep). Run it under ``mpirun -n N`` (or ``srun``); see solver.study.batch for the scheduling,
resume and failure rules and solver.study.summary for the summary. Exit status: 0 when every case is
complete (run now or finished before), 1 when a case failed (or, with ``--summary-only``, has not
run), 2 for bad input (a bad PATH or sweep file; a bad case is a failed case, not bad input), 130 when
interrupted (Ctrl-C; SIGTERM, which ``mpirun`` sends every rank when it is interrupted): one line on
world rank 0, ``batch_status.json`` written, finished cases and checkpoints kept (solver.cli.interrupts).

This module imports nothing heavy at import time (the CLI imports it to build its parser).
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from solver.cli.interrupts import interrupted, sigterm_interrupts
from solver.errors import InputError
from solver.study import batch

METRIC_CHOICES = ("h_min_min", "p_max_max", "F_asperity_max", "friction_power_mean", "run_time")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the ``batch`` command."""
    parser.add_argument(
        "paths",
        nargs="+",
        metavar="PATH",
        help="case directory, directory of case directories, or sweep file (TOML with [sweep])",
    )
    parser.add_argument(
        "--ranks-per-case",
        type=int,
        default=1,
        metavar="K",
        help="MPI ranks per case (the world is split into groups of K; default 1)",
    )
    parser.add_argument(
        "--schedule",
        choices=("dynamic", "static"),
        default="dynamic",
        help="dynamic: groups take the next case when free (default); static: round robin",
    )
    parser.add_argument(
        "--cases-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="where sweep files write their case directories (default: [sweep] cases_dir, "
        "else a directory named after the sweep file, beside it)",
    )
    parser.add_argument(
        "--output",
        type=Path,
        default=None,
        metavar="DIR",
        help="batch directory for batch_status.json, summary.nc and the plot (default: the "
        "sweep's cases directory, else the common parent of the case directories)",
    )
    parser.add_argument("--force", action="store_true", help="run finished cases again")
    parser.add_argument(
        "--shard",
        default=None,
        metavar="I/N",
        help="run only shard I of N (cases I, I+N, ...; 0 <= I < N), e.g. one Slurm "
        "array task; writes batch_status.shard-I-of-N.json and no summary",
    )
    parser.add_argument(
        "--summary-only",
        action="store_true",
        help="run nothing: write batch_status.json and the summary from the cases' files "
        "(the final step after sharded runs)",
    )
    parser.add_argument("--no-summary", action="store_true", help="do not write the summary")
    parser.add_argument(
        "--plot-metric",
        choices=METRIC_CHOICES,
        default="h_min_min",
        help="metric of summary_<metric>.png (default h_min_min)",
    )
    parser.add_argument(
        "--list",
        action="store_true",
        help="expand sweep files, list the cases and whether they are finished, run nothing",
    )


def parse_shard(text: str | None) -> tuple[int, int] | None:
    """``"3/8"`` -> ``(3, 8)``."""
    if text is None:
        return None
    try:
        index, count = (int(part) for part in text.split("/"))
    except ValueError:
        raise InputError(f"--shard = {text!r} has the wrong form (expected I/N, e.g. 0/4)") from None
    if not (count >= 1 and 0 <= index < count):
        raise InputError(f"--shard = {text!r} is out of range (allowed: I/N with 0 <= I < N)")
    return index, count


class _RankPrefix(logging.Filter):
    def __init__(self, rank: int):
        super().__init__()
        self.rank = rank

    def filter(self, record: logging.LogRecord) -> bool:
        record.world_rank = self.rank
        return True


def _log_other_ranks(world) -> None:
    """Batch progress of every rank (the CLI's handler shows world rank 0 only)."""
    logger = logging.getLogger("solver.study.batch")
    logger.handlers[:] = [h for h in logger.handlers if not getattr(h, "_batch_rank_handler", False)]
    if world.rank == 0:
        return
    handler = logging.StreamHandler(sys.stderr)
    handler._batch_rank_handler = True  # type: ignore[attr-defined]
    handler.addFilter(_RankPrefix(world.rank))
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s[rank %(world_rank)d]: %(message)s"))
    logger.addHandler(handler)


def describe_interruption(err: BaseException, output: Path) -> str:
    """The line of an interrupted batch (world rank 0): where its case stopped, the counts, the status
    file, and that a rerun resumes."""
    if not isinstance(err, batch.BatchInterrupted):  # after the cases: writing the summary
        return f"batch in {output}: while writing the summary; rerun the same command to write it"
    records = err.records
    counts = {state: sum(r["status"] == state for r in records) for state in batch.STATES}
    finished = counts["complete"] + counts["skipped"]
    text = f"batch: {finished} of {len(records)} case(s) finished"
    if counts["failed"] + counts["invalid"]:
        text += f", {counts['failed'] + counts['invalid']} failed"
    if counts["interrupted"]:
        text += f", {counts['interrupted']} interrupted or not run"
    if err.record is not None:  # this rank's own case
        text += f" ({err.record['error'].removeprefix('interrupted: ')})"
    text += f"; {err.status_file} written" if err.status_file else "; no batch_status.json written"
    return text + "; rerun the same command to resume"


def run(args: argparse.Namespace, comm) -> int:
    """Run the batch on ``comm`` (the world); the exit status (same on every rank)."""
    shard = parse_shard(args.shard)
    if args.summary_only and (args.shard or args.list):
        raise InputError("--summary-only runs nothing: it cannot be combined with --shard or --list")
    plan = batch.discover_collective(comm, args.paths, cases_dir=args.cases_dir, output=args.output)

    if args.list or args.summary_only:
        status = 0
        if comm.rank == 0:
            if args.list:
                cases = plan.shard(*shard).cases if shard else plan.cases
                for case in cases:
                    state = (
                        "finished"
                        if batch.is_finished(case)
                        else ((batch.read_case_status(case) or {}).get("status", "pending"))
                    )
                    state = "pending" if state in ("complete", "skipped") else state
                    print(f"{state:9s} {case}")
                print(f"{len(cases)} case(s); batch directory {plan.output}", file=sys.stderr)
            else:
                result = batch.collect(plan, plot_metric=args.plot_metric, summary=not args.no_summary)
                status = result.exit_status
        return comm.bcast(status, root=0)

    _log_other_ranks(comm)
    try:
        with sigterm_interrupts():
            result = batch.run_batch(
                plan,
                comm,
                ranks_per_case=args.ranks_per_case,
                schedule=args.schedule,
                force=args.force,
                shard=shard,
                summary=not args.no_summary,
                plot_metric=args.plot_metric,
            )
    except KeyboardInterrupt as err:
        return interrupted(comm, describe_interruption(err, plan.output))
    if comm.rank == 0:
        failed = [r for r in result.records if r["status"] not in batch.PASSED]
        for record in failed:
            print(f"{record['status']}: {record['case']}: {record['error']}", file=sys.stderr)
    return result.exit_status
