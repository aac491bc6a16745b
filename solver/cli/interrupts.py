"""Interruptions of the long commands (``run``, ``batch``): one line, what finished is kept, exit 130.

Ctrl-C raises KeyboardInterrupt in Python already. SIGTERM is turned into one while a command runs
(:func:`sigterm_interrupts`): Open MPI's ``mpirun``, when it is interrupted (Ctrl-C), sends SIGTERM to
every rank and SIGKILL a second later (``odls_base_sigkill_timeout``), and batch systems send it before
they kill a job. The commands catch the interruption, write what they must (checkpoints are already
on disk; ``batch`` writes ``batch_status.json``) and end with :func:`interrupted`.

The exit status is 130 (128 + SIGINT, the shell's convention). Under MPI the process ends at once with
``os._exit(130)`` after flushing its streams: ``python3 -m mpi4py`` turns a non-zero exit status into
``MPI_Abort``, whose many lines would bury the one that says where the run stopped, and ``mpirun`` is
tearing the job down anyway (its own exit status is then 1, whatever the ranks return). The other ranks
wait a few seconds first: ``mpirun`` kills every rank as soon as one ends, and rank 0 must write the
batch's status and the line.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time

EXIT_INTERRUPTED = 130
LINGER_SECONDS = 5.0  # ranks other than 0, under MPI, before they end (see interrupted)


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


@contextlib.contextmanager
def sigterm_interrupts():
    """SIGTERM and SIGINT raise KeyboardInterrupt meanwhile (the main thread only; elsewhere nothing
    changes). SIGINT is set too: a process started in the background by a shell script inherits it
    ignored, and then ``kill -INT`` would not reach Python's handler (the libraries may reset it to the
    default action, which ends the process without the line)."""
    try:
        previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    except ValueError:  # not the main thread
        yield
        return
    previous_int = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
        signal.signal(signal.SIGINT, previous_int)


def interrupted(world, line: str) -> int:
    """Print ``interrupted: <line>`` (world rank 0) and return 130; under MPI, exit with 130 here."""
    if world.rank == 0:
        print(f"interrupted: {line}", file=sys.stderr)
    under_mpi = world.size > 1 or "mpi4py.run" in sys.modules
    if under_mpi:
        sys.stdout.flush()
        sys.stderr.flush()
        if world.rank != 0:
            # mpirun kills every rank at once when one of them ends: rank 0 could be killed while it
            # writes batch_status.json and its line. The others leave that to rank 0's end (or to
            # mpirun's own kill after its timeout).
            time.sleep(LINGER_SECONDS)
        os._exit(EXIT_INTERRUPTED)
    return EXIT_INTERRUPTED
