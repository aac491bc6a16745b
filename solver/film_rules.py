"""Which film choices go together: the one place where a film's compatibility rules are written.

A film is a cavitation law (Reynolds VI or JFO), a bushing (rigid, Winkler layer or FE eye), an inlet
(the max-gap line or none) with or without an oil supply, and the numerics it runs on. Some
combinations cannot work; ``check_film`` refuses them with one line that names the case key and the
command-line flag of each choice, so a case file and the ``bearing`` command get the same message.
``default_inlet`` is the inlet a user gets without asking: the max-gap line where the model allows it,
``none`` where it does not.

Plain Python, below solver.case in the import layers (pyproject.toml): the case loader calls it when
it reads a case, solver.film.spec.FilmSpec when a film is specified (the command line builds one
before any mesh or compliance), and the factory once more with the communicator's size.
"""

from __future__ import annotations

import math

from solver.errors import InputError

CAVITATION_LAWS = ("reynolds", "jfo")
BUSHINGS = ("none", "winkler", "fe")
INLETS = ("max-gap", "none")
TRANSPORTS = ("limited", "upwind")
CAVITATED_SHEARS = ("film-fraction", "full")

#: how a choice is named: case key, command-line flag
_CAVITATION = "oil.cavitation = {0!r} (--cavitation {0})"
_BUSHING = "small_end.elastic = {0!r} (--elastic {0})"
_INLET = "oil.inlet = {0!r} (--inlet {0})"
_SUPPLY = "an oil supply (oil.inlet = 'hole' or a groove; --hole-*, --groove-*, --circumferential-groove)"


def _choice(name: str, value: str, allowed: tuple[str, ...], key: str, flag: str) -> None:
    if value not in allowed:
        raise InputError(
            f"{key} = {value!r} ({flag} {value}) is out of range (allowed: {', '.join(map(repr, allowed))})"
        )


def check_film(
    *,
    cavitation: str = "reynolds",
    bushing: str = "none",
    inlet: str = "max-gap",
    supply: bool = False,
    cavitation_pressure: float = 0.0,
    degree: int = 1,
    transport: str = "limited",
    cavitated_shear: str = "film-fraction",
    ranks: int = 1,
    quasi_static: bool = False,
    sigmas: tuple[float, ...] = (),
) -> None:
    """Raise InputError (one line) unless the choices go together.

    Args:
        cavitation: "reynolds" or "jfo".
        bushing: "none" (rigid), "winkler" or "fe".
        inlet: "max-gap" or "none".
        supply: the film has an oil supply (a hole or a groove).
        cavitation_pressure: p_cav [Pa gauge].
        degree: the pressure's polynomial degree.
        transport: the JFO film fraction's transport, "limited" or "upwind".
        cavitated_shear: the JFO film's Couette shear in the cavitated zone, "film-fraction" or "full".
        ranks: the processes the film runs on.
        quasi_static: the film is solved without time (no history is ever committed): the max-gap inlet
            is then allowed with a history (its frame turns with the eccentricity, which a committed
            state could not follow).
        sigmas: the composite roughness of the roughness and of the contact model, when given [m].
    """
    _choice("cavitation", cavitation, CAVITATION_LAWS, "oil.cavitation", "--cavitation")
    _choice("bushing", bushing, BUSHINGS, "small_end.elastic", "--elastic")
    _choice("inlet", inlet, INLETS, "oil.inlet", "--inlet")
    _choice("transport", transport, TRANSPORTS, "solver.film_fraction_transport", "transport")
    _choice("cavitated_shear", cavitated_shear, CAVITATED_SHEARS, "oil.cavitated_shear", "--cavitated-shear")
    if degree not in (1, 2):
        raise InputError(f"degree = {degree} (--degree {degree}) is out of range (allowed: 1 or 2)")
    special = [
        text.format(value)
        for text, value, default in ((_CAVITATION, cavitation, "reynolds"), (_BUSHING, bushing, "none"))
        if value != default
    ]
    if special and (degree != 1 or ranks != 1):
        raise InputError(
            f"{' with '.join(special)} needs the serial P1 film: degree = {degree} (--degree) on {ranks} "
            "rank(s) is out of range (allowed: one rank, no mpirun; degree 1)"
        )
    if inlet == "max-gap":
        if supply:
            raise InputError(
                f"{_INLET.format(inlet)} with {_SUPPLY} is out of range (allowed with a supply: inlet 'none')"
            )
        if bushing == "fe":
            raise InputError(
                f"{_INLET.format(inlet)} with {_BUSHING.format(bushing)} is out of range: the max-gap frame "
                "turns the film against the eye (allowed: inlet 'none', with or without a supply)"
            )
        if special and not quasi_static:
            raise InputError(
                f"{_INLET.format(inlet)} with {' and '.join(special)} is out of range: the film's history "
                "(deformation, film fraction) cannot turn with the max-gap frame (allowed: inlet 'none', "
                "'hole' or a groove; max-gap only for quasi-static solves)"
            )
    if cavitation == "jfo" and inlet == "none" and not supply and not cavitation_pressure < 0:
        # edges at the cavitation pressure, no supply: no oil can enter the film but along its edges'
        # first element row, so the oil it holds depends on the mesh (load -16 % from 0.1 to 0.025 R)
        raise InputError(
            f"oil.cavitation_pressure_bar = {cavitation_pressure / 1e5:g} (--cavitation-pressure "
            f"{cavitation_pressure:g} Pa) with {_CAVITATION.format(cavitation)}, inlet 'none' and no oil "
            "supply is out of range (allowed: < 0, the edges flooded above the cavitation pressure; or "
            "an oil supply)"
        )
    if sigmas and not math.isclose(min(sigmas), max(sigmas), rel_tol=1e-12):
        raise InputError("roughness.sigma and contact.sigma differ (allowed: the same composite roughness)")


def default_inlet(*, cavitation: str, bushing: str, supply: bool, quasi_static: bool) -> str:
    """The inlet without asking: "max-gap" (the classic tables' assumption) where ``check_film`` allows
    it for these choices, else "none"."""
    history = cavitation != "reynolds" or bushing != "none"
    if supply or bushing == "fe" or (history and not quasi_static):
        return "none"
    return "max-gap"
