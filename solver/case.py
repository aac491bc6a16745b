"""The case description: ``case.toml`` -> validated, frozen dataclasses in SI units.

Outside (TOML) every key carries its unit when it is not an SI base unit (``bore_mm``,
``speed_rpm``, ``clearance_um``); inside every float is SI (m, kg, s, rad, Pa). The conversion
happens once, in :func:`load_case`. One table, :data:`FIELDS`, holds every key: its unit factor,
default, allowed range and meaning. It drives the loader, the range checks in ``__post_init__`` (so
a dataclass built in Python is checked too) and the reference page docs/case-reference.md
(``python3 -m solver docs``).

The defaults are the reference engine of DESIGN 3.7 (a 2.0 L four-cylinder gasoline engine, one
cylinder, 2000 rpm, single-zone pressure with a 60 bar peak). A case file only needs what differs
from it; ``name`` defaults to the case directory's name. Errors are :class:`InputError` with one line
that names the field as ``section.key`` and its allowed range.

Sections: ``[engine]``, ``[gas]`` (the mechanism and its loads), ``[small_end]``, ``[oil]``,
``[surface]`` (the lubricated small end), ``[big_end]`` (the big end: ideal, or a clearance joint in
the same oil and surface: short bearing, finite-element film or dry contact), ``[pin_boss]`` (the
floating pin's film in the piston bosses, ``small_end.pin = "floating"``) and ``[solver]`` (the coupled
run: joint model, mesh, tolerances, cycles, outputs). Unknown sections and keys are errors.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from solver.errors import InputError, out_of_range, read_toml_file
from solver.film_rules import (
    BIG_END_LENGTHS,
    CASE_LENGTHS,
    CLEARANCE_RATIO_RANGE,
    PIN_BOSS_LENGTHS,
    RADIUS_RANGE,
    WIDTH_RATIO_RANGE,
    check_edge_relief_length,
    check_film,
    check_geometry,
)
from solver.oil import GRADES, MIN_KINEMATIC_VISCOSITY, OilData, oil_data

#: the small end's oil inlets (``oil.inlet``): the last three are an oil supply at ``oil.supply_pressure_bar``
INLETS = ("none", "max-gap", "hole", "axial-groove", "circumferential-groove")

#: the big end's models (``big_end.joint``)
BIG_END_JOINTS = ("ideal", "short-bearing", "mixed-fem", "dry")
#: the big end's oil supply (``big_end.supply``): a hole in the crankpin, turning with the crank
BIG_END_SUPPLIES = ("none", "hole")

#: the piston pin (``small_end.pin``) and the floating pin's film in the piston bosses (``pin_boss.joint``)
PINS = ("fixed", "floating")
PIN_BOSS_JOINTS = ("short-bearing", "mixed-fem", "ideal")

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm
DEG = math.pi / 180.0  # rad per degree
BAR = 1e5  # Pa per bar


@dataclasses.dataclass(frozen=True)
class FieldSpec:
    """One key of case.toml.

    Attributes:
        section: TOML table (``""`` for top-level keys).
        key: TOML key, with its unit suffix.
        attribute: dataclass attribute (SI value).
        kind: ``float``, ``bool``, ``str`` or ``Path`` (a file name relative to the case directory).
        default: default in TOML units; ``None`` = optional and absent.
        scale: SI value = scale * TOML value (floats only).
        minimum: lower bound in TOML units, or ``None``.
        maximum: upper bound in TOML units, or ``None``.
        open_interval: the bounds themselves are excluded.
        choices: allowed strings (``kind is str``), or ``None``.
        unit: unit of the TOML value, for the documentation.
        doc: one-line meaning.
    """

    section: str
    key: str
    attribute: str
    kind: type
    default: Any
    scale: float = 1.0
    minimum: float | None = None
    maximum: float | None = None
    open_interval: bool = True
    choices: tuple[str, ...] | None = None
    unit: str = ""
    doc: str = ""

    @property
    def name(self) -> str:
        """``section.key`` as used in messages."""
        return f"{self.section}.{self.key}" if self.section else self.key

    def allowed(self) -> str:
        """The allowed range as text, e.g. ``> 0`` or ``(180, 540)``."""
        if self.choices:
            return ", ".join(repr(choice) for choice in self.choices)
        if self.kind is bool:
            return "true, false"
        if self.kind is int:
            return f"an integer in [{self.minimum:g}, {self.maximum:g}]"
        if self.kind is list:
            return f"a list of numbers in [{self.minimum:g}, {self.maximum:g}]"
        if self.kind is not float:
            return "any" if self.kind is str else "an existing file"
        low, high = self.minimum, self.maximum
        if low is not None and high is not None:
            left, right = ("(", ")") if self.open_interval else ("[", "]")
            return f"{left}{low:g}, {high:g}{right}"
        if low is not None:
            return f"{'>' if self.open_interval else '>='} {low:g}"
        if high is not None:
            return f"{'<' if self.open_interval else '<='} {high:g}"
        return "any number"

    def check(self, si_value: Any) -> None:
        """Raise InputError if the SI value is outside the allowed range."""
        if self.kind is int:
            if isinstance(si_value, bool) or not isinstance(si_value, int):
                raise InputError(f"{self.name} = {si_value!r} has the wrong type (expected an integer)")
            if not self.minimum <= si_value <= self.maximum:
                raise out_of_range(self.name, si_value, self.allowed())
            return
        if self.kind is list:
            values = [v / self.scale for v in si_value]
            if not all(math.isfinite(v) and self.minimum <= v <= self.maximum for v in values):
                raise out_of_range(self.name, [f"{v:g}" for v in values], self.allowed())
            return
        if si_value is None or self.kind is not float:
            if (
                self.choices
                and si_value not in self.choices
                and not (si_value is None and self.default is None)
            ):
                raise out_of_range(self.name, repr(si_value), self.allowed())
            return
        value = si_value / self.scale
        bad = not math.isfinite(value)
        if self.minimum is not None:
            bad |= value <= self.minimum if self.open_interval else value < self.minimum
        if self.maximum is not None:
            bad |= value >= self.maximum if self.open_interval else value > self.maximum
        if bad:
            raise out_of_range(self.name, f"{value:g}", self.allowed())


def _f(
    section, key, attribute, default, scale=1.0, minimum=None, maximum=None, *, closed=False, unit="", doc=""
):
    """A float field; ``closed`` includes the bounds."""
    return FieldSpec(
        section, key, attribute, float, default, scale, minimum, maximum, not closed, None, unit, doc
    )


#: Every key of case.toml (single source of the loader, the checks and docs/case-reference.md).
FIELDS: tuple[FieldSpec, ...] = (
    FieldSpec("", "name", "name", str, None, unit="", doc="case name (default: the case directory's name)"),
    FieldSpec("", "description", "description", str, "", doc="free text"),
    # [engine] -- DESIGN 3.7 frame: origin at the crank centre, +x from crank to piston, crank turns CCW
    _f("engine", "speed_rpm", "speed", 2000.0, RPM, 0.0, 30000.0, unit="rpm", doc="constant crank speed"),
    FieldSpec(
        "engine",
        "speed_file",
        "speed_file",
        Path,
        None,
        doc="optional CSV `crank_angle_deg,speed_rpm` over 0-720 deg; replaces speed_rpm",
    ),
    _f("engine", "bore_mm", "bore", 86.0, 1e-3, 0.0, unit="mm", doc="cylinder bore"),
    _f(
        "engine",
        "crank_radius_mm",
        "crank_radius",
        43.0,
        1e-3,
        0.0,
        unit="mm",
        doc="crank radius r (stroke = 2 r)",
    ),
    _f(
        "engine",
        "rod_length_mm",
        "rod_length",
        145.0,
        1e-3,
        0.0,
        unit="mm",
        doc="connecting rod length l, big-end to small-end centre; > crank radius + |pin offset|",
    ),
    _f(
        "engine",
        "pin_offset_mm",
        "pin_offset",
        0.0,
        1e-3,
        unit="mm",
        doc="lateral (+y) offset of the piston pin from the cylinder axis",
    ),
    _f("engine", "rod_mass_kg", "rod_mass", 0.55, 1.0, 0.0, unit="kg", doc="connecting rod mass"),
    _f(
        "engine",
        "rod_inertia_kg_m2",
        "rod_inertia",
        2.2e-3,
        1.0,
        0.0,
        unit="kg m^2",
        doc="rod moment of inertia about its centre of mass",
    ),
    _f(
        "engine",
        "rod_cg_from_big_end_mm",
        "rod_cg_from_big_end",
        35.0,
        1e-3,
        0.0,
        unit="mm",
        closed=True,
        doc="distance of the rod's centre of mass from the big-end centre, on the rod axis; <= rod length",
    ),
    _f(
        "engine",
        "piston_mass_kg",
        "piston_mass",
        0.45,
        1.0,
        0.0,
        unit="kg",
        doc="piston assembly mass (pin, rings included); centre of mass at the pin",
    ),
    _f(
        "engine",
        "crank_mass_kg",
        "crank_mass",
        0.0,
        1.0,
        0.0,
        closed=True,
        unit="kg",
        doc="crank throw mass, centre of mass on the crank axis (only its weight loads the main bearing)",
    ),
    _f(
        "engine",
        "crank_inertia_kg_m2",
        "crank_inertia",
        0.0,
        1.0,
        0.0,
        closed=True,
        unit="kg m^2",
        doc="crank inertia about its axis (matters with a speed trace)",
    ),
    FieldSpec("engine", "gravity", "gravity", bool, True, doc="gravity along -x (9.80665 m/s^2)"),
    # [gas]
    FieldSpec(
        "gas",
        "model",
        "model",
        str,
        None,
        choices=("single-zone", "motored", "trace", "none"),
        doc="cylinder pressure: single-zone model, motored (no combustion), CSV trace, or none "
        "(p = crankcase pressure); default: trace if pressure_file is given, else single-zone",
    ),
    FieldSpec(
        "gas",
        "pressure_file",
        "pressure_file",
        Path,
        None,
        doc="CSV `crank_angle_deg,pressure_bar` (or `pressure_Pa`, `pressure_MPa`), absolute, 0-720 deg",
    ),
    _f("gas", "compression_ratio", "compression_ratio", 10.5, 1.0, 1.0, 40.0, doc="(V_c + V_d) / V_c"),
    _f(
        "gas",
        "polytropic_exponent",
        "polytropic_exponent",
        1.32,
        1.0,
        1.0,
        5.0 / 3.0,
        doc="n of p V^n = const for compression and expansion",
    ),
    _f(
        "gas",
        "peak_pressure_bar",
        "peak_pressure",
        60.0,
        BAR,
        0.0,
        unit="bar",
        doc="target peak cylinder pressure (absolute); default unless imep_bar is given",
    ),
    _f(
        "gas",
        "imep_bar",
        "imep",
        None,
        BAR,
        0.0,
        unit="bar",
        doc="target net IMEP (instead of peak_pressure_bar)",
    ),
    _f(
        "gas",
        "combustion_start_deg",
        "combustion_start",
        350.0,
        DEG,
        180.0,
        540.0,
        unit="deg",
        doc="start of heat release (360 = firing TDC)",
    ),
    _f(
        "gas",
        "combustion_duration_deg",
        "combustion_duration",
        50.0,
        DEG,
        0.0,
        360.0,
        unit="deg",
        doc="Wiebe combustion duration; start + duration < 540",
    ),
    _f("gas", "wiebe_a", "wiebe_a", 5.0, 1.0, 0.0, 50.0, doc="Wiebe efficiency parameter a"),
    _f("gas", "wiebe_m", "wiebe_m", 2.0, 1.0, -1.0, 10.0, doc="Wiebe form factor m"),
    _f(
        "gas",
        "intake_pressure_bar",
        "intake_pressure",
        1.0,
        BAR,
        0.0,
        unit="bar",
        doc="intake pressure (0-180 deg and start of compression), absolute",
    ),
    _f(
        "gas",
        "exhaust_pressure_bar",
        "exhaust_pressure",
        1.1,
        BAR,
        0.0,
        unit="bar",
        doc="exhaust pressure (after the blowdown, to the valve overlap), absolute",
    ),
    _f(
        "gas",
        "exhaust_opening_deg",
        "exhaust_opening",
        490.0,
        DEG,
        360.0,
        720.0,
        unit="deg",
        doc="exhaust valve opening (130 deg after firing TDC); from there the pressure falls smoothly to the "
        "exhaust pressure (540 with blowdown and overlap 0: the seed's step model)",
    ),
    _f(
        "gas",
        "blowdown_duration_deg",
        "blowdown_duration",
        70.0,
        DEG,
        0.0,
        360.0,
        closed=True,
        unit="deg",
        doc="crank angle over which the blowdown brings the pressure to the exhaust pressure",
    ),
    _f(
        "gas",
        "valve_overlap_deg",
        "valve_overlap",
        40.0,
        DEG,
        0.0,
        180.0,
        closed=True,
        unit="deg",
        doc="valve overlap centred on 720 deg: the exhaust pressure passes smoothly to the intake pressure",
    ),
    _f(
        "gas",
        "crankcase_pressure_bar",
        "crankcase_pressure",
        1.0,
        BAR,
        0.0,
        unit="bar",
        closed=True,
        doc="crankcase pressure under the piston, absolute",
    ),
    # [small_end]
    _f(
        "small_end",
        "pin_radius_mm",
        "pin_radius",
        10.0,
        1e-3,
        0.0,
        unit="mm",
        doc=f"piston pin radius R; in [{RADIUS_RANGE[0] * 1e3:g}, {RADIUS_RANGE[1] * 1e3:g}] "
        "(a plausible bearing)",
    ),
    _f(
        "small_end",
        "width_mm",
        "width",
        20.0,
        1e-3,
        0.0,
        unit="mm",
        doc=f"bushing width B; B / R in [{WIDTH_RATIO_RANGE[0]:g}, {WIDTH_RATIO_RANGE[1]:g}]",
    ),
    _f(
        "small_end",
        "clearance_um",
        "clearance",
        10.0,
        1e-6,
        0.0,
        unit="um",
        doc=f"radial clearance c; c / R in [{CLEARANCE_RATIO_RANGE[0]:g}, {CLEARANCE_RATIO_RANGE[1]:g}] "
        "and c > the composite roughness (surface)",
    ),
    FieldSpec(
        "small_end",
        "elastic",
        "elastic",
        str,
        "none",
        choices=("none", "winkler", "fe"),
        doc="bushing deformation under the film and asperity pressure (docs/models.md): none (rigid), "
        "winkler (thin bushing on a rigid eye, w = k p node by node) or fe (finite-element compliance of "
        "the eye and bushing, cached on disk); needs inlet none, hole or a groove. With the FE eye an "
        "engine cycle costs about 2 times the rigid one, with a Winkler bushing more (its unknowns are "
        "nodal: one LU of the whole coupled matrix; docs/benchmarks.md)",
    ),
    _f(
        "small_end",
        "bushing_thickness_mm",
        "bushing_thickness",
        1.5,
        1e-3,
        0.0,
        unit="mm",
        doc="bushing wall thickness (moduli: surface.E_bushing_GPa, surface.nu_bushing); with an elastic "
        "bushing <= pin radius",
    ),
    _f(
        "small_end",
        "eye_outer_radius_mm",
        "eye_outer_radius",
        17.0,
        1e-3,
        0.0,
        unit="mm",
        doc="outer radius of the rod's eye; > pin radius + bushing thickness",
    ),
    _f(
        "small_end", "E_eye_GPa", "E_eye", 210.0, 1e9, 0.0, unit="GPa", doc="Young's modulus of the rod (eye)"
    ),
    _f("small_end", "nu_eye", "nu_eye", 0.3, 1.0, 0.0, 0.5, doc="Poisson ratio of the rod (eye)"),
    _f(
        "small_end",
        "shank_half_angle_deg",
        "shank_half_angle",
        30.0,
        DEG,
        0.0,
        90.0,
        unit="deg",
        doc="half angle of the arc where the eye joins the shank (clamped in the fe model; the shank is "
        "opposite the top of the eye, toward the big end)",
    ),
    FieldSpec(
        "small_end",
        "compliance_basis",
        "compliance_basis",
        str,
        "eigen",
        choices=("eigen", "layer"),
        doc="fe: the compliance's basis (docs/models.md): eigen (modes of the whole compliance) or layer "
        "(the bushing's local compression node by node plus modes of the rest: a thin bushing on a stiff "
        "housing; against the full compliance on refined grids: docs/verification.md)",
    ),
    FieldSpec(
        "small_end",
        "compliance_modes",
        "compliance_modes",
        int,
        0,
        minimum=0,
        maximum=5000,
        doc="fe: modes kept, at most the grid's nodes (compliance_grid_theta x compliance_grid_z); 0: the "
        "fewest whose truncation error is within compliance_tolerance (the modes and the error: run.log)",
    ),
    FieldSpec(
        "small_end",
        "compliance_grid_theta",
        "compliance_grid_theta",
        int,
        72,
        minimum=12,
        maximum=720,
        doc="fe: nodes of the compliance's grid around the bore (the hats the FE eye is loaded with; "
        "docs/verification.md: the grid's convergence)",
    ),
    FieldSpec(
        "small_end",
        "compliance_grid_z",
        "compliance_grid_z",
        int,
        5,
        minimum=2,
        maximum=65,
        doc="fe: nodes of the compliance's grid over the half width, both ends included",
    ),
    _f(
        "small_end",
        "compliance_tolerance",
        "compliance_tolerance",
        0.001,
        1.0,
        0.0,
        1.0,
        doc="fe, compliance_modes = 0: the largest truncation error of the displacement under the reference "
        "loads (uniform, 30 deg bumps; max norm, relative)",
    ),
    _f(
        "small_end",
        "edge_relief_um",
        "edge_relief_depth",
        0.0,
        1e-6,
        0.0,
        100.0,
        closed=True,
        unit="um",
        doc="the bore's relief at each edge of the bushing: how much wider the gap is at the edge than in "
        "the cylindrical middle (0: a cylindrical bore to the edges; docs/models.md)",
    ),
    _f(
        "small_end",
        "edge_relief_length_mm",
        "edge_relief_length",
        3.0,
        1e-3,
        0.0,
        unit="mm",
        doc="with edge_relief_um > 0: the relieved length at each edge; < small_end.width_mm / 2",
    ),
    FieldSpec(
        "small_end",
        "edge_relief_shape",
        "edge_relief_shape",
        str,
        "parabolic",
        choices=("parabolic", "linear"),
        doc="with edge_relief_um > 0: the relief's profile over its length, parabolic (a crowned edge, "
        "tangent to the bore where it starts) or linear (a taper)",
    ),
    FieldSpec(
        "small_end",
        "pin",
        "pin",
        str,
        "fixed",
        choices=PINS,
        doc="the piston pin: fixed in the piston (the small end's journal), or floating, a body of its own "
        "that turns in the small end's film and in the piston bosses' film ([pin_boss]); with floating the "
        "piston's own mass is engine.piston_mass_kg less small_end.pin_mass_g (docs/models.md)",
    ),
    _f(
        "small_end",
        "pin_mass_g",
        "pin_mass",
        101.0,
        1e-3,
        0.0,
        unit="g",
        doc="floating pin: the pin's mass, < engine.piston_mass_kg (the default: a steel tube 21 mm outside, "
        "12 mm bore, 55 mm long, 7850 kg/m^3)",
    ),
    _f(
        "small_end",
        "pin_inertia_kg_mm2",
        "pin_inertia",
        7.36,
        1e-6,
        0.0,
        unit="kg mm^2",
        doc="floating pin: the pin's polar moment of inertia about its axis (the default: the same tube, "
        "m (R_o^2 + R_i^2) / 2)",
    ),
    # [big_end]
    FieldSpec(
        "big_end",
        "joint",
        "joint",
        str,
        "ideal",
        choices=BIG_END_JOINTS,
        doc="big-end model (crankpin in the rod's big eye): ideal revolute; Ocvirk short bearing (rigid, "
        "smooth, the oil of [oil]); mixed-fem, the small end's finite-element film (a rigid eye, a "
        "Winkler shell or the finite-element eye, big_end.elastic; the oil, cavitation law (Reynolds or "
        "the mass-conserving JFO film, its film fraction carried from step to step) and max-gap or no inlet "
        "of [oil], the roughness of [big_end_surface], solver.mesh_size); or dry contact (Hertz stiffness "
        "from the moduli of [big_end_surface])",
    ),
    _f(
        "big_end",
        "radius_mm",
        "radius",
        24.0,
        1e-3,
        0.0,
        unit="mm",
        doc=f"crankpin radius; in [{RADIUS_RANGE[0] * 1e3:g}, {RADIUS_RANGE[1] * 1e3:g}]",
    ),
    _f(
        "big_end",
        "width_mm",
        "width",
        20.0,
        1e-3,
        0.0,
        unit="mm",
        doc=f"big-end bearing width B; B / R in [{WIDTH_RATIO_RANGE[0]:g}, {WIDTH_RATIO_RANGE[1]:g}]",
    ),
    _f(
        "big_end",
        "clearance_um",
        "clearance",
        25.0,
        1e-6,
        0.0,
        unit="um",
        doc=f"big-end radial clearance c; c / R in [{CLEARANCE_RATIO_RANGE[0]:g}, "
        f"{CLEARANCE_RATIO_RANGE[1]:g}]",
    ),
    FieldSpec(
        "big_end",
        "supply",
        "supply",
        str,
        "none",
        choices=BIG_END_SUPPLIES,
        doc="oil supply of a mixed-fem big end: none, or a hole in the crankpin (it turns with the crank: in "
        "the rod frame at supply_hole_angle_deg + crank angle - rod angle), held at supply_pressure_bar",
    ),
    _f(
        "big_end",
        "supply_pressure_bar",
        "supply_pressure",
        3.0,
        BAR,
        0.0,
        1000.0,
        closed=True,
        unit="bar",
        doc="with supply = hole: oil pressure in the crankpin's hole, gauge (a typical gallery pressure)",
    ),
    _f(
        "big_end",
        "supply_hole_diameter_mm",
        "supply_hole_diameter",
        5.0,
        1e-3,
        0.0,
        unit="mm",
        doc="with supply = hole: the hole's diameter; < big_end.width_mm and < big_end.radius_mm",
    ),
    _f(
        "big_end",
        "supply_hole_angle_deg",
        "supply_hole_angle",
        0.0,
        DEG,
        -360.0,
        360.0,
        unit="deg",
        doc="with supply = hole: the hole's angle on the crankpin from the crank throw (0: the side away "
        "from the crank axis), counter-clockwise as the crank turns; on the mid-plane",
    ),
    FieldSpec(
        "big_end",
        "elastic",
        "elastic",
        str,
        "none",
        choices=("none", "winkler", "fe"),
        doc="big-end shell deformation under the film and asperity pressure, as small_end.elastic: none "
        "(rigid), winkler (a thin shell of bushing_thickness_mm on a rigid eye, w = k p node by node, "
        "the moduli big_end_surface.E_bushing_GPa, big_end_surface.nu_bushing) or fe (the finite-element "
        "compliance of the big eye, cap continuous with it, and that shell, clamped where the eye joins "
        "the shank, toward the small end; cached on disk; docs/models.md); a mixed-fem big end, inlet none "
        "or a supply (with big_end.supply = hole the eye's shapes are turned into the crankpin's frame)",
    ),
    _f(
        "big_end",
        "bushing_thickness_mm",
        "bushing_thickness",
        1.8,
        1e-3,
        0.0,
        unit="mm",
        doc="with elastic = winkler or fe: the big-end shell's wall thickness; <= big_end.radius_mm",
    ),
    # [pin_boss]
    FieldSpec(
        "pin_boss",
        "joint",
        "joint",
        str,
        "short-bearing",
        choices=PIN_BOSS_JOINTS,
        doc="the floating pin in the piston's two bosses (small_end.pin = floating; ignored with a fixed "
        "pin): Ocvirk short bearing (rigid, smooth, the oil of [oil]); mixed-fem: the finite-element film "
        "(rigid bosses, the roughness and asperity contact of [pin_boss_surface], the oil of [oil] with its "
        "Reynolds cavitation and its inlet max-gap or none, no supply, solver.mesh_size; with films = 2 one "
        "film of half the width whose loads count twice; oil.cavitation = jfo refused); ideal is the fixed "
        "pin, refused with a floating one (use small_end.pin = fixed)",
    ),
    _f(
        "pin_boss",
        "radius_mm",
        "radius",
        10.0,
        1e-3,
        0.0,
        unit="mm",
        doc=f"the pin's radius in the bosses; in [{RADIUS_RANGE[0] * 1e3:g}, {RADIUS_RANGE[1] * 1e3:g}]",
    ),
    _f(
        "pin_boss",
        "width_mm",
        "width",
        30.0,
        1e-3,
        0.0,
        unit="mm",
        doc=f"both bosses' total width (each boss half of it; docs/models.md); width / radius in "
        f"[{WIDTH_RATIO_RANGE[0]:g}, {WIDTH_RATIO_RANGE[1]:g}]",
    ),
    FieldSpec(
        "pin_boss",
        "films",
        "films",
        int,
        2,
        minimum=1,
        maximum=2,
        doc="2: the two bosses as two films of half the total width each, side by side (each with its own "
        "edges: together a quarter of one whole-width film's load capacity, Ocvirk's B^3); 1: one film of "
        "the total width (the stiffer planar simplification)",
    ),
    _f(
        "pin_boss",
        "clearance_um",
        "clearance",
        10.0,
        1e-6,
        0.0,
        unit="um",
        doc=f"the bosses' radial clearance c; c / radius in [{CLEARANCE_RATIO_RANGE[0]:g}, "
        f"{CLEARANCE_RATIO_RANGE[1]:g}]",
    ),
    _f(
        "pin_boss",
        "viscosity_ratio",
        "viscosity_ratio",
        1.0,
        1.0,
        0.0,
        doc="the bosses' oil viscosity over the small end's (oil.viscosity_Pa_s or the oil's data): the "
        "bosses are splash-fed and may run hotter or colder; a large ratio holds the pin in the piston",
    ),
    # [oil]
    _f(
        "oil",
        "viscosity_Pa_s",
        "viscosity",
        0.010,
        1.0,
        0.0,
        unit="Pa s",
        doc="dynamic viscosity in the film; or give the oil's data below instead (not both)",
    ),
    FieldSpec(
        "oil",
        "grade",
        "grade",
        str,
        None,
        choices=tuple(GRADES),
        doc="SAE grade with typical data-sheet values (solver/oil.py cites them); instead of viscosity_Pa_s",
    ),
    _f(
        "oil",
        "kinematic_viscosity_40C_cSt",
        "kinematic_viscosity_40C",
        None,
        1.0,
        MIN_KINEMATIC_VISCOSITY,
        closed=True,
        unit="mm^2/s",
        doc="data sheet: kinematic viscosity at 40 C (with the 100 C value and density)",
    ),
    _f(
        "oil",
        "kinematic_viscosity_100C_cSt",
        "kinematic_viscosity_100C",
        None,
        1.0,
        MIN_KINEMATIC_VISCOSITY,
        closed=True,
        unit="mm^2/s",
        doc="data sheet: kinematic viscosity at 100 C; < the 40 C value",
    ),
    _f(
        "oil",
        "density_15C_kg_m3",
        "density_15C",
        None,
        1.0,
        700.0,
        1200.0,
        unit="kg/m^3",
        doc="data sheet: density at 15 C",
    ),
    _f(
        "oil",
        "temperature_C",
        "temperature",
        100.0,
        1.0,
        -40.0,
        250.0,
        closed=True,
        unit="C",
        doc="with grade or the data sheet: the film temperature (thermal = isothermal) or the supply "
        "temperature (thermal = effective); viscosity by ASTM D341 (Walther), density by linear "
        "expansion",
    ),
    FieldSpec(
        "oil",
        "thermal",
        "thermal",
        str,
        "isothermal",
        choices=("isothermal", "effective"),
        doc="film temperature: isothermal (temperature_C) or effective (from the heat balance of the "
        "cycle: (1 - heat_to_solids) x dissipated power = density x specific heat x side flow x "
        "rise above temperature_C, iterated with the cycles; needs grade or the data sheet)",
    ),
    _f(
        "oil",
        "specific_heat_J_kgK",
        "specific_heat",
        2000.0,
        1.0,
        500.0,
        5000.0,
        unit="J/(kg K)",
        doc="thermal = effective: the oil's specific heat (unused engine oil: 1880 at 20 C, 2050 at 60 C, "
        "2220 at 100 C, Cengel & Boles' property tables; the default is a typical value, an assumption)",
    ),
    _f(
        "oil",
        "heat_to_solids",
        "heat_to_solids",
        0.2,
        1.0,
        0.0,
        0.95,
        closed=True,
        doc="thermal = effective: share of the dissipated power conducted away through pin and rod "
        "instead of "
        "carried by the side flow (an assumption, not computed; 0: adiabatic film)",
    ),
    _f(
        "oil",
        "thermal_tolerance",
        "thermal_tolerance",
        1e-6,
        1.0,
        0.0,
        0.1,
        doc="thermal = effective: the run is thermally consistent when |heat into the oil - heat carried by "
        "the side flow| <= this x heat into the oil",
    ),
    FieldSpec(
        "oil",
        "piezoviscosity",
        "piezoviscosity",
        str,
        "none",
        choices=("none", "barus", "roelands"),
        doc="pressure dependence of the viscosity: none, barus (mu0 exp(alpha p)) or roelands (with the "
        "initial slope alpha); in the film and the friction. With a rigid bushing the pressure can "
        "become unbounded: use it with small_end.elastic",
    ),
    _f(
        "oil",
        "pressure_viscosity_GPa_inv",
        "pressure_viscosity",
        15.0,
        1e-9,
        0.0,
        100.0,
        unit="1/GPa",
        doc="pressure-viscosity coefficient alpha (engine oils: 10-20 1/GPa)",
    ),
    _f(
        "oil",
        "cavitation_pressure_bar",
        "cavitation_pressure",
        0.0,
        BAR,
        -1.01325,
        closed=True,
        unit="bar",
        doc="cavitation pressure, gauge (relative to the ambient pressure at the bushing edges)",
    ),
    FieldSpec(
        "oil",
        "cavitation",
        "cavitation",
        str,
        "reynolds",
        choices=("reynolds", "jfo"),
        doc="cavitation model: reynolds (p >= p_cav, the seed's model; not mass-conserving) or jfo "
        "(mass-conserving: the film fraction is carried through the cycle; inlet none or a supply; with "
        "inlet none it needs cavitation_pressure_bar < 0: the edges flooded, oil drawn in there). In "
        "an engine run the JFO film needs a finer resolution than the defaults for 2 % (mesh_size 0.047, "
        "rtol 1e-7, as `cases/reference-2000rpm-jfo`; the refinement study in docs/verification.md)",
    ),
    FieldSpec(
        "oil",
        "cavitated_shear",
        "cavitated_shear",
        str,
        "film-fraction",
        choices=("film-fraction", "full"),
        doc="cavitation = jfo: the Couette shear in the cavitated zone, film-fraction (theta mu U / h: only "
        "the oil streamers shear, as in Elrod's model; the default) or full (mu U / h, as in a full film: "
        "the friction before 2026-11-27). The Reynolds film (cavitation = reynolds) always shears in full",
    ),
    FieldSpec(
        "oil",
        "inlet",
        "inlet",
        str,
        "none",
        choices=INLETS,
        doc="oil inlet of the small end: none (cavitation alone decides), max-gap (ambient pressure "
        "along the line of maximum film thickness), or an oil supply at supply_pressure_bar: hole (a "
        "round hole), axial-groove (a rectangular axial groove) or circumferential-groove (a full "
        "circumferential groove), each centred on the mid-plane (below)",
    ),
    _f(
        "oil",
        "supply_hole_angle_deg",
        "supply_hole_angle",
        0.0,
        DEG,
        -360.0,
        360.0,
        unit="deg",
        doc="with inlet = hole: angle of the hole in the rod frame from the rod axis (0 = top of the "
        "small end)",
    ),
    _f(
        "oil",
        "supply_hole_diameter_mm",
        "supply_hole_diameter",
        3.0,
        1e-3,
        0.0,
        unit="mm",
        doc="with inlet = hole: hole diameter; < bushing width and < pin radius",
    ),
    _f(
        "oil",
        "groove_angle_deg",
        "groove_angle",
        0.0,
        DEG,
        -360.0,
        360.0,
        unit="deg",
        doc="with inlet = axial-groove: angle of the groove's centre in the rod frame from the rod "
        "axis (0 = top "
        "of the small end)",
    ),
    _f(
        "oil",
        "groove_arc_deg",
        "groove_arc",
        30.0,
        DEG,
        0.0,
        360.0,
        unit="deg",
        doc="with inlet = axial-groove: the groove's circumferential extent",
    ),
    _f(
        "oil",
        "groove_length_mm",
        "groove_length",
        10.0,
        1e-3,
        0.0,
        unit="mm",
        doc="with inlet = axial-groove: the groove's axial length; < bushing width",
    ),
    _f(
        "oil",
        "groove_width_mm",
        "groove_width",
        3.0,
        1e-3,
        0.0,
        unit="mm",
        doc="with inlet = circumferential-groove: the groove's axial width; < bushing width",
    ),
    _f(
        "oil",
        "supply_pressure_bar",
        "supply_pressure",
        0.0,
        BAR,
        0.0,
        1000.0,
        closed=True,
        unit="bar",
        doc="with inlet = hole or a groove: oil pressure in the supply, gauge",
    ),
    # [surface]
    _f(
        "surface", "sigma_pin_um", "sigma_pin", 0.1, 1e-6, 0.0, closed=True, unit="um", doc="pin roughness Rq"
    ),
    _f(
        "surface",
        "sigma_bushing_um",
        "sigma_bushing",
        0.3,
        1e-6,
        0.0,
        closed=True,
        unit="um",
        doc="bushing roughness Rq (composite sigma must be > 0)",
    ),
    _f(
        "surface", "peklenik_gamma", "peklenik_gamma", 1.0, 1.0, 0.0, doc="Peklenik surface pattern parameter"
    ),
    _f("surface", "eta_beta_sigma", "eta_beta_sigma", 0.05, 1.0, 0.0, doc="Greenwood-Tripp eta beta sigma"),
    _f("surface", "sigma_over_beta", "sigma_over_beta", 0.001, 1.0, 0.0, doc="Greenwood-Tripp sigma / beta"),
    _f("surface", "E_pin_GPa", "E_pin", 210.0, 1e9, 0.0, unit="GPa", doc="pin Young's modulus"),
    _f("surface", "nu_pin", "nu_pin", 0.3, 1.0, -1.0, 0.5, doc="pin Poisson ratio"),
    _f("surface", "E_bushing_GPa", "E_bushing", 115.0, 1e9, 0.0, unit="GPa", doc="bushing Young's modulus"),
    _f("surface", "nu_bushing", "nu_bushing", 0.33, 1.0, -1.0, 0.5, doc="bushing Poisson ratio"),
    _f(
        "surface",
        "composite_modulus_GPa",
        "composite_modulus",
        None,
        1e9,
        0.0,
        unit="GPa",
        doc="composite modulus E' (default: from the moduli and Poisson ratios, DESIGN 3.3)",
    ),
    _f(
        "surface",
        "asperity_friction",
        "asperity_friction",
        0.1,
        1.0,
        0.0,
        2.0,
        closed=True,
        doc="asperity friction coefficient (also the Coulomb coefficient of the dry joint)",
    ),
    _f(
        "surface",
        "restitution",
        "restitution",
        0.9,
        1.0,
        0.0,
        1.0,
        closed=True,
        doc="coefficient of restitution of the dry (Lankarani-Nikravesh) joint",
    ),
    _f(
        "surface",
        "impact_speed_m_s",
        "impact_speed",
        0.1,
        1.0,
        0.0,
        unit="m/s",
        doc="reference impact speed of the dry joint's hysteresis damping",
    ),
    # [solver]
    _f(
        "solver",
        "step_deg",
        "step",
        1.0,
        DEG,
        0.0,
        10.0,
        closed=False,
        unit="deg",
        doc="crank-angle step of the outputs; 720 / step_deg must be an integer",
    ),
    _f(
        "solver",
        "max_step_deg",
        "max_step",
        0.0,
        DEG,
        0.0,
        10.0,
        closed=True,
        unit="deg",
        doc="the time integrator's largest step, at most step_deg (0: step_deg, the outputs bound the "
        "steps); the coupled answers' time error is third order in it (docs/verification.md)",
    ),
    FieldSpec(
        "solver",
        "joint",
        "joint",
        str,
        "mixed-fem",
        choices=("mixed-fem", "short-bearing", "dry", "ideal"),
        doc="small-end model: finite-element mixed lubrication, Ocvirk short bearing, dry contact, or ideal",
    ),
    _f(
        "solver",
        "mesh_size",
        "mesh_size",
        None,
        1.0,
        0.0,
        1.0,
        doc="film element size / pin radius; when absent 0.07, and at least 10 elements across the "
        "half width",
    ),
    _f(
        "solver",
        "mesh_edge_size",
        "mesh_edge_size",
        None,
        1.0,
        0.0,
        1.0,
        doc="film element size / pin radius at the bushing's edges, graded to mesh_size over 0.3 R (absent: "
        "uniform); where the film cavitates below the edges' ambient pressure oil is drawn in through a "
        "layer at the edges (docs/verification.md)",
    ),
    _f("solver", "rtol", "rtol", 1e-6, 1.0, 0.0, 0.01, doc="relative tolerance of the time integration"),
    FieldSpec(
        "solver",
        "film_fraction_transport",
        "film_fraction_transport",
        str,
        "limited",
        choices=("limited", "upwind"),
        doc="oil.cavitation = jfo: the film fraction's transport, limited (second order, flux-corrected "
        "upwinding; the default) or upwind (first order: the scheme before 2026-11-26)",
    ),
    FieldSpec(
        "solver",
        "max_cycles",
        "max_cycles",
        int,
        4,
        minimum=1,
        maximum=100,
        doc="at most this many 720 deg cycles (the last one is reported)",
    ),
    _f(
        "solver",
        "periodic_tolerance",
        "periodic_tolerance",
        0.01,
        1.0,
        0.0,
        1.0,
        doc="periodic when the cycle minimum of h_min changes by less than this fraction of the clearance",
    ),
    FieldSpec(
        "solver",
        "periodic_acceleration",
        "periodic_acceleration",
        str,
        "none",
        choices=("none", "mpe", "film"),
        doc="the cycles' way to the periodic state: none (each cycle from the last one's end), mpe (after "
        "two cycles the next starts from the minimal polynomial extrapolation of the cycle-end states: "
        "positions, velocities, film fraction and deformation; then a plain cycle tests periodicity) or "
        "film (after each cycle the small end's film runs alone under that cycle's motion, one solve a "
        "step, until its film fraction is periodic under it, and the next cycle starts from it: for the "
        "mass-conserving film, whose oil settles slowly: a mixed-fem small end with oil.cavitation jfo); "
        "docs/models.md",
    ),
    _f(
        "solver",
        "periodic_friction_tolerance",
        "periodic_friction_tolerance",
        None,
        1.0,
        0.0,
        1.0,
        doc="also require the cycle-mean friction power to change by less than this fraction of itself from "
        "one cycle to the next (absent: not checked); a JFO film's min h_min can settle cycles before its "
        "friction",
    ),
    FieldSpec(
        "solver",
        "field_angles_deg",
        "field_angles",
        list,
        [0.0, 180.0, 360.0, 380.0, 540.0],
        DEG,
        0.0,
        720.0,
        False,
        doc="crank angles of the ParaView fields (pressure, film thickness, asperity pressure)",
    ),
    _f(
        "solver",
        "field_step_deg",
        "field_step",
        5.0,
        DEG,
        0.0,
        720.0,
        closed=True,
        unit="deg",
        doc="crank-angle step of the ParaView time series of the film fields (rounded to a multiple "
        "of step_deg, at least one; 0: none)",
    ),
    _f(
        "solver",
        "slip_regularisation_m_s",
        "slip_regularisation",
        1e-3,
        1.0,
        0.0,
        unit="m/s",
        doc="sliding speed below which asperity and Coulomb friction are smoothed",
    ),
)

# [big_end_surface]: the big end's (crankpin: pin_* keys; the big eye's shell: bushing_* keys) and
# [pin_boss_surface]: the floating pin's bosses' (the pin: pin_* keys; the piston's bosses: bushing_* keys),
# the keys of [surface] with the same names, units and ranges; a key the section does not give takes the
# case's [surface] value (load_case)
FIELDS = (
    tuple(spec for spec in FIELDS if spec.section != "solver")
    + tuple(
        dataclasses.replace(spec, section=section)
        for section in ("big_end_surface", "pin_boss_surface")
        for spec in FIELDS
        if spec.section == "surface"
    )
    + tuple(spec for spec in FIELDS if spec.section == "solver")
)

# [big_end]'s finite-element eye (elastic = fe): the small end's keys of the eye and its compliance, with
# the same names, units and ranges; the eye's default outer radius and the docs are the big eye's
_BIG_EYE = {
    "eye_outer_radius_mm": {
        "default": 37.0,
        "doc": "fe: outer radius of the rod's big eye, the cap continuous with it; > big_end.radius_mm + "
        "bushing_thickness_mm (the default: a wall of 11 mm around the shell's 25.8 mm, 1.43 times it, near "
        "the small end's 17 / 11.5 = 1.48; a rod cap of a 2 l engine's size)",
    },
    "E_eye_GPa": {"doc": "fe: Young's modulus of the rod's big eye (and cap)"},
    "nu_eye": {"doc": "fe: Poisson ratio of the rod's big eye (and cap)"},
    "shank_half_angle_deg": {
        "doc": "fe: half angle of the arc where the big eye joins the shank (clamped; the shank is toward "
        "the small end, at 0 deg of the rod frame)",
    },
    "compliance_basis": {},
    "compliance_modes": {},
    "compliance_grid_theta": {},
    "compliance_grid_z": {},
    "compliance_tolerance": {},
    "edge_relief_um": {
        "doc": "the big-end shell's relief at each edge: how much wider the gap is at the edge than in the "
        "cylindrical middle (0: cylindrical to the edges; with big_end.joint = mixed-fem; docs/models.md)",
    },
    "edge_relief_length_mm": {
        "doc": "with edge_relief_um > 0: the relieved length at each edge; < big_end.width_mm / 2",
    },
    "edge_relief_shape": {},
}
_at = next(i for i, s in enumerate(FIELDS) if s.section == "big_end" and s.key == "bushing_thickness_mm")
FIELDS = (
    FIELDS[: _at + 1]
    + tuple(
        dataclasses.replace(spec, section="big_end", **_BIG_EYE[spec.key])
        for spec in FIELDS
        if spec.section == "small_end" and spec.key in _BIG_EYE
    )
    + FIELDS[_at + 1 :]
)

SECTIONS = (
    "engine",
    "gas",
    "small_end",
    "big_end",
    "pin_boss",
    "oil",
    "surface",
    "big_end_surface",
    "pin_boss_surface",
    "solver",
)
#: Sections whose absent keys are another section's values, not the defaults (not counted as defaulted).
INHERITED = {"big_end_surface": "surface", "pin_boss_surface": "surface"}


def _specs(section: str) -> tuple[FieldSpec, ...]:
    return tuple(spec for spec in FIELDS if spec.section == section)


def _spec(section: str, attribute: str) -> FieldSpec:
    return next(spec for spec in FIELDS if spec.section == section and spec.attribute == attribute)


def _default(section: str, attribute: str) -> Any:
    spec = _spec(section, attribute)
    if spec.default is None or spec.kind is not float:
        return spec.default
    return spec.default * spec.scale


def _check_section(instance: Any, section: str) -> None:
    for spec in _specs(section):
        value = getattr(instance, spec.attribute)
        if spec.kind is float and value is not None:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(f"{spec.name} = {value!r} has the wrong type (expected a number)")
        spec.check(value)


def _field(section: str, attribute: str):
    return dataclasses.field(default=_default(section, attribute))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Engine:
    """Crank-rod-piston geometry, masses and speed (SI). See FIELDS for the meaning of each."""

    speed: float = _field("engine", "speed")  # rad/s
    speed_file: Path | None = None  # CSV crank_angle_deg, speed_rpm
    bore: float = _field("engine", "bore")  # m
    crank_radius: float = _field("engine", "crank_radius")  # m
    rod_length: float = _field("engine", "rod_length")  # m
    pin_offset: float = _field("engine", "pin_offset")  # m
    rod_mass: float = _field("engine", "rod_mass")  # kg
    rod_inertia: float = _field("engine", "rod_inertia")  # kg m^2
    rod_cg_from_big_end: float = _field("engine", "rod_cg_from_big_end")  # m
    piston_mass: float = _field("engine", "piston_mass")  # kg
    crank_mass: float = _field("engine", "crank_mass")  # kg
    crank_inertia: float = _field("engine", "crank_inertia")  # kg m^2
    gravity: bool = True

    def __post_init__(self) -> None:
        _check_section(self, "engine")
        limit = self.crank_radius + abs(self.pin_offset)
        if not self.rod_length > limit:
            raise out_of_range(
                "engine.rod_length_mm",
                f"{self.rod_length * 1e3:g}",
                f"> crank_radius_mm + |pin_offset_mm| = {limit * 1e3:g}",
            )
        if not self.rod_cg_from_big_end <= self.rod_length:
            raise out_of_range(
                "engine.rod_cg_from_big_end_mm",
                f"{self.rod_cg_from_big_end * 1e3:g}",
                f"[0, rod_length_mm = {self.rod_length * 1e3:g}]",
            )


@dataclasses.dataclass(frozen=True, kw_only=True)
class Gas:
    """Cylinder pressure model (SI; angles in rad, 360 deg = firing TDC)."""

    model: str = "single-zone"  # single-zone | motored | trace | none
    pressure_file: Path | None = None
    compression_ratio: float = _field("gas", "compression_ratio")
    polytropic_exponent: float = _field("gas", "polytropic_exponent")
    peak_pressure: float | None = _field("gas", "peak_pressure")  # Pa, absolute
    imep: float | None = None  # Pa
    combustion_start: float = _field("gas", "combustion_start")  # rad
    combustion_duration: float = _field("gas", "combustion_duration")  # rad
    wiebe_a: float = _field("gas", "wiebe_a")
    wiebe_m: float = _field("gas", "wiebe_m")
    intake_pressure: float = _field("gas", "intake_pressure")  # Pa, absolute
    exhaust_pressure: float = _field("gas", "exhaust_pressure")  # Pa, absolute
    exhaust_opening: float = _field("gas", "exhaust_opening")  # rad
    blowdown_duration: float = _field("gas", "blowdown_duration")  # rad
    valve_overlap: float = _field("gas", "valve_overlap")  # rad
    crankcase_pressure: float = _field("gas", "crankcase_pressure")  # Pa, absolute

    def __post_init__(self) -> None:
        _check_section(self, "gas")
        if self.model == "trace" and self.pressure_file is None:
            raise InputError('gas.pressure_file is required with gas.model = "trace"')
        if self.model != "trace" and self.pressure_file is not None:
            raise InputError(f'gas.pressure_file is only used with gas.model = "trace" (got "{self.model}")')
        if self.model == "single-zone" and self.peak_pressure is not None and self.imep is not None:
            raise InputError("give either gas.peak_pressure_bar or gas.imep_bar, not both")
        if self.model == "single-zone" and self.peak_pressure is None and self.imep is None:
            raise InputError("the single-zone model needs gas.peak_pressure_bar or gas.imep_bar")
        end = self.combustion_start + self.combustion_duration
        if not end < self.exhaust_opening:
            raise out_of_range(
                "gas.combustion_duration_deg",
                f"{self.combustion_duration / DEG:g}",
                f"< {(self.exhaust_opening - self.combustion_start) / DEG:g} (combustion must end before the "
                f"exhaust opens, gas.exhaust_opening_deg = {self.exhaust_opening / DEG:g})",
            )
        if not self.exhaust_opening + self.blowdown_duration + self.valve_overlap / 2 <= 4.0 * math.pi:
            raise out_of_range(
                "gas.blowdown_duration_deg",
                f"{self.blowdown_duration / DEG:g}",
                f"<= {720.0 - self.exhaust_opening / DEG - self.valve_overlap / DEG / 2:g} (the blowdown "
                "ends before the valve overlap)",
            )


@dataclasses.dataclass(frozen=True, kw_only=True)
class SmallEnd:
    """Small-end bearing geometry (SI)."""

    pin_radius: float = _field("small_end", "pin_radius")  # m
    width: float = _field("small_end", "width")  # m
    clearance: float = _field("small_end", "clearance")  # m, radial
    elastic: str = "none"
    bushing_thickness: float = _field("small_end", "bushing_thickness")  # m
    eye_outer_radius: float = _field("small_end", "eye_outer_radius")  # m
    E_eye: float = _field("small_end", "E_eye")  # Pa
    nu_eye: float = _field("small_end", "nu_eye")
    shank_half_angle: float = _field("small_end", "shank_half_angle")  # rad
    compliance_basis: str = _field("small_end", "compliance_basis")
    compliance_modes: int = _field("small_end", "compliance_modes")  # 0: from compliance_tolerance
    compliance_tolerance: float = _field("small_end", "compliance_tolerance")
    compliance_grid_theta: int = _field("small_end", "compliance_grid_theta")
    compliance_grid_z: int = _field("small_end", "compliance_grid_z")
    edge_relief_depth: float = _field("small_end", "edge_relief_depth")  # m, 0: none
    edge_relief_length: float = _field("small_end", "edge_relief_length")  # m
    edge_relief_shape: str = _field("small_end", "edge_relief_shape")
    pin: str = _field("small_end", "pin")  # fixed | floating
    pin_mass: float = _field("small_end", "pin_mass")  # kg, floating pin
    pin_inertia: float = _field("small_end", "pin_inertia")  # kg m^2, floating pin

    def __post_init__(self) -> None:
        _check_section(self, "small_end")
        nodes = self.compliance_grid_theta * self.compliance_grid_z
        if self.compliance_modes > nodes:
            raise out_of_range(
                "small_end.compliance_modes",
                self.compliance_modes,
                f"[0, {nodes}]: at most the grid's nodes, compliance_grid_theta x compliance_grid_z",
            )
        if self.elastic == "fe" and not self.eye_outer_radius > self.pin_radius + self.bushing_thickness:
            raise out_of_range(
                "small_end.eye_outer_radius_mm",
                f"{self.eye_outer_radius * 1e3:g}",
                f"> pin radius + bushing thickness = {(self.pin_radius + self.bushing_thickness) * 1e3:g}",
            )
        if self.edge_relief_depth > 0.0:
            check_edge_relief_length(self.edge_relief_length, self.width, "small_end")
        if not self.clearance < self.pin_radius:
            raise out_of_range(
                "small_end.clearance_um",
                f"{self.clearance * 1e6:g}",
                f"< pin_radius = {self.pin_radius * 1e6:g} um",
            )


@dataclasses.dataclass(frozen=True, kw_only=True)
class BigEnd:
    """Big-end bearing (crankpin in the rod's big eye) geometry and model (SI)."""

    joint: str = _field("big_end", "joint")  # one of BIG_END_JOINTS
    radius: float = _field("big_end", "radius")  # m, crankpin radius
    width: float = _field("big_end", "width")  # m
    clearance: float = _field("big_end", "clearance")  # m, radial
    supply: str = _field("big_end", "supply")  # one of BIG_END_SUPPLIES
    supply_pressure: float = _field("big_end", "supply_pressure")  # Pa, gauge
    supply_hole_diameter: float = _field("big_end", "supply_hole_diameter")  # m
    supply_hole_angle: float = _field("big_end", "supply_hole_angle")  # rad, crank frame
    elastic: str = _field("big_end", "elastic")  # none | winkler | fe
    bushing_thickness: float = _field("big_end", "bushing_thickness")  # m, the shell's wall
    # elastic = fe: the big eye (shank toward the small end) and its compliance, as SmallEnd's
    eye_outer_radius: float = _field("big_end", "eye_outer_radius")  # m
    E_eye: float = _field("big_end", "E_eye")  # Pa
    nu_eye: float = _field("big_end", "nu_eye")
    shank_half_angle: float = _field("big_end", "shank_half_angle")  # rad
    compliance_basis: str = _field("big_end", "compliance_basis")
    compliance_modes: int = _field("big_end", "compliance_modes")  # 0: from compliance_tolerance
    compliance_tolerance: float = _field("big_end", "compliance_tolerance")
    compliance_grid_theta: int = _field("big_end", "compliance_grid_theta")
    compliance_grid_z: int = _field("big_end", "compliance_grid_z")
    edge_relief_depth: float = _field("big_end", "edge_relief_depth")  # m, 0: none
    edge_relief_length: float = _field("big_end", "edge_relief_length")  # m
    edge_relief_shape: str = _field("big_end", "edge_relief_shape")

    def __post_init__(self) -> None:
        _check_section(self, "big_end")
        check_geometry(
            radius=self.radius,
            width=self.width,
            clearance=self.clearance,
            bushing_thickness=None if self.elastic == "none" else self.bushing_thickness,
            names=BIG_END_LENGTHS,
        )
        if self.edge_relief_depth > 0.0:
            check_edge_relief_length(self.edge_relief_length, self.width, "big_end")
        if self.elastic != "fe":
            return
        nodes = self.compliance_grid_theta * self.compliance_grid_z
        if self.compliance_modes > nodes:
            raise out_of_range(
                "big_end.compliance_modes",
                self.compliance_modes,
                f"[0, {nodes}]: at most the grid's nodes, compliance_grid_theta x compliance_grid_z",
            )
        if not self.eye_outer_radius > self.radius + self.bushing_thickness:
            raise out_of_range(
                "big_end.eye_outer_radius_mm",
                f"{self.eye_outer_radius * 1e3:g}",
                f"> radius + bushing thickness = {(self.radius + self.bushing_thickness) * 1e3:g}",
            )

    @property
    def lubricated(self) -> bool:
        """A clearance joint rather than an ideal revolute."""
        return self.joint != "ideal"


@dataclasses.dataclass(frozen=True, kw_only=True)
class PinBoss:
    """The floating pin's bearing in the piston's two bosses: two films of half the total width each, or
    one film of the total width (``films``; SI)."""

    joint: str = _field("pin_boss", "joint")  # short-bearing | ideal (the fixed pin)
    radius: float = _field("pin_boss", "radius")  # m, the pin's
    width: float = _field("pin_boss", "width")  # m, both bosses together
    films: int = _field("pin_boss", "films")  # 2: each boss its own film of width / 2; 1: one film
    clearance: float = _field("pin_boss", "clearance")  # m, radial
    viscosity_ratio: float = _field("pin_boss", "viscosity_ratio")  # of the oil's viscosity

    def __post_init__(self) -> None:
        _check_section(self, "pin_boss")
        check_geometry(radius=self.radius, width=self.width, clearance=self.clearance, names=PIN_BOSS_LENGTHS)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Oil:
    """Lubricant (SI)."""

    viscosity: float = _field("oil", "viscosity")  # Pa s (from the data below when they are given)
    grade: str | None = None
    kinematic_viscosity_40C: float | None = None  # mm^2/s
    kinematic_viscosity_100C: float | None = None  # mm^2/s
    density_15C: float | None = None  # kg/m^3
    temperature: float = _field("oil", "temperature")  # C (the supply temperature when thermal = effective)
    thermal: str = "isothermal"  # isothermal | effective (solver.study.thermal)
    specific_heat: float = _field("oil", "specific_heat")  # J/(kg K)
    heat_to_solids: float = _field("oil", "heat_to_solids")
    thermal_tolerance: float = _field("oil", "thermal_tolerance")
    piezoviscosity: str = "none"
    pressure_viscosity: float = _field("oil", "pressure_viscosity")  # 1/Pa
    cavitation_pressure: float = _field("oil", "cavitation_pressure")  # Pa, gauge
    cavitation: str = "reynolds"  # reynolds | jfo (solver.film.jfo)
    cavitated_shear: str = "film-fraction"  # film-fraction | full (solver.film.forms)
    inlet: str = "none"  # one of INLETS
    supply_hole_angle: float = _field("oil", "supply_hole_angle")  # rad, rod frame
    supply_hole_diameter: float = _field("oil", "supply_hole_diameter")  # m
    groove_angle: float = _field("oil", "groove_angle")  # rad, rod frame (axial groove)
    groove_arc: float = _field("oil", "groove_arc")  # rad (axial groove)
    groove_length: float = _field("oil", "groove_length")  # m (axial groove)
    groove_width: float = _field("oil", "groove_width")  # m (circumferential groove)
    supply_pressure: float = _field("oil", "supply_pressure")  # Pa, gauge

    def __post_init__(self) -> None:
        _check_section(self, "oil")
        data = self.data()
        if self.thermal == "effective" and data is None:
            raise InputError(
                'oil.thermal = "effective" needs the oil\'s viscosity against temperature: give '
                "oil.grade or the data sheet (oil.kinematic_viscosity_40C_cSt, ..._100C_cSt, "
                "density_15C_kg_m3), not a fixed oil.viscosity_Pa_s"
            )
        if data is not None:  # the film's viscosity at temperature_C (frozen: set once here; with thermal =
            # effective the first cycle's, solver.study.simulation sets the film's own between cycles)
            object.__setattr__(self, "viscosity", float(data.dynamic_viscosity(self.temperature)))

    def data(self) -> OilData | None:
        """The oil's data sheet (grade or the three values), or None when viscosity_Pa_s is used."""
        return oil_data(
            self.grade, self.kinematic_viscosity_40C, self.kinematic_viscosity_100C, self.density_15C
        )


@dataclasses.dataclass(frozen=True, kw_only=True)
class Surface:
    """Roughness, asperity contact and elastic constants (SI): the case's ``[surface]`` (the small end's pin
    and bushing); :class:`BigEndSurface` is the big end's, :class:`PinBossSurface` the floating pin's
    bosses'."""

    section: ClassVar[str] = "surface"

    sigma_pin: float = _field("surface", "sigma_pin")  # m, Rq
    sigma_bushing: float = _field("surface", "sigma_bushing")  # m, Rq
    peklenik_gamma: float = _field("surface", "peklenik_gamma")
    eta_beta_sigma: float = _field("surface", "eta_beta_sigma")
    sigma_over_beta: float = _field("surface", "sigma_over_beta")
    E_pin: float = _field("surface", "E_pin")  # Pa
    nu_pin: float = _field("surface", "nu_pin")
    E_bushing: float = _field("surface", "E_bushing")  # Pa
    nu_bushing: float = _field("surface", "nu_bushing")
    composite_modulus: float | None = None  # Pa, E'; None = from the moduli
    asperity_friction: float = _field("surface", "asperity_friction")
    restitution: float = _field("surface", "restitution")
    impact_speed: float = _field("surface", "impact_speed")  # m/s

    def __post_init__(self) -> None:
        _check_section(self, self.section)
        if not self.sigma > 0.0:
            raise InputError(
                f"{self.section}.sigma_pin_um and {self.section}.sigma_bushing_um are both 0 "
                "(allowed: composite roughness > 0)"
            )

    @property
    def sigma(self) -> float:
        """m, composite roughness sqrt(sigma_pin^2 + sigma_bushing^2)."""
        return math.hypot(self.sigma_pin, self.sigma_bushing)


@dataclasses.dataclass(frozen=True, kw_only=True)
class BigEndSurface(Surface):
    """The big end's surface (``[big_end_surface]``): the crankpin (pin_* keys) and the big eye's shell
    (bushing_* keys), the keys, units and ranges of :class:`Surface`; messages name
    ``big_end_surface.<key>``."""

    section: ClassVar[str] = "big_end_surface"


@dataclasses.dataclass(frozen=True, kw_only=True)
class PinBossSurface(Surface):
    """The floating pin's bosses' surface (``[pin_boss_surface]``): the pin (pin_* keys) and the piston's
    bosses (bushing_* keys), the keys, units and ranges of :class:`Surface`; messages name
    ``pin_boss_surface.<key>``. Used by the finite-element boss film (``pin_boss.joint = "mixed-fem"``)."""

    section: ClassVar[str] = "pin_boss_surface"


@dataclasses.dataclass(frozen=True, kw_only=True)
class Solver:
    """Numerical settings of the coupled run (SI; angles in rad)."""

    step: float = _field("solver", "step")  # rad, output crank-angle step
    max_step: float = _field("solver", "max_step")  # rad, the integrator's largest step (0: step)
    joint: str = "mixed-fem"
    mesh_size: float | None = _field(
        "solver", "mesh_size"
    )  # element size / pin radius; None: the film's default
    mesh_edge_size: float | None = _field("solver", "mesh_edge_size")  # element size / R at the edges
    rtol: float = _field("solver", "rtol")
    film_fraction_transport: str = "limited"  # limited | upwind (solver.film.jfo)
    max_cycles: int = 4
    periodic_tolerance: float = _field("solver", "periodic_tolerance")  # fraction of the clearance
    periodic_friction_tolerance: float | None = _field("solver", "periodic_friction_tolerance")  # None: off
    periodic_acceleration: str = "none"  # none | mpe (solver.study.periodic)
    field_angles: tuple[float, ...] = tuple(math.radians(a) for a in (0.0, 180.0, 360.0, 380.0, 540.0))  # rad
    field_step: float = _field("solver", "field_step")  # rad, ParaView series step (0: no series)
    slip_regularisation: float = _field("solver", "slip_regularisation")  # m/s

    def __post_init__(self) -> None:
        _check_section(self, "solver")
        count = 4.0 * math.pi / self.step
        if abs(count - round(count)) > 1e-9 * count:
            allowed = "(0, 10) with 720 / step_deg an integer"
            raise out_of_range("solver.step_deg", f"{self.step / DEG:g}", allowed)
        if self.max_step > self.step * (1 + 1e-12):
            allowed = f"[0, step_deg = {self.step / DEG:g}] (0: step_deg)"
            raise out_of_range("solver.max_step_deg", f"{self.max_step / DEG:g}", allowed)

    @property
    def steps_per_output(self) -> int:
        """The equal integrator intervals an output interval is divided into, each at most ``max_step``
        (1 when ``max_step`` is 0: the outputs bound the steps)."""
        return max(1, math.ceil(self.step / self.max_step - 1e-9)) if self.max_step > 0 else 1


@dataclasses.dataclass(frozen=True, kw_only=True)
class Case:
    """One operating point.

    Attributes:
        name: case name.
        directory: the case directory (relative file names are resolved against it; results go to
            ``directory / "results"``).
        description: free text.
        engine, gas, small_end, big_end, pin_boss, oil, surface, big_end_surface, pin_boss_surface,
            solver: the sections (``big_end_surface``, ``pin_boss_surface``: the big end's and the floating
            pin's bosses' surfaces; load_case fills the keys their sections do not give from ``[surface]``;
            built directly, their default is the defaults of Surface).
        defaulted: the sections the case file does not have (their defaults are used: all of them
            for an empty file, which is the reference engine); not a parameter of the case.
    """

    name: str
    directory: Path
    description: str = ""
    engine: Engine = dataclasses.field(default_factory=Engine)
    gas: Gas = dataclasses.field(default_factory=Gas)
    small_end: SmallEnd = dataclasses.field(default_factory=SmallEnd)
    big_end: BigEnd = dataclasses.field(default_factory=BigEnd)
    pin_boss: PinBoss = dataclasses.field(default_factory=PinBoss)
    oil: Oil = dataclasses.field(default_factory=Oil)
    surface: Surface = dataclasses.field(default_factory=Surface)
    big_end_surface: Surface = dataclasses.field(default_factory=BigEndSurface)
    pin_boss_surface: Surface = dataclasses.field(default_factory=PinBossSurface)
    solver: Solver = dataclasses.field(default_factory=Solver)
    defaulted: tuple[str, ...] = dataclasses.field(default=(), compare=False, repr=False)

    def __post_init__(self) -> None:
        _check_supply(self.oil, self.small_end)
        _check_pin(self)
        _check_big_end(self)
        if self.small_end.edge_relief_depth > 0.0 and self.solver.joint != "mixed-fem":
            raise InputError(
                f"small_end.edge_relief_um = {self.small_end.edge_relief_depth * 1e6:g} shapes the "
                f'finite-element film (allowed with solver.joint = "mixed-fem"; got {self.solver.joint!r}; '
                "or small_end.edge_relief_um = 0)"
            )
        # the film's compatibility rules, the same the bearing command and FilmSpec check
        check_film(
            cavitation=self.oil.cavitation,
            bushing=self.small_end.elastic,
            inlet="max-gap" if self.oil.inlet == "max-gap" else "none",
            supply=self.oil.inlet not in ("none", "max-gap"),
            cavitation_pressure=self.oil.cavitation_pressure,
            transport=self.solver.film_fraction_transport,
        )
        # a bearing no engine has is a length in the wrong unit (solver.film_rules, as the bearing command)
        check_geometry(
            radius=self.small_end.pin_radius,
            width=self.small_end.width,
            clearance=self.small_end.clearance,
            sigma=self.surface.sigma,
            bushing_thickness=None if self.small_end.elastic == "none" else self.small_end.bushing_thickness,
            names=CASE_LENGTHS,
        )


def _check_pin(case: Case) -> None:
    """A floating pin: lighter than the piston assembly it belongs to, a film in the bosses."""
    se = case.small_end
    if se.pin != "floating":
        return
    if not se.pin_mass < case.engine.piston_mass:
        raise out_of_range(
            "small_end.pin_mass_g",
            f"{se.pin_mass * 1e3:g}",
            f"(0, engine.piston_mass_kg = {case.engine.piston_mass * 1e3:g} g): the piston assembly holds "
            "the pin",
        )
    if case.pin_boss.joint == "ideal":
        raise InputError(
            'pin_boss.joint = "ideal" is the fixed pin (allowed with small_end.pin = "floating": '
            "'short-bearing' or 'mixed-fem'; or small_end.pin = \"fixed\")"
        )
    if case.pin_boss.joint == "mixed-fem" and case.oil.cavitation != "reynolds":
        # the bosses' film would carry a film fraction's history: not plumbed through the cycles for a third
        # film (checkpoint, cycle map)
        raise InputError(
            f'pin_boss.joint = "mixed-fem" with oil.cavitation = {case.oil.cavitation!r} is out of range '
            "(allowed: oil.cavitation = 'reynolds'; or pin_boss.joint = 'short-bearing')"
        )


def _check_big_end(case: Case) -> None:
    """A finite-element big end: the film of [oil] (Reynolds or JFO) in a rigid eye, a Winkler shell or
    the FE eye; a supply hole in the crankpin fed into it."""
    be = case.big_end
    if be.edge_relief_depth > 0.0 and be.joint != "mixed-fem":
        raise InputError(
            f"big_end.edge_relief_um = {be.edge_relief_depth * 1e6:g} shapes the finite-element film "
            f'(allowed with big_end.joint = "mixed-fem"; got {be.joint!r}; or big_end.edge_relief_um = 0)'
        )
    if be.supply == "hole":
        if be.joint != "mixed-fem":
            raise InputError(
                f'big_end.supply = "hole" is fed into the finite-element film (allowed with big_end.joint = '
                f'"mixed-fem"; got {be.joint!r})'
            )
        if case.oil.inlet == "max-gap":
            raise InputError(
                'big_end.supply = "hole" with oil.inlet = "max-gap" is out of range (allowed with a supply: '
                'oil.inlet "none", "hole", "axial-groove" or "circumferential-groove": the small end\'s own)'
            )
        limit = min(be.width, be.radius) * 1e3
        if not be.supply_hole_diameter * 1e3 < limit:
            raise out_of_range(
                "big_end.supply_hole_diameter_mm",
                f"{be.supply_hole_diameter * 1e3:g}",
                f"< min(big_end.width_mm, big_end.radius_mm) = {limit:g}",
            )
        if not be.supply_pressure >= case.oil.cavitation_pressure:
            raise out_of_range(
                "big_end.supply_pressure_bar",
                f"{be.supply_pressure / BAR:g}",
                f">= oil.cavitation_pressure_bar = {case.oil.cavitation_pressure / BAR:g}",
            )
    if be.elastic != "none" and be.joint != "mixed-fem":
        raise InputError(
            f"big_end.elastic = {be.elastic!r} deforms the finite-element film's shell (allowed with "
            f'big_end.joint = "mixed-fem"; got {be.joint!r}; or big_end.elastic = "none")'
        )
    if be.elastic != "none" and case.oil.inlet == "max-gap":
        raise InputError(
            f"big_end.elastic = {be.elastic!r} with oil.inlet = 'max-gap' is out of range: the film's "
            "history (deformation) cannot turn with the max-gap frame (allowed: oil.inlet 'none', 'hole' "
            'or a groove; or big_end.elastic = "none")'
        )
    if be.joint == "mixed-fem" and case.oil.cavitation == "jfo" and be.supply == "none":
        # the big end's film takes the oil of [oil] but not the small end's supply
        if not case.oil.cavitation_pressure < 0:
            raise InputError(
                f"oil.cavitation_pressure_bar = {case.oil.cavitation_pressure / BAR:g} with oil.cavitation "
                "= 'jfo' and a mixed-fem big end without a supply is out of range (allowed: < 0, the edges "
                'flooded above the cavitation pressure; or big_end.supply = "hole")'
            )


def _check_supply(oil: Oil, small_end: SmallEnd) -> None:
    """The oil supply (hole or groove, centred on the mid-plane) must fit on the small end's bushing."""
    width = small_end.width * 1e3  # mm
    if oil.inlet == "hole":
        limit = min(small_end.width, small_end.pin_radius) * 1e3
        if not oil.supply_hole_diameter * 1e3 < limit:
            raise out_of_range(
                "oil.supply_hole_diameter_mm",
                f"{oil.supply_hole_diameter * 1e3:g}",
                f"< min(small_end.width_mm, small_end.pin_radius_mm) = {limit:g}",
            )
    elif oil.inlet == "axial-groove" and not oil.groove_length * 1e3 < width:
        raise out_of_range(
            "oil.groove_length_mm",
            f"{oil.groove_length * 1e3:g}",
            f"(0, small_end.width_mm = {width:g}), inside the bushing",
        )
    elif oil.inlet == "circumferential-groove" and not oil.groove_width * 1e3 < width:
        raise out_of_range(
            "oil.groove_width_mm",
            f"{oil.groove_width * 1e3:g}",
            f"(0, small_end.width_mm = {width:g}), inside the bushing",
        )


_SECTION_CLASSES = {
    "engine": Engine,
    "gas": Gas,
    "small_end": SmallEnd,
    "big_end": BigEnd,
    "pin_boss": PinBoss,
    "oil": Oil,
    "surface": Surface,
    "big_end_surface": BigEndSurface,
    "pin_boss_surface": PinBossSurface,
    "solver": Solver,
}


def _unknown(name: str, known: list[str], where: str) -> InputError:
    close = difflib.get_close_matches(name, known, n=1)
    hint = f" (did you mean {close[0]}?)" if close else f" (known: {', '.join(known)})"
    return InputError(f"{where}: unknown key {name}{hint}")


def _convert(spec: FieldSpec, value: Any, directory: Path) -> Any:
    """TOML value -> SI value, with the type check."""
    if spec.kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"{spec.name} = {value!r} has the wrong type (expected a number)")
        return float(value) * spec.scale
    if spec.kind is bool:
        if not isinstance(value, bool):
            raise InputError(f"{spec.name} = {value!r} has the wrong type (expected true or false)")
        return value
    if spec.kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{spec.name} = {value!r} has the wrong type (expected an integer)")
        return value
    if spec.kind is list:
        if not isinstance(value, list) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
        ):
            raise InputError(f"{spec.name} = {value!r} has the wrong type (expected a list of numbers)")
        return tuple(float(v) * spec.scale for v in value)
    if not isinstance(value, str):
        raise InputError(f"{spec.name} = {value!r} has the wrong type (expected a string)")
    if spec.kind is Path:
        path = (directory / value).resolve()
        if not path.is_file():
            raise InputError(f"{spec.name} = {value!r}: file not found ({path})")
        return path
    return value


def load_case(path: str | Path) -> Case:
    """Read and validate a case: a directory containing ``case.toml``, or a TOML file.

    Raises:
        InputError: missing file, TOML syntax error, unknown section or key, wrong type, value out of
            range, inconsistent values; the message is one line naming ``section.key``.
    """
    path = Path(path)
    file = path / "case.toml" if path.is_dir() else path
    if not file.is_file():
        raise InputError(f"case file not found: {file}")
    data = read_toml_file(file, "case file")
    directory = file.parent.resolve()
    where = str(file)

    top_level = {spec.key: spec for spec in _specs("")}
    for key, value in data.items():
        if isinstance(value, dict):
            if key not in SECTIONS:
                close = difflib.get_close_matches(key, SECTIONS, n=1)
                hint = f"did you mean [{close[0]}]?" if close else f"known: {', '.join(SECTIONS)}"
                raise InputError(f"{where}: unknown section [{key}] ({hint})")
        elif key not in top_level:
            raise _unknown(key, list(top_level) + [f"[{s}]" for s in SECTIONS], where)

    values: dict[str, Any] = {}
    for key, spec in top_level.items():
        if key in data:
            values[spec.attribute] = _convert(spec, data[key], directory)
    values.setdefault("name", directory.name if file.name == "case.toml" else file.stem)

    for section, cls in _SECTION_CLASSES.items():
        table = data.get(section, {})
        if section in INHERITED:  # the keys not given: the other section's (given or default), same names
            table = {**data.get(INHERITED[section], {}), **table}
        specs = {spec.key: spec for spec in _specs(section)}
        arguments: dict[str, Any] = {}
        for key, value in table.items():
            if key not in specs:
                raise _unknown(f"{section}.{key}", [f"{section}.{k}" for k in specs], where)
            arguments[specs[key].attribute] = _convert(specs[key], value, directory)
        if (
            section == "oil"
            and "viscosity" in arguments
            and any(
                k in arguments
                for k in ("grade", "kinematic_viscosity_40C", "kinematic_viscosity_100C", "density_15C")
            )
        ):
            raise InputError(
                "give either oil.viscosity_Pa_s or the oil's data (oil.grade, or "
                "oil.kinematic_viscosity_40C_cSt/..._100C_cSt/density_15C_kg_m3), not both"
            )
        if section == "gas":
            if "imep" in arguments and "peak_pressure" in arguments:
                raise InputError("give either gas.peak_pressure_bar or gas.imep_bar, not both")
            if "imep" in arguments:
                arguments["peak_pressure"] = None
            arguments.setdefault("model", "trace" if "pressure_file" in arguments else "single-zone")
        values[section] = cls(**arguments)
    defaulted = tuple(section for section in SECTIONS if section not in data and section not in INHERITED)
    return Case(directory=directory, defaulted=defaulted, **values)


def defaults_note(case: Case) -> str | None:
    """The log line that says which sections came from the defaults (None: the case file has them all)."""
    if not case.defaulted:
        return None
    sections = ", ".join(f"[{section}]" for section in case.defaulted)
    if len(case.defaulted) == len(SECTIONS) - len(INHERITED):
        return f"the case file has no section: every default is used, the reference engine ({sections})"
    return f"sections not in the case file, defaults used: {sections}"


def case_attributes(case: Case) -> dict[str, object]:
    """Every case parameter as ``"section.key"`` in TOML units (netCDF-friendly values)."""
    attrs: dict[str, object] = {}
    for spec in FIELDS:
        holder = case if not spec.section else getattr(case, spec.section)
        value = getattr(holder, spec.attribute)
        if value is None:
            value = "none"
        elif spec.kind is float:
            value = float(value) / spec.scale
        elif spec.kind is list:
            value = np.array([v / spec.scale for v in value])
        elif spec.kind is bool:
            value = "true" if value else "false"
        elif spec.kind is int:
            value = int(value)
        else:
            value = str(value)
        attrs[spec.name] = value
    return attrs
