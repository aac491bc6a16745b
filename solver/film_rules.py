"""Which film choices go together: the one place where a film's compatibility rules are written.

A film is a cavitation law (Reynolds VI or JFO), a bushing (rigid, Winkler layer or FE eye), an inlet
(the max-gap line or none) with or without an oil supply, and the numerics it runs on. Some
combinations cannot work; ``check_film`` refuses them with one line that names the case key and the
command-line flag of each choice, so a case file and the ``bearing`` command get the same message.
``default_inlet`` is the inlet a user gets without asking: the max-gap line where the model allows it,
``none`` where it does not. ``check_geometry`` refuses a bearing no engine has (a radius, clearance or
width that is most likely a length in the wrong unit), naming the case key or the flag (``CASE_LENGTHS``,
``FLAG_LENGTHS``) and the value the user probably meant.

Plain Python, below solver.case in the import layers (pyproject.toml): the case loader calls it when
it reads a case, solver.film.spec.FilmSpec when a film is specified (the command line builds one
before any mesh or compliance), and the factory once more with the communicator's size.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from solver.errors import InputError, out_of_range

CAVITATION_LAWS = ("reynolds", "jfo")
BUSHINGS = ("none", "winkler", "fe")
INLETS = ("max-gap", "none")
TRANSPORTS = ("limited", "upwind")
CAVITATED_SHEARS = ("film-fraction", "full")

#: how a choice is named: case key, command-line flag
_CAVITATION = "oil.cavitation = {0!r} (--cavitation {0})"
_BUSHING = "{1}.elastic = {0!r} (--elastic {0})"
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
    joint: str = "small_end",
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
        joint: the case section whose ``elastic`` key chose the bushing (its name in the messages).
    """
    _choice("cavitation", cavitation, CAVITATION_LAWS, "oil.cavitation", "--cavitation")
    _choice("bushing", bushing, BUSHINGS, f"{joint}.elastic", "--elastic")
    _choice("inlet", inlet, INLETS, "oil.inlet", "--inlet")
    _choice("transport", transport, TRANSPORTS, "solver.film_fraction_transport", "transport")
    _choice("cavitated_shear", cavitated_shear, CAVITATED_SHEARS, "oil.cavitated_shear", "--cavitated-shear")
    if degree not in (1, 2):
        raise InputError(f"degree = {degree} (--degree {degree}) is out of range (allowed: 1 or 2)")
    special = [
        text.format(value, joint)
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
                f"{_INLET.format(inlet)} with {_BUSHING.format(bushing, joint)} is out of range: the max-gap "
                "frame turns the film against the eye (allowed: inlet 'none', with or without a supply)"
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


def check_edge_relief_length(length: float, width: float, section: str = "small_end") -> None:
    """Raise InputError unless a bore's edge relief of ``length`` [m] at each edge leaves the middle of a
    bearing of ``width`` [m] cylindrical (l < B / 2; solver.film.relief)."""
    if not length < 0.5 * width:
        raise out_of_range(
            f"{section}.edge_relief_length_mm",
            f"{length * 1e3:g}",
            f"(0, {0.5 * width * 1e3:g}): less than half the bearing's width",
        )


def reference_speed(wedge: float, sliding: float, squeeze: float) -> float:
    """The film scaling's reference angular speed [rad/s]: the first of |wedge| (omega_j + omega_b),
    |sliding| (omega_j - omega_b) and |squeeze| (|de/dt| / c) that is not 0, else |squeeze|."""
    for value in (wedge, sliding):
        if value != 0:
            return abs(value)
    return abs(squeeze)


def default_inlet(*, cavitation: str, bushing: str, supply: bool, quasi_static: bool) -> str:
    """The inlet without asking: "max-gap" (the classic tables' assumption) where ``check_film`` allows
    it for these choices, else "none"."""
    history = cavitation != "reynolds" or bushing != "none"
    if supply or bushing == "fe" or (history and not quasi_static):
        return "none"
    return "max-gap"


#: the plausible bearing: radius [m], clearance / radius, width / radius (closed ranges). A bearing
#: outside them is most likely a length in the wrong unit (a clearance in mm given as um: h_min goes to
#: zero and the film solver crawls).
RADIUS_RANGE = (1e-4, 1.0)
CLEARANCE_RATIO_RANGE = (1e-4, 1e-2)
WIDTH_RATIO_RANGE = (0.05, 5.0)
#: a composite roughness [m] that a unit slip could have meant (only for the message's hint)
SIGMA_HINT_RANGE = (1e-8, 1e-5)

#: the units a length may have been given in by mistake: name, metres per unit
_UNITS = (("m", 1.0), ("mm", 1e-3), ("um", 1e-6))


@dataclasses.dataclass(frozen=True)
class Length:
    """How a length is named to the user: its case key or command-line flag and the unit it takes.

    Attributes:
        name: ``small_end.clearance_um`` or ``--clearance``.
        unit: ``"m"``, ``"mm"`` or ``"um"``.
        flag: a command-line flag (``--x 0.1``) rather than a case key (``x = 0.1``).
        composite: a length made of several settings (the composite roughness): a value is then
            written ``0.3 um``.
    """

    name: str
    unit: str
    flag: bool = False
    composite: bool = False

    @property
    def scale(self) -> float:
        """Metres per unit."""
        return dict(_UNITS)[self.unit]

    def value(self, value_si: float) -> str:
        """``small_end.clearance_um = 0.012`` or ``--clearance = 1.2e-08``: the value as given."""
        return f"{self.name} = {value_si / self.scale:g}"

    def setting(self, value_si: float) -> str:
        """How the user writes this SI value: ``--radius 0.012`` or ``small_end.clearance_um = 12``."""
        if self.composite:
            return f"{value_si / self.scale:g} {self.unit}"
        return f"{self.name} {value_si / self.scale:g}" if self.flag else self.value(value_si)


#: the case's names (solver.case) and the bearing and stribeck commands' flags (solver.cli.bearing)
CASE_LENGTHS = {
    "radius": Length("small_end.pin_radius_mm", "mm"),
    "width": Length("small_end.width_mm", "mm"),
    "clearance": Length("small_end.clearance_um", "um"),
    "sigma": Length("sqrt(surface.sigma_pin_um^2 + surface.sigma_bushing_um^2)", "um", composite=True),
    "bushing_thickness": Length("small_end.bushing_thickness_mm", "mm"),
}
#: the big end's lengths (checked as the small end's, without roughness; its shell when elastic)
BIG_END_LENGTHS = {
    "radius": Length("big_end.radius_mm", "mm"),
    "width": Length("big_end.width_mm", "mm"),
    "clearance": Length("big_end.clearance_um", "um"),
    "bushing_thickness": Length("big_end.bushing_thickness_mm", "mm"),
}
#: the floating pin's film in the piston bosses (checked as the big end's)
PIN_BOSS_LENGTHS = {
    "radius": Length("pin_boss.radius_mm", "mm"),
    "width": Length("pin_boss.width_mm", "mm"),
    "clearance": Length("pin_boss.clearance_um", "um"),
}
FLAG_LENGTHS = {
    "radius": Length("--radius", "m", flag=True),
    "width": Length("--width", "m", flag=True),
    "clearance": Length("--clearance", "m", flag=True),
    "sigma": Length("sqrt(--sigma-journal^2 + --sigma-bushing^2)", "m", flag=True, composite=True),
    "bushing_thickness": Length("--bushing-thickness", "m", flag=True),
}


def _unit_slip(length: Length, value_si: float, plausible: Callable[[float], bool]) -> str:
    """``; if you meant 12 mm: --radius 0.012``: the first other unit in which the number the user
    typed is plausible, or "" when there is none."""
    typed = value_si / length.scale
    for unit, scale in _UNITS:
        if unit != length.unit and plausible(typed * scale):
            return f"; if you meant {typed:g} {unit}: {length.setting(typed * scale)}"
    return ""


def _range(length: Length, value_si: float, low: float, high: float, what: str, hint: bool = True) -> None:
    """InputError unless low <= value_si <= high [m] (to rounding: 1e-9); ``what`` says where the range
    comes from; ``hint``: name the unit in which the number typed would be inside."""

    def inside(x: float) -> bool:
        return low * (1 - 1e-9) <= x <= high * (1 + 1e-9)

    if inside(value_si):
        return
    raise InputError(
        f"{length.value(value_si)} is out of range (allowed: [{low / length.scale:g}, "
        f"{high / length.scale:g}] {length.unit}{what}{_unit_slip(length, value_si, inside) if hint else ''})"
    )


def check_geometry(
    *,
    radius: float,
    width: float,
    clearance: float,
    sigma: float = 0.0,
    bushing_thickness: float | None = None,
    names: dict[str, Length] = CASE_LENGTHS,
) -> None:
    """Raise InputError (one line) unless the bearing is plausible: a radius in RADIUS_RANGE, a clearance
    and a width in CLEARANCE_RATIO_RANGE and WIDTH_RATIO_RANGE of it, a clearance above the composite
    roughness, an elastic bushing no thicker than the radius. The message names the key or flag
    (``names``: CASE_LENGTHS or FLAG_LENGTHS), the value, the allowed range and, when the number typed
    would be plausible in another unit, that unit and the setting it means.

    Args:
        radius: journal (pin) radius R [m].
        width: bearing width B [m].
        clearance: radial clearance c [m].
        sigma: composite roughness sqrt(sigma_1^2 + sigma_2^2) [m]; 0: smooth surfaces (not checked).
        bushing_thickness: the elastic bushing's wall thickness [m]; None: rigid (not checked).
        names: how each length is named to the user.
    """
    _range(names["radius"], radius, *RADIUS_RANGE, "")
    low, high = CLEARANCE_RATIO_RANGE
    _range(
        names["clearance"],
        clearance,
        low * radius,
        high * radius,
        f", clearance / radius in [{low:g}, {high:g}]",
    )
    low, high = WIDTH_RATIO_RANGE
    _range(names["width"], width, low * radius, high * radius, f", width / radius in [{low:g}, {high:g}]")
    if sigma > 0 and not clearance > sigma:
        rough = names["sigma"]
        slip = _unit_slip(
            rough, sigma, lambda s: clearance > s and SIGMA_HINT_RANGE[0] <= s <= SIGMA_HINT_RANGE[1]
        )
        raise InputError(
            f"{names['clearance'].value(clearance)} is below the composite roughness {rough.value(sigma)} "
            f"(allowed: clearance > composite roughness{slip})"
        )
    if bushing_thickness is not None:
        # (no unit hint: a bushing of any small thickness is inside)
        _range(names["bushing_thickness"], bushing_thickness, 0.0, radius, ", at most the radius", hint=False)
