"""The project's exceptions.

``InputError`` is bad input from a user (CLI argument, case file, data file): ``str(err)`` is the
whole one-line message that the CLI prints, and the CLI exits with status 2 without a traceback.
"""


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
