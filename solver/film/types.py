"""The film's value types (SI): a bearing's geometry and oil, the kinematics a film is solved for, and
what a solve gives (FilmResult, FilmJacobian, FilmStats, Equilibrium).

Numpy only: importing this module imports no dolfinx, PETSc or gmsh, so the dynamics and the study can
describe a film's state without loading the finite-element stack (a test checks it).

Conventions (DESIGN 3.1): everything is in the bushing frame. The eccentricity ``e' = (e'_x, e'_y)`` is
the journal centre minus the bushing centre; ``ecc_rate`` is the time derivative of those bushing-frame
components (it includes the frame's rotation, see ``Kinematics.from_global``). Forces act on the
journal (the bushing carries the opposite); torques are about each body's own centre, counter-clockwise
positive.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from solver.errors import InputError, out_of_range
from solver.film.supply import AxialGroove, CircumferentialGroove, Supply, SupplyHole

INLETS = ("max-gap", "none")
CAVITATION_MODELS = ("reynolds", "jfo")
#: the JFO film fraction's transport in time (solver.film.jfo): "limited", second order
#: (TransportLimiter, from the last committed film fraction), or "upwind", first order (Kuzmin's
#: discrete upwinding alone, the scheme before the limiter); quasi-static solves are upwind either way
TRANSPORT_SCHEMES = ("limited", "upwind")
GROOVES = ("none", "axial", "circumferential")
MAX_ECCENTRICITY = 0.9995  # equilibrium search limit (h_min = 5e-4 c)
STALL_TOLERANCE = 1e-3  # relative force residual accepted when Newton's method stalls on the VI's kinks
DEFAULT_MESH_SIZE = 0.07  # element size / R: ~1600 nodes on the half film for B/D = 1 (bench/)
AXIAL_ELEMENTS = 10  # at least this many elements across the half width (bench/bearing_mesh_convergence.py)

#: |e| / c the pin may reach in an elastic bushing (the deformation then holds the film open); under a
#: static load the equilibrium raises it to what the compliance gives (solver.film.solvers.CoupledFilm.reach)
ELASTIC_MAX_ECCENTRICITY = 2.0


def default_mesh_size(width: float, radius: float) -> float:
    """Element size / R that resolves both directions: DEFAULT_MESH_SIZE around the bearing, and at
    least AXIAL_ELEMENTS across the half width, where the pressure falls to the edges (a narrow
    bearing with 0.07 R gets two or three elements there and loses ~7 % of its load at B/D = 1/8)."""
    return min(DEFAULT_MESH_SIZE, 0.5 * width / radius / AXIAL_ELEMENTS)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Bearing:
    """Geometry and oil of a plain journal bearing (SI).

    Pressures are gauge pressures relative to the ambient pressure at the bearing edges.
    """

    radius: float  # m, nominal radius R
    width: float  # m, bearing width B
    clearance: float  # m, radial clearance c
    viscosity: float  # Pa s, dynamic viscosity mu
    cavitation_pressure: float = 0.0  # Pa gauge, p_cav (<= 0)
    supply_pressure: float = 0.0  # Pa gauge, pressure in the supply hole or groove (if any)
    supply_hole_angle: float | None = None  # rad, bushing angle of an oil hole (None: no hole)
    supply_hole_diameter: float = 0.0  # m
    groove: str = "none"  # oil groove, centred on the mid-plane: "none", "axial" or "circumferential"
    groove_angle: float = 0.0  # rad, axial groove: bushing angle of its centre
    groove_arc: float = 0.0  # rad, axial groove: its circumferential extent, in (0, 2 pi)
    groove_length: float = 0.0  # m, axial groove: its axial length, < width
    groove_width: float = 0.0  # m, circumferential groove: its axial width, < width
    inlet: str = "max-gap"  # "max-gap": ambient pressure along the line of maximum film thickness; "none"

    def __post_init__(self) -> None:
        for name in ("radius", "width", "clearance", "viscosity"):
            if not getattr(self, name) > 0:
                raise out_of_range(name, getattr(self, name), "> 0")
        if not self.clearance < 0.1 * self.radius:
            raise out_of_range(
                "clearance", self.clearance, f"< 0.1 radius = {0.1 * self.radius:g} m (thin film)"
            )
        if not self.cavitation_pressure <= 0:
            raise out_of_range("cavitation_pressure", self.cavitation_pressure, "<= 0 Pa gauge")
        if self.supply_hole_angle is not None and not 0 < self.supply_hole_diameter < min(
            self.width, self.radius
        ):
            raise out_of_range("supply_hole_diameter", self.supply_hole_diameter, "(0, min(width, radius))")
        if self.inlet not in INLETS:
            raise out_of_range("inlet", repr(self.inlet), " or ".join(map(repr, INLETS)))
        if self.groove not in GROOVES:
            raise out_of_range("groove", repr(self.groove), ", ".join(map(repr, GROOVES)))
        if self.groove != "none" and self.supply_hole_angle is not None:
            raise InputError(
                f"groove = {self.groove!r} with a supply hole (allowed: one oil supply, a hole or a groove)"
            )
        if self.groove == "axial":
            if not math.isfinite(self.groove_angle):
                raise out_of_range("groove_angle", self.groove_angle, "a finite number of rad")
            if not 0 < self.groove_arc < 2 * math.pi:
                raise out_of_range("groove_arc", f"{self.groove_arc:g}", "(0, 2 pi) rad")
            if not 0 < self.groove_length < self.width:
                raise out_of_range(
                    "groove_length", f"{self.groove_length:g}", f"(0, width = {self.width:g}) m"
                )
        if self.groove == "circumferential" and not 0 < self.groove_width < self.width:
            raise out_of_range("groove_width", f"{self.groove_width:g}", f"(0, width = {self.width:g}) m")
        if self.supply is not None:
            if not self.supply_pressure >= self.cavitation_pressure:  # (also NaN)
                raise out_of_range(
                    "supply_pressure",
                    f"{self.supply_pressure:g}",
                    f">= cavitation_pressure = {self.cavitation_pressure:g} Pa gauge",
                )

    @property
    def supply(self) -> Supply | None:
        """The oil supply on the film mesh (dimensionless, solver.film.mesh): hole, groove or None."""
        R = self.radius
        if self.supply_hole_angle is not None:
            return SupplyHole(angle=self.supply_hole_angle, diameter=self.supply_hole_diameter / R)
        if self.groove == "axial":
            return AxialGroove(angle=self.groove_angle, arc=self.groove_arc, length=self.groove_length / R)
        if self.groove == "circumferential":
            return CircumferentialGroove(width=self.groove_width / R)
        return None


@dataclasses.dataclass(frozen=True)
class Kinematics:
    """Relative kinematics of journal and bushing in the bushing frame (SI)."""

    ecc: tuple[float, float]  # m, journal centre - bushing centre, bushing frame
    ecc_rate: tuple[float, float] = (0.0, 0.0)  # m/s, d/dt of the bushing-frame components
    omega_journal: float = 0.0  # rad/s, absolute angular speed of the journal
    omega_bushing: float = 0.0  # rad/s, absolute angular speed of the bushing

    @staticmethod
    def from_global(
        r_journal,
        v_journal,
        r_bushing,
        v_bushing,
        phi_bushing: float,
        omega_journal: float,
        omega_bushing: float,
    ) -> Kinematics:
        """From global centre positions/velocities: ``e' = A^T e``, ``de'/dt = A^T de/dt - omega_b S e'``."""
        c, s = math.cos(phi_bushing), math.sin(phi_bushing)
        A_T = np.array([[c, s], [-s, c]])
        e_b = A_T @ (np.asarray(r_journal, float) - np.asarray(r_bushing, float))
        rate = A_T @ (np.asarray(v_journal, float) - np.asarray(v_bushing, float)) - omega_bushing * np.array(
            [-e_b[1], e_b[0]]
        )
        return Kinematics(
            (float(e_b[0]), float(e_b[1])), (float(rate[0]), float(rate[1])), omega_journal, omega_bushing
        )


@dataclasses.dataclass(frozen=True)
class FilmResult:
    """Results of one film solve (SI, bushing frame).

    Forces act on the journal (the bushing carries the opposite); torques are about each body's own
    centre, counter-clockwise positive. ``force`` and the ``torque_*`` totals include asperity
    contact; without a contact model its parts are zero.
    """

    force: tuple[float, float]  # N, total (film + asperity) force on the journal
    hydro_force: tuple[float, float]  # N, film pressure force on the journal
    asperity_force: tuple[float, float]  # N, asperity contact force on the journal
    p_max: float  # Pa gauge, peak film pressure
    p_max_theta: float  # rad, bushing angle of the peak
    p_max_z: float  # m, axial position of the peak (0 = mid-width)
    h_min: float  # m, minimum film thickness
    torque_journal: float  # N m, friction torque on the journal (viscous + asperity)
    torque_bushing: float  # N m, friction torque on the bushing (viscous + asperity)
    asperity_torque_journal: (
        float  # N m, asperity part of torque_journal (friction + moment of the normal forces)
    )
    asperity_normal_force: float  # N, integral of p_c over the surface (what asperity friction acts on)
    contact_area_ratio: float  # real contact area / nominal bearing area
    asperity_p_max: float  # Pa, peak asperity contact pressure (at h_min)
    side_flow: float  # m^3/s, flow out of both edges (Poiseuille, positive outward)
    iterations: int  # Newton (VI) iterations
    solve_time: float  # s, wall time of the solve (assembly + VI)
    sigma: float = 0.0  # m, composite roughness (0: smooth)
    supply_flow: float = 0.0  # m^3/s, flow from the supply hole or groove into the film (0: no supply)
    max_deformation: float = (
        0.0  # m, the bushing's largest radial deformation (signed, + opens the gap; 0: rigid)
    )
    max_deformation_theta: float = 0.0  # rad, its bushing angle
    cavitated_area_ratio: float = (
        0.0  # ruptured film area / bearing area (theta < 1, or p at p_cav: Reynolds)
    )
    oil_volume: float = math.nan  # m^3, oil held in the film, integral of theta h_T (JFO; NaN: Reynolds)

    @property
    def load(self) -> float:
        """|force| [N]: the load carried by film and asperities together."""
        return math.hypot(*self.force)

    @property
    def hydro_load(self) -> float:
        return math.hypot(*self.hydro_force)

    @property
    def asperity_load(self) -> float:
        return math.hypot(*self.asperity_force)

    @property
    def h_min_over_sigma(self) -> float:
        return self.h_min / self.sigma if self.sigma > 0 else math.inf


@dataclasses.dataclass(frozen=True)
class FilmJacobian:
    """d(output)/d(input) at the last solution, active set frozen (SI).

    Rows: total force_x, force_y, torque_journal, torque_bushing. Columns: ecc_x, ecc_y (per m),
    ecc_rate_x, ecc_rate_y (per m/s), omega_journal - omega_bushing (per rad/s).
    """

    matrix: np.ndarray  # (4, 5)

    @property
    def force_ecc(self) -> np.ndarray:
        return self.matrix[:2, :2]


#: the rows of FilmJacobian (the film's functionals add up to them)
JACOBIAN_ROWS = ("force_x", "force_y", "torque_journal", "torque_bushing")


@dataclasses.dataclass
class FilmStats:
    """Work done by a FilmModel so far (counts and wall seconds); the run reports it per cycle."""

    solves: int = 0
    vi_iterations: int = 0  # SNES VI (Newton) iterations of all solves
    failures: int = 0  # solves that did not converge
    jacobians: int = 0
    transport_fallbacks: int = 0  # JFO, limited transport: committed states whose step fell back to upwinding
    euler_rate_steps: int = 0  # film with history: committed steps whose rate was implicit Euler (grown fast)
    solve_seconds: float = 0.0  # assembly, VI and functionals
    jacobian_seconds: float = 0.0  # sensitivities and their functionals

    def copy(self) -> "FilmStats":
        return dataclasses.replace(self)


@dataclasses.dataclass(frozen=True)
class Equilibrium:
    """Static equilibrium of the journal under a load."""

    kinematics: Kinematics
    result: FilmResult
    newton_iterations: int
    force_residual: float  # N, |film force + load| at the solution
