"""The project's exceptions, and the reading of the user's input files, which raise them.

``InputError`` is bad input from a user (CLI argument, case file, data file): ``str(err)`` is the
whole one-line message that the CLI prints, and the CLI exits with status 2 without a traceback.
Every input file (case, sweep, pressure and speed traces) is read through ``read_text_file`` or
``read_toml_file``: a missing, unreadable, binary or non-UTF-8 file is such an error, naming the file.
"""

from __future__ import annotations

import tomllib
from pathlib import Path


class InputError(ValueError):
    """Bad input; ``str(err)`` is the complete one-line message shown to the user."""


def out_of_range(name: str, value: object, allowed: str) -> InputError:
    """The standard message for a value outside its allowed range."""
    return InputError(f"{name} = {value} is out of range (allowed: {allowed})")


class FilmNotConverged(RuntimeError):
    """The film (Reynolds VI) solve failed; carries PETSc's converged reason."""

    def __init__(self, message: str, reason: int, iterations: int):
        super().__init__(f"{message} (SNES converged reason {reason}, {iterations} iterations)")
        self.reason = reason
        self.iterations = iterations


def read_text_file(path: str | Path, what: str) -> str:
    """The text of an input file, decoded as UTF-8 whatever the locale.

    Args:
        path: the file.
        what: what the file is, for the message (e.g. ``"case file"``, ``"gas.pressure_file"``).

    Raises:
        InputError: one line naming ``what`` and the file: not found, unreadable, or not UTF-8 text.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{what} = {str(path)!r}: file not found") from None
    except OSError as err:
        raise InputError(f"{what} = {str(path)!r}: cannot read ({err.strerror})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise InputError(
            f"{what} = {str(path)!r}: not a UTF-8 text file (invalid byte at offset {err.start})"
        ) from None
    if "\x00" in text:
        raise InputError(f"{what} = {str(path)!r}: not a text file (it contains NUL bytes)")
    return text.removeprefix("\ufeff")  # a byte-order mark some editors write


def read_toml_file(path: str | Path, what: str) -> dict:
    """The table of a TOML input file; InputError naming the file as in ``read_text_file`` or for bad TOML."""
    text = read_text_file(path, what)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{what} = {str(path)!r}: invalid TOML: {err}") from None
