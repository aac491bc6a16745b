"""``python3 -m solver bearing``: one journal bearing, at a given eccentricity or under a load.

The journal turns at ``--speed`` rpm and the bushing at ``--bushing-speed`` rpm (default 0; both
counter-clockwise for positive speeds) about the fixed x, y axes in which the load and the journal
centre are given (the bushing's own axes at the instant they coincide with them). The load acts on
the journal along -y ("downwards"); ``--attitude`` places the journal centre that many degrees from
the load line in the direction of the mean surface speed. The steady film is driven by the sum of the
surface speeds (the wedge, R (omega_j + omega_b) / 2 relative to the load line), the Couette friction
by their difference (the sliding speed R (omega_j - omega_b)). With ``--eccentricity-rate`` the journal
also moves along the line of centres (pure squeeze if the speeds are 0). All inputs and outputs are SI
except the speeds (rpm) and angles (degrees).

An oil supply (a round hole, a rectangular axial groove or a full circumferential groove, centred on
the mid-plane) is held at ``--supply-pressure``; it goes with ``--inlet none`` (its default then).
The report gives the flow from the supply into the film beside the side flow (solver.film.bearing).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from solver.case import FIELDS
from solver.errors import InputError
from solver.film.surface import Surface
from solver.film.types import TRANSPORT_SCHEMES
from solver.film_rules import (
    CLEARANCE_RATIO_RANGE,
    FLAG_LENGTHS,
    RADIUS_RANGE,
    WIDTH_RATIO_RANGE,
    check_geometry,
    default_inlet,
    reference_speed,
)
from solver.study import io


def _number(
    name: str,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = True,
    high_open: bool = True,
    allowed: str = "",
):
    """An argparse type: a finite float inside the given range, else a one-line error naming it."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{name} = {text!r} is not a number (allowed: {allowed})"
            ) from None
        ok = math.isfinite(value)
        if ok and low is not None:
            ok = value > low if low_open else value >= low
        if ok and high is not None:
            ok = value < high if high_open else value <= high
        if not ok:
            raise argparse.ArgumentTypeError(f"{name} = {text} is out of range (allowed: {allowed})")
        return value

    return parse


def _integer(name: str, low: int, high: int):
    """An argparse type: an integer in [low, high], else a one-line error naming it."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"{name} = {text} is out of range (allowed: an integer in [{low}, {high}])"
            )
        return value

    return parse


def add_geometry_arguments(parser: argparse.ArgumentParser) -> None:
    """Bearing geometry, oil and inlet (shared with the stribeck command)."""
    g = parser.add_argument_group("bearing")
    g.add_argument(
        "--radius",
        required=True,
        type=_number("--radius", 0, allowed="> 0 m"),
        help=f"journal radius R [m] (SI: 12 mm is 0.012; in [{RADIUS_RANGE[0]:g}, {RADIUS_RANGE[1]:g}])",
    )
    g.add_argument(
        "--width",
        required=True,
        type=_number("--width", 0, allowed="> 0 m"),
        help=f"bearing width B [m] (B / R in [{WIDTH_RATIO_RANGE[0]:g}, {WIDTH_RATIO_RANGE[1]:g}])",
    )
    g.add_argument(
        "--clearance",
        required=True,
        type=_number("--clearance", 0, allowed="> 0 m"),
        help=f"radial clearance c [m] (c / R in [{CLEARANCE_RATIO_RANGE[0]:g}, "
        f"{CLEARANCE_RATIO_RANGE[1]:g}], above the composite roughness)",
    )
    g.add_argument(
        "--viscosity",
        type=_number("--viscosity", 0, allowed="> 0 Pa s"),
        default=None,
        help="dynamic viscosity [Pa s]; or the oil's data: --grade, or --kinematic-viscosity-40C, "
        "--kinematic-viscosity-100C and --density, at --temperature",
    )
    g.add_argument(
        "--grade",
        default=None,
        help="SAE grade with typical data-sheet values (0W-20, 0W-30, 5W-30, 5W-40, 10W-40, 15W-40)",
    )
    g.add_argument(
        "--kinematic-viscosity-40C",
        dest="nu40",
        type=_number("--kinematic-viscosity-40C", 0, allowed="> 0 cSt"),
        default=None,
        help="kinematic viscosity at 40 C [cSt = mm^2/s]",
    )
    g.add_argument(
        "--kinematic-viscosity-100C",
        dest="nu100",
        type=_number("--kinematic-viscosity-100C", 0, allowed="> 0 cSt"),
        default=None,
        help="kinematic viscosity at 100 C [cSt]",
    )
    g.add_argument(
        "--density",
        type=_number("--density", 0, allowed="> 0 kg/m^3"),
        default=None,
        help="density at 15 C [kg/m^3]",
    )
    g.add_argument(
        "--temperature",
        type=_number("--temperature", -40, 250, low_open=False, high_open=False, allowed="[-40, 250] C"),
        default=None,
        help="oil temperature [C] for the data-sheet viscosity (default 100)",
    )
    g.add_argument(
        "--speed",
        type=_number("--speed", allowed="a finite number of rpm"),
        default=0.0,
        help="journal speed [rpm] (default 0)",
    )
    g.add_argument(
        "--cavitation-pressure",
        type=_number("--cavitation-pressure", high=0, high_open=False, allowed="<= 0 Pa gauge"),
        default=0.0,
        help="cavitation pressure [Pa gauge] (default 0)",
    )
    g.add_argument(
        "--cavitation",
        choices=("reynolds", "jfo"),
        default="reynolds",
        help="cavitation model: reynolds (p >= p_cav, default) or jfo (mass-conserving; the steady, "
        "quasi-static solution; one rank, degree 1)",
    )
    g.add_argument(
        "--cavitated-shear",
        choices=("film-fraction", "full"),
        default="film-fraction",
        help="with --cavitation jfo: the Couette shear in the cavitated zone, film-fraction (theta mu U / h: "
        "only the oil streamers shear; default) or full (mu U / h, the friction before 2026-11-27)",
    )
    g.add_argument(
        "--inlet",
        choices=("max-gap", "none"),
        default=None,
        help="max-gap: ambient pressure along the line of maximum film thickness (the tables' "
        "assumption, the default where the model allows it); none: cavitation alone decides (the "
        "default, and the only choice, with an oil supply below or with --elastic fe)",
    )
    add_supply_arguments(parser)


def add_supply_arguments(parser: argparse.ArgumentParser) -> None:
    """The oil supply: a round hole, a rectangular axial groove or a full circumferential groove, each centred
    on the mid-plane and held at --supply-pressure. Angles are bushing angles [deg] from the bushing's +x
    axis toward +y (the load acts along -y, at -90)."""
    g = parser.add_argument_group("oil supply (one of: a hole, an axial groove, a circumferential groove)")
    g.add_argument(
        "--hole-angle",
        type=_number("--hole-angle", -360, 360, allowed="(-360, 360) deg"),
        default=None,
        help="round hole: bushing angle of its centre [deg] (with --hole-diameter)",
    )
    g.add_argument(
        "--hole-diameter",
        type=_number("--hole-diameter", 0, allowed="(0, min(width, radius)) m"),
        default=None,
        help="round hole: diameter [m]",
    )
    g.add_argument(
        "--groove-angle",
        type=_number("--groove-angle", -360, 360, allowed="(-360, 360) deg"),
        default=None,
        help="axial groove: bushing angle of its centre [deg] (with --groove-arc and --groove-length)",
    )
    g.add_argument(
        "--groove-arc",
        type=_number("--groove-arc", 0, 360, allowed="(0, 360) deg"),
        default=None,
        help="axial groove: circumferential extent [deg]",
    )
    g.add_argument(
        "--groove-length",
        type=_number("--groove-length", 0, allowed="(0, width) m"),
        default=None,
        help="axial groove: axial length [m]",
    )
    g.add_argument(
        "--circumferential-groove",
        metavar="WIDTH",
        type=_number("--circumferential-groove", 0, allowed="(0, width) m"),
        default=None,
        help="a full circumferential groove of this axial width [m]",
    )
    g.add_argument(
        "--supply-pressure",
        type=_number("--supply-pressure", 0, low_open=False, allowed=">= 0 Pa gauge"),
        default=None,
        help="oil pressure in the hole or groove [Pa gauge] (default 0)",
    )


SUPPLY_FLAGS = {  # supply -> its flags (argparse dest, flag)
    "hole": (("hole_angle", "--hole-angle"), ("hole_diameter", "--hole-diameter")),
    "axial-groove": (
        ("groove_angle", "--groove-angle"),
        ("groove_arc", "--groove-arc"),
        ("groove_length", "--groove-length"),
    ),
    "circumferential-groove": (("circumferential_groove", "--circumferential-groove"),),
}


def resolve_supply(args, quasi_static: bool = True) -> None:
    """Check the oil supply options, set ``args.supply`` (``"none"`` or a key of SUPPLY_FLAGS) and
    ``args.inlet`` (default: solver.film_rules.default_inlet, max-gap where the model allows it for a
    quasi-static film, or for a film in time with ``quasi_static=False``); errors name the flags."""
    given = [
        name
        for name, flags in SUPPLY_FLAGS.items()
        if any(getattr(args, dest) is not None for dest, _ in flags)
    ]
    if len(given) > 1:
        flags = " and ".join(SUPPLY_FLAGS[name][0][1] for name in given)
        raise InputError(
            f"{flags}: two oil supplies (allowed: one of a hole, an axial groove, a circumferential groove)"
        )
    args.supply = given[0] if given else "none"
    if args.supply != "none":
        missing = [flag for dest, flag in SUPPLY_FLAGS[args.supply] if getattr(args, dest) is None]
        if missing:
            present = [flag for dest, flag in SUPPLY_FLAGS[args.supply] if getattr(args, dest) is not None]
            raise InputError(
                f"{' '.join(present)} without {' and '.join(missing)} (allowed: all of "
                f"{', '.join(flag for _, flag in SUPPLY_FLAGS[args.supply])})"
            )
        if args.supply == "hole" and not args.hole_diameter < min(args.width, args.radius):
            raise InputError(
                f"--hole-diameter = {args.hole_diameter:g} is out of range (allowed: (0, min(width, "
                f"radius)) = (0, {min(args.width, args.radius):g}) m)"
            )
        if args.supply == "axial-groove" and not args.groove_length < args.width:
            raise InputError(
                f"--groove-length = {args.groove_length:g} is out of range (allowed: (0, width) = "
                f"(0, {args.width:g}) m)"
            )
        if args.supply == "circumferential-groove" and not args.circumferential_groove < args.width:
            raise InputError(
                f"--circumferential-groove = {args.circumferential_groove:g} is out of range (allowed: "
                f"(0, width) = (0, {args.width:g}) m)"
            )
    elif args.supply_pressure is not None:
        raise InputError(
            "--supply-pressure without an oil supply (allowed: with --hole-*, --groove-* or "
            "--circumferential-groove)"
        )
    if args.inlet is None:  # the default the model allows (solver.film_rules)
        args.inlet = default_inlet(
            cavitation=getattr(args, "cavitation", "reynolds"),
            bushing=getattr(args, "elastic", "none"),
            supply=args.supply != "none",
            quasi_static=quasi_static,
        )


def _case_default(key: str):
    """The default of a case's [surface] key (solver.case.FIELDS), in its unit."""
    return next(spec.default for spec in FIELDS if spec.section == "surface" and spec.key == key)


SURFACE_FLAGS = {  # Surface field -> (flag, argparse type, help)
    "sigma_journal": (
        "--sigma-journal",
        _number("--sigma-journal", 0, low_open=False, allowed=">= 0 m"),
        f"Rq roughness of the journal [m] (default 0: smooth, unlike an engine case, whose pin has "
        f"surface.sigma_pin_um = {_case_default('sigma_pin_um'):g} um)",
    ),
    "sigma_bushing": (
        "--sigma-bushing",
        _number("--sigma-bushing", 0, low_open=False, allowed=">= 0 m"),
        f"Rq roughness of the bushing [m] (default 0: smooth, unlike an engine case, whose bushing has "
        f"surface.sigma_bushing_um = {_case_default('sigma_bushing_um'):g} um)",
    ),
    "peklenik_gamma": (
        "--peklenik-gamma",
        _number("--peklenik-gamma", 0, allowed="> 0, fits in [1/9, 9]"),
        "Peklenik surface pattern parameter (default 1, isotropic)",
    ),
    "eta_beta_sigma": (
        "--eta-beta-sigma",
        _number("--eta-beta-sigma", 0, allowed="> 0"),
        "Greenwood-Tripp eta*beta*sigma (default 0.05)",
    ),
    "sigma_over_beta": (
        "--sigma-over-beta",
        _number("--sigma-over-beta", 0, allowed="> 0"),
        "Greenwood-Tripp sigma/beta (default 0.001)",
    ),
    "asperity_density": (
        "--asperity-density",
        _number("--asperity-density", 0, allowed="> 0 1/m^2"),
        "asperity density eta [1/m^2] (instead of --eta-beta-sigma)",
    ),
    "asperity_radius": (
        "--asperity-radius",
        _number("--asperity-radius", 0, allowed="> 0 m"),
        "asperity radius beta [m] (instead of --sigma-over-beta)",
    ),
    "E_journal": (
        "--E-journal",
        _number("--E-journal", 0, allowed="> 0 Pa"),
        "Young's modulus of the journal [Pa]",
    ),
    "nu_journal": (
        "--nu-journal",
        _number("--nu-journal", -1, 0.5, allowed="(-1, 0.5)"),
        "Poisson's ratio of the journal",
    ),
    "E_bushing": (
        "--E-bushing",
        _number("--E-bushing", 0, allowed="> 0 Pa"),
        "Young's modulus of the bushing [Pa]",
    ),
    "nu_bushing": (
        "--nu-bushing",
        _number("--nu-bushing", -1, 0.5, allowed="(-1, 0.5)"),
        "Poisson's ratio of the bushing",
    ),
    "E_composite": (
        "--E-composite",
        _number("--E-composite", 0, allowed="> 0 Pa"),
        "composite modulus E' [Pa] (instead of the moduli and Poisson's ratios)",
    ),
    "asperity_friction": (
        "--asperity-friction",
        _number("--asperity-friction", 0, 2, low_open=False, allowed="[0, 2)"),
        "asperity friction coefficient (default 0.1)",
    ),
}


def add_surface_arguments(parser: argparse.ArgumentParser) -> None:
    """Roughness, asperity and material options (solver.film.surface.Surface; defaults: the reference
    engine)."""
    g = parser.add_argument_group(
        "surfaces (mixed lubrication: rough when a sigma > 0; smooth by default, unlike an engine case)"
    )
    for field, (flag, type_, help_text) in SURFACE_FLAGS.items():
        g.add_argument(flag, dest=field, type=type_, default=None, help=help_text)
    g.add_argument(
        "--asperity-model",
        dest="asperity_model",
        choices=("exact", "fit"),
        default=None,
        help="F_5/2 by quadrature (exact, default) or the common fit",
    )


def surface_from_args(args):
    """The Surface of the parsed options; errors name the command-line flag."""
    given = {f: getattr(args, f) for f in (*SURFACE_FLAGS, "asperity_model") if getattr(args, f) is not None}
    if "asperity_density" in given:
        given.setdefault("eta_beta_sigma", None)
    if "asperity_radius" in given:
        given.setdefault("sigma_over_beta", None)
    try:
        return Surface(**given)
    except InputError as err:
        message = str(err)
        for field, (flag, _, _) in SURFACE_FLAGS.items():
            message = message.replace(field, flag)
        raise InputError(message.replace("asperity_model", "--asperity-model")) from None


def add_elastic_arguments(parser: argparse.ArgumentParser) -> None:
    """The bushing's deformation and the oil's piezoviscosity (DESIGN 7; solver.film.ehd,
    solver.film.viscosity)."""
    g = parser.add_argument_group("elastic bushing and piezoviscous oil")
    g.add_argument(
        "--elastic",
        choices=("none", "winkler", "fe"),
        default="none",
        help="bushing deformation: none (rigid, default), winkler (thin bushing on a rigid housing, "
        "needs --bushing-thickness) or fe (finite-element eye and bushing, cached on disk; needs "
        "--bushing-thickness and --eye-outer-radius; without --inlet its inlet is none, the one it allows)",
    )
    g.add_argument(
        "--bushing-thickness",
        type=_number("--bushing-thickness", 0, allowed="> 0 m"),
        default=None,
        help="bushing wall thickness [m] (moduli: --E-bushing, --nu-bushing)",
    )
    g.add_argument(
        "--eye-outer-radius",
        type=_number("--eye-outer-radius", 0, allowed="> radius + bushing thickness"),
        default=None,
        help="outer radius of the housing (the rod's eye) [m]",
    )
    g.add_argument(
        "--E-housing",
        type=_number("--E-housing", 0, allowed="> 0 Pa"),
        default=210e9,
        help="Young's modulus of the housing (eye) [Pa] (default 210e9, steel)",
    )
    g.add_argument(
        "--nu-housing",
        type=_number("--nu-housing", 0, 0.5, low_open=False, allowed="[0, 0.5)"),
        default=0.3,
        help="Poisson's ratio of the housing (default 0.3)",
    )
    g.add_argument(
        "--shank-angle",
        type=_number("--shank-angle", -360, 360, allowed="(-360, 360) deg"),
        default=90.0,
        help="fe: bushing angle of the middle of the clamped arc where the eye joins the "
        "shank (default 90: +y, opposite the load, as a rod in tension)",
    )
    g.add_argument(
        "--shank-half-angle",
        type=_number("--shank-half-angle", 0, 90, allowed="(0, 90) deg"),
        default=30.0,
        help="fe: half angle of that arc (default 30 deg)",
    )
    g.add_argument(
        "--compliance-basis",
        choices=("layer", "eigen"),
        default="eigen",
        help="fe: eigen (modes of the whole compliance; default) or layer (the bushing's local compression "
        "node by node plus modes of the rest: a thin bushing on a stiff housing)",
    )
    g.add_argument(
        "--compliance-modes",
        type=int,
        default=0,
        help="fe: modes of the compliance kept (default 0: the fewest within --compliance-tolerance)",
    )
    g.add_argument(
        "--compliance-grid",
        nargs=2,
        type=int,
        default=(72, 5),
        metavar=("N_THETA", "N_Z"),
        help="fe: nodes of the compliance's grid around the bore and over the half width (default 72 5)",
    )
    g.add_argument(
        "--compliance-tolerance",
        type=_number("--compliance-tolerance", 0, 1, allowed="(0, 1)"),
        default=0.001,
        help="fe: the truncation error under the reference loads the modes are chosen for (default 0.001)",
    )
    g.add_argument(
        "--piezoviscosity",
        choices=("none", "barus", "roelands"),
        default="none",
        help="pressure dependence of the viscosity (default none)",
    )
    g.add_argument(
        "--pressure-viscosity",
        type=_number("--pressure-viscosity", 0, 1e-7, allowed="(0, 1e-7) 1/Pa"),
        default=1.5e-8,
        help="pressure-viscosity coefficient alpha [1/Pa] (default 1.5e-8)",
    )


def elastic_from_args(args, surface):
    """(bushing, piezoviscosity) descriptions of the parsed options (after _check_elastic; cheap: the FE
    eye is built by the film's factory); the bushing's moduli are the surface's."""
    from solver.film.bushings import bushing_model
    from solver.film.viscosity import viscosity_law

    elastic = bushing_model(
        args.elastic,
        radius=args.radius,
        width=args.width,
        bushing_thickness=args.bushing_thickness,
        eye_outer_radius=args.eye_outer_radius,
        E_eye=args.E_housing,
        nu_eye=args.nu_housing,
        E_bushing=surface.E_bushing,
        nu_bushing=surface.nu_bushing,
        shank_half_angle_deg=args.shank_half_angle,
        modes=args.compliance_modes,
        shank_angle_deg=args.shank_angle,
        tolerance=args.compliance_tolerance,
        basis=args.compliance_basis,
        grid=tuple(args.compliance_grid),
    )
    return elastic, viscosity_law(args.piezoviscosity, args.pressure_viscosity, args.viscosity)


def _check_elastic(args, comm) -> None:
    if args.elastic == "none":
        return
    if args.bushing_thickness is None:
        raise InputError(f"--elastic {args.elastic} needs --bushing-thickness (allowed: > 0 m)")
    if args.elastic == "fe":
        if args.eye_outer_radius is None or not args.eye_outer_radius > args.radius + args.bushing_thickness:
            raise InputError(
                f"--eye-outer-radius = {args.eye_outer_radius} is out of range (allowed: > radius + "
                f"bushing thickness = {args.radius + args.bushing_thickness:g} m)"
            )
        n_theta, n_z = args.compliance_grid
        if not (12 <= n_theta <= 720 and 2 <= n_z <= 65):
            raise InputError(
                f"--compliance-grid = {n_theta} {n_z} is out of range (allowed: [12, 720] nodes around, "
                "[2, 65] over the half width)"
            )
        if not 0 <= args.compliance_modes <= n_theta * n_z:
            raise InputError(
                f"--compliance-modes = {args.compliance_modes} is out of range (allowed: "
                f"[0, {n_theta * n_z}], the grid's nodes; 0: from --compliance-tolerance)"
            )


def add_relief_arguments(parser: argparse.ArgumentParser) -> None:
    """The bore's edge relief (solver.film.relief)."""
    g = parser.add_argument_group("bore profile")
    g.add_argument(
        "--edge-relief",
        type=_number("--edge-relief", 0, low_open=False, allowed=">= 0 m"),
        default=0.0,
        help="the bore's relief at each edge [m]: how much wider the gap is at the edge than in the "
        "cylindrical middle (default 0: cylindrical to the edges)",
    )
    g.add_argument(
        "--edge-relief-length",
        type=_number("--edge-relief-length", 0, allowed="> 0 m, < --width / 2"),
        default=3e-3,
        help="the relieved length at each edge [m] (default 0.003; < --width / 2)",
    )
    g.add_argument(
        "--edge-relief-shape",
        choices=("parabolic", "linear"),
        default="parabolic",
        help="the relief's profile: parabolic (a crowned edge, tangent to the bore; default) or linear "
        "(a taper)",
    )


def edge_relief_from_args(args):
    """The EdgeRelief of the options, or None (no relief); a one-line error unless it leaves the bore's
    middle cylindrical."""
    if not getattr(args, "edge_relief", 0.0):
        return None
    from solver.film.relief import EdgeRelief

    if not args.edge_relief_length < 0.5 * args.width:
        raise InputError(
            f"--edge-relief-length = {args.edge_relief_length:g} is out of range (allowed: > 0 m, "
            f"< --width / 2 = {0.5 * args.width:g} m)"
        )
    return EdgeRelief(depth=args.edge_relief, length=args.edge_relief_length, shape=args.edge_relief_shape)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The bearing command's arguments."""
    add_geometry_arguments(parser)
    add_relief_arguments(parser)
    add_surface_arguments(parser)
    add_elastic_arguments(parser)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument(
        "--eccentricity",
        type=_number("--eccentricity", 0, 1, low_open=False, allowed="[0, 1)"),
        help="eccentricity ratio e/c",
    )
    mode.add_argument("--load", type=_number("--load", 0, allowed="> 0 N"), help="load on the journal [N]")
    mode.add_argument(
        "--motion",
        type=Path,
        metavar="FILE",
        help="the film in time under a prescribed motion: a CSV file with the columns time_s, ecc_x_m, "
        "ecc_y_m (bushing frame) and optionally ecc_rate_x_m_s, ecc_rate_y_m_s, journal_speed_rpm, "
        "bushing_speed_rpm (solver.cli.motion; docs/user-guide.md)",
    )
    parser.add_argument(
        "--fields",
        action="store_true",
        help="with --motion and --output: the film's fields at every row as one ParaView time series "
        "DIR/bearing_motion.xdmf (+ .h5; time in s)",
    )
    parser.add_argument(
        "--start",
        choices=("full", "steady"),
        default=None,
        help="with --motion: the film's history at the first row, full (film fraction 1 one row before "
        "it; default) or steady (the steady film at the first row, as an engine run starts)",
    )
    parser.add_argument(
        "--substeps",
        type=_integer("--substeps", 1, 10000),
        default=None,
        help="with --motion: internal steps per row interval (default 1), the motion interpolated by "
        "cubic Hermite between the rows and the film's history committed at each; the time "
        "discretisation's error (e.g. the mass-conserving film's oil balance) falls as their square",
    )
    parser.add_argument(
        "--transport",
        choices=TRANSPORT_SCHEMES,
        default=None,
        help="with --motion and --cavitation jfo: the film fraction's transport in time, limited "
        "(second order, flux-corrected; default) or upwind (first order, the steady film's: a constant "
        "motion then keeps the steady answer)",
    )
    parser.add_argument(
        "--bushing-speed",
        type=_number("--bushing-speed", allowed="a finite number of rpm"),
        default=0.0,
        help="bushing speed [rpm] through the fixed load line (default 0); the steady film carries load "
        "by the sum of the speeds, the sliding (Couette friction) is their difference",
    )
    parser.add_argument(
        "--attitude",
        type=_number("--attitude", -360, 360, allowed="(-360, 360) deg"),
        default=None,
        help="with --eccentricity: angle of the line of centres from the load line [deg]",
    )
    parser.add_argument(
        "--eccentricity-rate",
        type=_number("--eccentricity-rate", allowed="a finite number of 1/s"),
        default=0.0,
        help="d(eps)/dt along the line of centres [1/s] (squeeze)",
    )
    n = parser.add_argument_group("numerics and output")
    n.add_argument(
        "--mesh-size",
        type=_number("--mesh-size", 0, 1, high_open=False, allowed="(0, 1] (element size / R)"),
        default=None,
        help="element size / radius (default: 0.07, and at least 10 elements across the half width)",
    )
    n.add_argument(
        "--mesh-edge-size",
        type=_number("--mesh-edge-size", 0, 1, high_open=False, allowed="(0, 1] (element size / R)"),
        default=None,
        help="element size / radius at the edges, graded to --mesh-size over 0.3 R (default: uniform); "
        "where the film cavitates below the edges' ambient pressure oil is drawn in at the edges",
    )
    n.add_argument(
        "--degree", type=int, choices=(1, 2), default=1, help="pressure element degree (default 1)"
    )
    n.add_argument("--json", action="store_true", help="print one JSON object")
    n.add_argument(
        "--output",
        type=Path,
        default=None,
        help="directory for the XDMF fields (for ParaView: the half film z >= 0, the film being symmetric "
        "about the mid-plane) and the PNG pressure map (the whole width)",
    )


def check_plausible(args) -> None:
    """A bearing no engine has is most likely a length in the wrong unit (the command takes metres):
    solver.film_rules.check_geometry, the rules a case's [small_end] meets, naming the flags."""
    elastic = getattr(args, "elastic", "none")
    check_geometry(
        radius=args.radius,
        width=args.width,
        clearance=args.clearance,
        sigma=surface_from_args(args).sigma,
        bushing_thickness=None if elastic == "none" else args.bushing_thickness,
        names=FLAG_LENGTHS,
    )


def _check(args) -> None:
    check_plausible(args)
    _check_speeds(args)
    if args.attitude is not None and args.eccentricity is None:
        raise InputError("--attitude goes with --eccentricity (allowed: omit it with --load)")
    if args.eccentricity is not None and args.eccentricity == 0 and args.eccentricity_rate == 0:
        pass  # concentric rotation: zero load, still a valid question (friction, flow)


def _check_speeds(args) -> None:
    """The journal's and the bushing's speeds: something moves; a load needs a wedge (a sum of the
    surface speeds); a turning bushing only where the quasi-static film is the steady one."""
    if args.load is not None and args.speed == 0 and args.bushing_speed == 0:
        raise InputError(
            "--speed = 0 and --bushing-speed = 0 with --load: a static load needs rotation (allowed: "
            "--speed != 0 or --bushing-speed != 0)"
        )
    if args.speed == 0 and args.bushing_speed == 0 and args.eccentricity_rate == 0:
        raise InputError(
            "--speed = 0, --bushing-speed = 0 and --eccentricity-rate = 0: nothing moves (allowed: one "
            "non-zero)"
        )
    if args.load is not None and args.speed + args.bushing_speed == 0:
        raise InputError(
            f"--speed = {args.speed:g} and --bushing-speed = {args.bushing_speed:g} with --load: pure "
            "counter-rotation (no mean surface speed, no wedge) carries no steady load (allowed: "
            "--speed + --bushing-speed != 0)"
        )
    if args.bushing_speed != 0:
        # In the bushing's frame the film's pattern turns at -omega_b; the quasi-static film keeps the
        # eccentricity's rate but not the rates of the deformation or of the film fraction.
        if args.elastic != "none":
            raise InputError(
                f"--bushing-speed = {args.bushing_speed:g} with --elastic {args.elastic} (allowed: "
                "--bushing-speed 0, or --elastic none)"
            )
        if args.cavitation == "jfo":
            raise InputError(
                f"--bushing-speed = {args.bushing_speed:g} with --cavitation jfo (allowed: --bushing-speed "
                "0, or --cavitation reynolds)"
            )


def resolve_viscosity(args) -> None:
    """Set ``args.viscosity`` [Pa s] from --viscosity or from the oil's data (solver.oil), and
    ``args.temperature``: one kind of input, not both (the same rules as a case's [oil])."""
    from solver.oil import oil_data

    given = args.grade is not None or any(v is not None for v in (args.nu40, args.nu100, args.density))
    if args.viscosity is not None:
        if given or args.temperature is not None:
            raise InputError(
                "--viscosity with the oil's data (--grade, --kinematic-viscosity-*, --density, "
                "--temperature) (allowed: one of the two)"
            )
        return
    flags = {
        "grade": "--grade",
        "kinematic_viscosity_40C": "--kinematic-viscosity-40C",
        "kinematic_viscosity_100C": "--kinematic-viscosity-100C",
        "density_15C": "--density",
    }
    oil = oil_data(args.grade, args.nu40, args.nu100, args.density, names=flags)
    if oil is None:
        raise InputError(
            "no viscosity (allowed: --viscosity, --grade, or --kinematic-viscosity-40C with "
            "--kinematic-viscosity-100C and --density)"
        )
    args.temperature = 100.0 if args.temperature is None else args.temperature
    args.viscosity = float(oil.dynamic_viscosity(args.temperature))


def bearing_from_args(args):
    """The Bearing of the parsed options (after resolve_viscosity and resolve_supply)."""
    from solver.film.types import Bearing

    supply = {}
    if args.supply == "hole":
        supply = {
            "supply_hole_angle": math.radians(args.hole_angle),
            "supply_hole_diameter": args.hole_diameter,
        }
    elif args.supply == "axial-groove":
        supply = {
            "groove": "axial",
            "groove_angle": math.radians(args.groove_angle),
            "groove_arc": math.radians(args.groove_arc),
            "groove_length": args.groove_length,
        }
    elif args.supply == "circumferential-groove":
        supply = {"groove": "circumferential", "groove_width": args.circumferential_groove}
    return Bearing(
        radius=args.radius,
        width=args.width,
        clearance=args.clearance,
        viscosity=args.viscosity,
        cavitation_pressure=args.cavitation_pressure,
        inlet=args.inlet,
        supply_pressure=args.supply_pressure or 0.0,
        **supply,
    )


def film_spec(args, bearing, surface, omega_ref: float, sliding: float, quasi_static: bool):
    """The FilmSpec of the parsed options (the film's rules checked, before any mesh or compliance:
    solver.film_rules): ``omega_ref`` the scaling's reference speed [rad/s], ``sliding`` the sliding
    angular speed [rad/s] that sets the asperity friction's regularisation."""
    from solver.film.spec import FilmSpec

    bushing, piezoviscosity = elastic_from_args(args, surface)
    return FilmSpec(
        bearing=bearing,
        omega_ref=omega_ref,
        mesh_size=args.mesh_size,
        mesh_edge_size=getattr(args, "mesh_edge_size", None),
        degree=args.degree,
        roughness=surface.roughness(),
        contact=surface.contact(),
        slip_regularisation=1e-3 * args.radius * abs(sliding) if sliding else 1e-3,
        bushing=bushing,
        piezoviscosity=piezoviscosity,
        cavitation=args.cavitation,
        cavitated_shear=args.cavitated_shear,
        transport=getattr(args, "transport", None) or "limited",
        quasi_static=quasi_static,
        edge_relief=edge_relief_from_args(args),
    )


def run_motion(args, comm) -> int:
    """``--motion FILE``: the film in time (quasi_static=False, the engine's) driven through the motion
    (solver.study.motion.drive), reported by solver.cli.motion; returns the exit status."""
    from solver.cli import motion as report
    from solver.study.motion import drive, reference_speed

    report.check(args)
    resolve_viscosity(args)
    resolve_supply(args, quasi_static=False)
    check_plausible(args)
    _check_elastic(args, comm)
    motion = report.motion_of(args)
    start = args.start or "full"
    args.substeps = args.substeps or 1
    if args.transport is not None and args.cavitation != "jfo":
        raise InputError(
            f"--transport {args.transport} with --cavitation {args.cavitation} "
            "(allowed: with --cavitation jfo)"
        )
    args.transport = args.transport or "limited"
    sliding = float(max(abs(motion.omega_journal - motion.omega_bushing)))
    clock = time.perf_counter()
    spec = film_spec(
        args,
        bearing_from_args(args),
        surface_from_args(args),
        reference_speed(motion, args.clearance),
        sliding,
        quasi_static=False,
    )
    spec.check(ranks=comm.size)
    from solver.film.factory import make_film  # dolfinx: after the checks

    with make_film(spec, comm) as model:
        setup_time = time.perf_counter() - clock
        every = report.PROGRESS_ROWS if len(motion) > report.PROGRESS_ROWS else 0
        series = report.field_series(args, comm, model)
        try:
            after_row = None if series is None else (lambda i: series.write(float(motion.time[i])))
            result = drive(
                model, motion, start, progress_every=every, after_row=after_row, substeps=args.substeps
            )
        except BaseException:
            if series is not None:
                series.abort()
            raise
        if series is not None:
            series.close()
        dofs = model.dofs
    return report.report(args, comm, motion, result, dofs, setup_time, start)


def run(args, comm) -> int:
    """Solve and report; returns the exit status."""
    if args.motion is not None:
        return run_motion(args, comm)
    if args.fields:
        raise InputError(
            "--fields goes with --motion (allowed: omit it without --motion; --output writes the fields)"
        )
    for flag, value, why in (
        ("--start", args.start, ""),
        ("--substeps", args.substeps, ""),
        ("--transport", args.transport, "; the steady film's transport is upwind"),
    ):
        if value is not None:
            raise InputError(
                f"{flag} {value} goes with --motion (allowed: omit it with --eccentricity or --load{why})"
            )
    resolve_viscosity(args)
    resolve_supply(args)
    _check(args)
    _check_elastic(args, comm)
    from solver.film.equilibrium import equilibrium
    from solver.film.types import Kinematics

    bearing = bearing_from_args(args)
    surface = surface_from_args(args)
    omega = args.speed * 2 * math.pi / 60
    omega_b = args.bushing_speed * 2 * math.pi / 60
    wedge = omega + omega_b  # twice the mean surface speed / R, relative to the fixed load line
    sliding = omega - omega_b  # the journal's speed relative to the bushing (Couette friction)
    rate = args.eccentricity_rate
    omega_ref = reference_speed(wedge, sliding, rate)
    start = time.perf_counter()
    spec = film_spec(args, bearing, surface, omega_ref, sliding, quasi_static=True)
    spec.check(ranks=comm.size)
    from solver.film.factory import make_film  # dolfinx: after the checks

    model = make_film(spec, comm)
    setup_time = time.perf_counter() - start
    c = args.clearance
    load_angle = -math.pi / 2  # the load acts along -y
    residual = None
    if args.load is not None:
        W = (args.load * math.cos(load_angle), args.load * math.sin(load_angle))
        eq = equilibrium(model, W, omega_journal=omega, omega_bushing=omega_b, load_frame="space")
        kin, result, newton_iterations, residual = (
            eq.kinematics,
            eq.result,
            eq.newton_iterations,
            eq.force_residual,
        )
    else:
        sense = 1.0 if (wedge or sliding) >= 0 else -1.0
        angle = load_angle + sense * math.radians(args.attitude or 0.0)
        direction = (math.cos(angle), math.sin(angle))
        # the journal centre fixed in space, the bushing turning through it (bushing frame at the
        # instant its axes are the fixed ones): the engine's kinematics
        kin = Kinematics.from_global(
            (args.eccentricity * c * direction[0], args.eccentricity * c * direction[1]),
            (rate * c * direction[0], rate * c * direction[1]),
            (0.0, 0.0),
            (0.0, 0.0),
            0.0,
            omega,
            omega_b,
        )
        result = model.solve(kin)
        newton_iterations = result.iterations
    eps = math.hypot(*kin.ecc) / c
    load = result.load
    # Attitude: angle between the load line (opposite the film force) and the line of centres.
    attitude = float("nan")
    if eps > 0 and load > 0:
        load_dir = math.atan2(-result.force[1], -result.force[0])
        attitude = abs((math.degrees(math.atan2(kin.ecc[1], kin.ecc[0]) - load_dir) + 180.0) % 360.0 - 180.0)
    psi = c / args.radius
    speed_for_So = abs(wedge) if wedge != 0 else abs(rate)
    So = (
        load * psi**2 / (args.width * 2 * args.radius * args.viscosity * speed_for_So)
        if speed_for_So > 0
        else math.nan  # pure counter-rotation at a given eccentricity: no wedge, no squeeze
    )
    report = {
        "load_N": load,
        "attitude_deg": attitude,
        "eccentricity": eps,
        "sommerfeld_So": So,
        "p_max_Pa": result.p_max,
        "h_min_m": result.h_min,
        "friction_torque_Nm": result.torque_journal,
        "side_flow_m3_per_s": result.side_flow,
        "dofs": model.dofs,
        "newton_iterations": newton_iterations,
        "solve_time_s": time.perf_counter() - start - setup_time,
        # additions (keys above are the interface)
        "force_x_N": result.force[0],
        "force_y_N": result.force[1],
        "friction_torque_bushing_Nm": result.torque_bushing,
        "p_max_angle_deg": math.degrees(result.p_max_theta),
        "p_max_z_m": result.p_max_z,
        "ecc_x_m": kin.ecc[0],
        "ecc_y_m": kin.ecc[1],
        "vi_iterations": result.iterations,
        "setup_time_s": setup_time,
        # mixed lubrication
        "hydro_load_N": result.hydro_load,
        "asperity_load_N": result.asperity_load,
        "asperity_share": result.asperity_load / load if load > 0 else 0.0,
        "contact_area_ratio": result.contact_area_ratio,
        "friction_coefficient": abs(result.torque_journal) / (args.radius * load) if load > 0 else math.inf,
        "asperity_friction_torque_Nm": result.asperity_torque_journal,
        "power_loss_W": abs(result.torque_journal * omega + result.torque_bushing * omega_b),
        "h_min_over_sigma": result.h_min_over_sigma if surface.rough else None,
        # elastic bushing and piezoviscous oil
        "viscosity_Pa_s": args.viscosity,
        "temperature_C": args.temperature,
        "elastic": args.elastic,
        "piezoviscosity": args.piezoviscosity,
        "max_deformation_m": result.max_deformation,
        "max_deformation_angle_deg": math.degrees(result.max_deformation_theta),
        # oil supply
        "inlet": args.inlet,
        "supply": args.supply,
        "supply_pressure_Pa": args.supply_pressure or 0.0,
        "supply_flow_m3_per_s": result.supply_flow,
        # cavitation
        "cavitation": args.cavitation,
        "cavitated_area_ratio": result.cavitated_area_ratio,
        # the bushing's motion (speeds [rpm]; surface speeds [m/s], relative to the fixed load line)
        "speed_rpm": args.speed,
        "bushing_speed_rpm": args.bushing_speed,
        "sliding_speed_m_per_s": args.radius * sliding,
        "entrainment_speed_m_per_s": args.radius * wedge / 2,
        "cavitated_shear": args.cavitated_shear,
        # the bore's edge relief (0: cylindrical to the edges)
        "edge_relief_m": getattr(args, "edge_relief", 0.0),
        "edge_relief_length_m": getattr(args, "edge_relief_length", None),
        "edge_relief_shape": getattr(args, "edge_relief_shape", None),
    }
    if residual is not None:
        report["force_residual_N"] = residual
    report["attitude_deg"] = None if math.isnan(attitude) else attitude
    report["sommerfeld_So"] = None if math.isnan(So) else So
    if args.output is not None:
        out = args.output
        if comm.rank == 0:
            out.mkdir(parents=True, exist_ok=True)
        comm.Barrier()
        io.write_film_fields(out, "bearing_pressure", model)
        io.plot_pressure_map(
            out / "bearing_pressure.png",
            model,
            title=f"eps = {eps:.3f}, load = {load:.4g} N, p_max = {result.p_max / 1e6:.3g} MPa",
        )
        if comm.rank == 0:
            io.write_json(out / "bearing.json", report)
    model.close()
    if comm.rank == 0:
        if args.json:
            print(json.dumps(report))
        else:
            _print_table(report, sys.stdout)
    return 0


def _print_table(report: dict, stream) -> None:
    rows = [
        ("eccentricity ratio", report["eccentricity"], ""),
        ("load", report["load_N"], "N"),
        ("attitude angle", report["attitude_deg"], "deg"),
        ("Sommerfeld number So", report["sommerfeld_So"], ""),
        ("peak pressure", report["p_max_Pa"] / 1e6, "MPa"),
        ("minimum film thickness", report["h_min_m"] * 1e6, "um"),
        ("sliding speed", report["sliding_speed_m_per_s"], "m/s"),
        ("friction torque on journal", report["friction_torque_Nm"], "N m"),
        ("friction torque on bushing", report["friction_torque_bushing_Nm"], "N m"),
        ("side flow", report["side_flow_m3_per_s"] * 6e4, "l/min"),
        ("dofs", report["dofs"], ""),
        ("Newton iterations", report["newton_iterations"], ""),
        ("solve time", report["solve_time_s"], "s"),
    ]
    if "force_residual_N" in report:
        rows.append(("force residual", report["force_residual_N"], "N"))
    if report["supply"] != "none":
        rows.append(("supply flow", report["supply_flow_m3_per_s"] * 6e4, "l/min"))
    if report["h_min_over_sigma"] is not None:
        rows += [
            ("hydrodynamic load", report["hydro_load_N"], "N"),
            ("asperity load", report["asperity_load_N"], "N"),
            ("h_min / sigma", report["h_min_over_sigma"], ""),
            ("real contact area ratio", report["contact_area_ratio"], ""),
        ]
    rows += [
        ("friction coefficient", report["friction_coefficient"], ""),
        ("power loss", report["power_loss_W"], "W"),
    ]
    if report["elastic"] != "none":
        rows.append(("largest bushing deformation", report["max_deformation_m"] * 1e6, "um"))
    rows.append((f"cavitated area ({report['cavitation']})", report["cavitated_area_ratio"], ""))
    for label, value, unit in rows:
        text = "n/a" if value is None else f"{value:14.6g}"
        print(f"{label:28s} {text:>14s} {unit}", file=stream)
