"""Command-line interface: ``python3 -m solver <command> ...``.

Each command lives in its own module with two functions, ``add_arguments(parser)`` and
``run(args, comm) -> int``; this module only dispatches. Bad input of any kind (argparse errors,
``InputError`` from validation) is reported as one line ``error: ...`` on stderr with exit status 2
and no traceback. ``MPI.COMM_WORLD`` appears here and in the batch layer only.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import re
import sys
from collections.abc import Sequence

from mpi4py import MPI

from solver import __version__
from solver.errors import FilmNotConverged, InputError

# command name -> (module, one-line help). Modules are imported lazily so that `--help` and
# argument errors do not pay for importing dolfinx.
COMMANDS: dict[str, tuple[str, str]] = {
    "bearing": (
        "solver.cli.bearing",
        "one journal bearing: load at given eccentricity, or equilibrium under a load",
    ),
    "stribeck": (
        "solver.cli.stribeck",
        "friction coefficient against speed at a fixed load (Stribeck curve)",
    ),
    "engine": ("solver.cli.engine", "the crank-rod-piston engine cycle with ideal joints"),
    "run": ("solver.cli.run", "one engine operating point with the lubricated small end (case directory)"),
    "batch": (
        "solver.cli.batch",
        "many operating points (case directories or a sweep file) across MPI ranks",
    ),
    "compare": ("solver.cli.compare", "finished runs side by side: a table and a plot over the crank angle"),
    "docs": (
        "solver.cli.docs",
        "write (or --check) the generated pages docs/case-reference.md and docs/results-reference.md",
    ),
}


#: a negative number, in scientific notation too (``-0.9e5``, ``-1E-3``, ``-.5``): argparse's own pattern
#: (Python 3.11: ``-1``, ``-0.5``) takes ``--cavitation-pressure -0.9e5`` for two flags
NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one-line InputErrors instead of usage + exit, and which reads a
    negative number in scientific notation as a value (no option of ours looks like a number)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str):  # noqa: D102 - argparse API
        raise InputError(f"{self.prog}: {message}")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="python3 -m solver", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log more (debug level)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, parser_class=_Parser)
    for name, (module_name, help_text) in COMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as err:  # a command not installed in this build
            if err.name != module_name:
                raise
            continue
        module.add_arguments(sub.add_parser(name, help=help_text, description=help_text))
    return parser


class _RankZeroFilter(logging.Filter):
    def __init__(self, rank: int):
        super().__init__()
        self.rank = rank

    def filter(self, record: logging.LogRecord) -> bool:
        return self.rank == 0


class _OursOrWarnings(logging.Filter):
    """Our own records at their level; other libraries' only from WARNING up.

    The forms' JIT compiles with distutils, which turns the root logger to INFO and logs every C
    compiler command line: not for a user's terminal.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        return (
            record.name == "solver" or record.name.startswith("solver.") or record.levelno >= logging.WARNING
        )


_HANDLER_TAG = "_tribo_handler"


def setup_logging(rank: int, verbose: bool) -> None:
    """Log to stderr on rank 0 only, each record once: our INFO, other libraries' warnings.

    The handler sits on the root logger, so that FFCx's ``logging.basicConfig()`` (at its import,
    later) finds a handler and adds none: a second root handler printed every line twice.
    """
    handler = logging.StreamHandler(sys.stderr)
    setattr(handler, _HANDLER_TAG, True)
    handler.addFilter(_RankZeroFilter(rank))
    handler.addFilter(_OursOrWarnings())
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    root.handlers[:] = [h for h in root.handlers if not getattr(h, _HANDLER_TAG, False)] + [handler]
    ours = logging.getLogger("solver")
    ours.handlers[:] = [h for h in ours.handlers if not getattr(h, _HANDLER_TAG, False)]
    ours.setLevel(logging.DEBUG if verbose else logging.INFO)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 ok, 1 failure, 2 bad input)."""
    world = MPI.COMM_WORLD
    try:
        args = _parser().parse_args(argv)
        setup_logging(world.rank, args.verbose)
        module = importlib.import_module(COMMANDS[args.command][0])
        return module.run(args, world)
    except InputError as err:
        if world.rank == 0:
            print(f"error: {err}", file=sys.stderr)
        return 2
    except FilmNotConverged as err:  # the film could not be solved at the state asked for
        if world.rank == 0:
            print(f"error: {err}", file=sys.stderr)
        return 1
