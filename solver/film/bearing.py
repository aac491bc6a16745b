"""The finite-element film of one journal bearing: kinematics in, forces, friction and flow out (SI).

``FilmModel`` owns the film mesh, the UFL forms (solver.film.reynolds) and the SNES VI (solver.film.cavitation).
It is built once per bearing and reused across solves: a change of kinematics only updates
``fem.Constant``s, reassembles the operator and the source, and warm-starts the VI from the last
pressure. After a solve, ``jacobian()`` gives the exact derivatives of the film forces and torques
with respect to the eccentricity and its rate (active set frozen), from back-substitutions with one
factorisation.

Conventions (DESIGN 3.1): everything is expressed in the bushing frame. The eccentricity
``e' = (e'_x, e'_y)`` is the journal centre minus the bushing centre; ``ecc_rate`` is the time
derivative of those bushing-frame components (it includes the frame's rotation, see
``Kinematics.from_global``). Surface speeds relative to the bushing: bushing 0, journal
``R (omega_journal - omega_bushing)``. The film force on the journal is ``-integral(p n dA)`` with n
the outward normal of the journal; the bushing carries the opposite force. Friction torques are
positive counter-clockwise (the direction of increasing theta), about each body's own centre.

Oil inlet (``Bearing.inlet``). ``"max-gap"``: the film is at ambient pressure along the axial line
of maximum film thickness, where the oil is taken to enter (the assumption of the classic
finite-bearing tables of Butenschoen 1976 and Raimondi & Boyd 1958); cavitation elsewhere is the VI.
It is implemented exactly by solving in a frame turned so that the maximum gap lies on the mesh
seam (theta = 0), where the mesh has nodes, and turning the results back; the Jacobian then
includes the motion of that line with the eccentricity direction. ``"none"``: only the edges are at
ambient pressure (and a supply at the supply pressure) and the VI alone places the film's start and
end; on a full 360 deg bearing this gives attitude angles 1-4 deg larger than the tables at
eccentricity <= 0.6 for the same load.

Oil supply (``Bearing.supply``): a round hole, a rectangular axial groove or a full circumferential
groove, centred on the mid-plane; the mesh cuts it out as the cells tagged ``supply``
(solver.film.mesh), whose dofs are held at the supply pressure (one Dirichlet condition whatever the
shape). It goes with ``inlet = "none"``.

Flows. The side flow (out of both edges) and the supply flow (from the supply into the film) are the
consistent fluxes of the discrete equation: ``r(P; w)`` with w = 1 on the edge (supply) dofs and 0
elsewhere, i.e. the sum of the residuals of those dofs, in m^3/s. Their sum over all dofs is the
integral of the source, so in a steady state the discrete balance is exact: supply flow + the oil
the Reynolds condition creates in the cavitated zone (the sum of the VI's residuals there, >= 0) =
side flow. The Reynolds cavitation model does not conserve mass: only without cavitation is the
supply flow the side flow.

Cavitation (``cavitation``): ``"reynolds"``, the SNES VI P >= P_cav above; ``"jfo"``, the
mass-conserving film of solver.film.jfo (and solver.film.ehd_jfo with an elastic bushing) with the same
flow factors, whose film fraction is film state: committed after every accepted integrator step
(``commit_history``, as the elastic bushing's deformation), its rate by BDF2 through the committed
states. Its flows are the consistent fluxes of the JFO residual, so a steady film's supply equals its
side flow; the cavitated area and the oil held in the film are in FilmResult.

Equilibrium under a load (``equilibrium``) is found by Newton's method on the two eccentricity
components with the film's Jacobian.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import time

from mpi4py import MPI
from petsc4py import PETSc

import basix
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from dolfinx.la import create_petsc_vector
from dolfinx.mesh import meshtags
from scipy.spatial import Delaunay
from ufl.algorithms import expand_derivatives

from solver.errors import FilmNotConverged, InputError, out_of_range
from solver.film import reynolds as film
from solver.film.cavitation import CavitatingSolver
from solver.film.ehd import ElasticFilm, ModalCompliance, WinklerLayer, deformation_peak
from solver.film.ehd_jfo import ElasticJFOFilm, MidpointJFO
from solver.film.jfo import JFOSolver, TransportLimiter
from solver.film.mesh import (
    TAGS,
    AxialGroove,
    CircumferentialGroove,
    FilmMeshSpec,
    Supply,
    SupplyHole,
    film_mesh,
)
from solver.film.scaling import FilmScales
from solver.film.tensors import MidpointOperator, PressureTorque, RigidMidpointCoefficients

log = logging.getLogger(__name__)


class _QuietJit(logging.Filter):
    """While a form is compiled: FFCx's INFO records and the C compiler's command lines (logged to
    the root logger by distutils) are dropped; FFCx's "Calling JIT C compiler" becomes one line of
    ours, once per process. A form loaded from the cache says nothing."""

    announced = False

    def filter(self, record: logging.LogRecord) -> bool:
        if (
            record.name == "ffcx"
            and "Calling JIT C compiler" in record.getMessage()
            and not _QuietJit.announced
        ):
            _QuietJit.announced = True
            log.info("compiling the film's forms for this machine: once, 5-20 s; cached in ~/.cache/fenics")
        return record.levelno >= logging.WARNING


@contextlib.contextmanager
def _quiet_jit():
    """Compile forms, expressions and elements quietly (see _QuietJit)."""
    quiet = _QuietJit()
    loggers = [logging.getLogger("ffcx"), logging.getLogger()]
    for logger in loggers:
        logger.addFilter(quiet)
    try:
        yield
    finally:
        for logger in loggers:
            logger.removeFilter(quiet)


def _form(expression):
    """dolfinx.fem.form with FFCx's verbosity at INFO: only then does it log "Calling JIT C compiler",
    which _QuietJit turns into one line; call it under _quiet_jit()."""
    return fem.form(expression, form_compiler_params={"verbosity": logging.INFO})


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


#: the functionals of the pressure part of the viscous torques (the same integrand, solver.film.tensors.PressureTorque)
_PRESSURE_TORQUES = ("viscous_pressure_journal", "viscous_pressure_bushing")

#: |e| / c the pin may reach in an elastic bushing (the deformation then holds the film open)
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
            if self.inlet == "max-gap":
                raise InputError(
                    "inlet = 'max-gap' cannot be combined with a supply hole or groove (allowed with a "
                    "supply: 'none')"
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
        """From global centre positions/velocities: ``e' = A^T e`` and ``de'/dt = A^T de/dt - omega_b S e'``."""
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


# Rows of the Jacobian and how the model's functionals add up to them.
_JACOBIAN_ROWS = ("force_x", "force_y", "torque_journal", "torque_bushing")


@dataclasses.dataclass
class FilmStats:
    """Work done by a FilmModel so far (counts and wall seconds); the run reports it per cycle."""

    solves: int = 0
    vi_iterations: int = 0  # SNES VI (Newton) iterations of all solves
    failures: int = 0  # solves that did not converge
    jacobians: int = 0
    transport_fallbacks: int = 0  # JFO, limited transport: committed states whose step fell back to upwinding
    solve_seconds: float = 0.0  # assembly, VI and functionals
    jacobian_seconds: float = 0.0  # sensitivities and their functionals

    def copy(self) -> "FilmStats":
        return dataclasses.replace(self)


class FrameTurn:
    """Carries a nodal field on the film mesh to a solution frame turned by delta about the axis:
    ``new(theta, z) = old(theta + delta, z)``, by linear interpolation on a triangulation of the
    nodes in (theta, z) (periodic in theta). Serial; used for the VI's warm start."""

    def __init__(self, x: np.ndarray):
        """x: the coordinates of the owned dofs (unit cylinder)."""
        self.size = len(x)
        self.theta = np.arctan2(x[:, 1], x[:, 0]) % (2 * math.pi)
        self.z = x[:, 2]
        two_pi = 2 * math.pi
        points = np.concatenate(
            [np.column_stack([self.theta + shift, self.z]) for shift in (0.0, two_pi, -two_pi)]
        )
        self.node = np.tile(np.arange(self.size), 3)
        self.triangulation = Delaunay(points)

    def __call__(self, values: np.ndarray, delta: float) -> np.ndarray:
        query = np.column_stack([(self.theta + delta) % (2 * math.pi), self.z])
        simplex = self.triangulation.find_simplex(query)
        inside = simplex >= 0  # (a node on the hull may fall outside by round-off: it keeps its value)
        transform = self.triangulation.transform[simplex[inside]]
        b = np.einsum("ijk,ik->ij", transform[:, :2], query[inside] - transform[:, 2])
        weights = np.column_stack([b, 1.0 - b.sum(axis=1)])
        corners = self.node[self.triangulation.simplices[simplex[inside]]]
        out = values.copy()
        out[inside] = np.einsum("ij,ij->i", weights, values[corners])
        return out


class FilmModel:
    """Finite-element film of one bearing, reused across solves (see module docstring).

    Args:
        bearing: geometry and oil.
        comm: communicator of the mesh and solver (never COMM_WORLD implicitly).
        omega_ref: reference angular speed of the scaling [rad/s].
        mesh_size: element size / R (None: default_mesh_size of the bearing).
        degree: polynomial degree of the pressure (1 or 2).
        roughness: Patir-Cheng flow factors (solver.film.flow_factors.PatirCheng); None: smooth film.
        contact: Greenwood-Tripp asperity contact (solver.film.contact.GreenwoodTripp); None: no contact.
        slip_regularisation: sliding speed [m/s] below which asperity friction is smoothed to zero.
        options: PETSc options over solver.film.cavitation.DEFAULT_OPTIONS.
        half: solve the half z >= 0 of the film (it is symmetric about the mid-plane); False meshes
            the whole width (same results to the discretisation error, twice the unknowns).
        elastic: the bushing's compliance (solver.film.ehd.WinklerLayer or ModalCompliance); None:
            rigid. Serial, P1; pressure and deformation are then solved together (solver.film.ehd).
        piezoviscosity: the oil's pressure-viscosity law (solver.film.viscosity.Barus or Roelands);
            None: iso-viscous. The film is then solved for the reduced pressure (``P`` holds it) and
            ``pressure`` holds the true pressure / p_ref.
        cavitation: "reynolds" (the VI p >= p_cav) or "jfo" (mass-conserving, solver.film.jfo, and with
            an elastic bushing solver.film.ehd_jfo: serial P1; the film fraction is film state,
            committed like the deformation).
    """

    # rad: the warm start is turned with the solution frame only when the frame jumps (the pin crossing its
    # clearance, where the field stays in the bushing frame); while it turns with the eccentricity the
    # field turns with it, and the last pressure as it is is the better start (turning it at every change
    # cost 13 % more VI iterations on a crossing and 6 x more under a load turning 0.3 rad per solve)
    TURN_THRESHOLD = 0.5

    def __init__(
        self,
        bearing: Bearing,
        comm: MPI.Comm,
        *,
        omega_ref: float,
        mesh_size: float | None = None,
        degree: int = 1,
        roughness=None,
        contact=None,
        slip_regularisation: float = 1e-3,
        options: dict | None = None,
        half: bool = True,
        elastic=None,
        piezoviscosity=None,
        cavitation: str = "reynolds",
        transport: str = "limited",
    ):
        with _quiet_jit():
            self._setup(
                bearing,
                comm,
                omega_ref,
                mesh_size,
                degree,
                roughness,
                contact,
                slip_regularisation,
                options,
                half,
                elastic,
                piezoviscosity,
                cavitation,
                transport,
            )

    def _setup(
        self,
        bearing,
        comm,
        omega_ref,
        mesh_size,
        degree,
        roughness,
        contact,
        slip_regularisation,
        options,
        half,
        elastic,
        piezoviscosity,
        cavitation,
        transport,
    ) -> None:
        if transport not in TRANSPORT_SCHEMES:
            raise out_of_range(
                "film-fraction transport", repr(transport), " or ".join(map(repr, TRANSPORT_SCHEMES))
            )
        self.transport = transport
        self.bearing = bearing
        self.elastic = elastic
        self.piezo = piezoviscosity
        if cavitation not in CAVITATION_MODELS:
            raise out_of_range("cavitation", repr(cavitation), " or ".join(map(repr, CAVITATION_MODELS)))
        self.cavitation = cavitation
        if cavitation == "jfo" and (comm.size != 1 or degree != 1):
            raise InputError("cavitation = 'jfo' needs the serial P1 film (allowed: one rank, degree 1)")
        if (
            cavitation == "jfo"
            and bearing.inlet == "none"
            and bearing.supply is None
            and bearing.cavitation_pressure >= 0
        ):
            # edges at the cavitation pressure, no supply: no oil can enter the film but along its edges'
            # first element row, so the oil it holds depends on the mesh (load -16 % from 0.1 to 0.025 R)
            raise out_of_range(
                "cavitation_pressure",
                f"{bearing.cavitation_pressure:g}",
                "< 0 Pa gauge with cavitation 'jfo', inlet 'none' and no supply (flooded edges), "
                "or give a supply hole or groove",
            )
        if elastic is not None:
            if comm.size != 1 or degree != 1:
                raise InputError("an elastic bushing needs the serial P1 film (allowed: one rank, degree 1)")
            if isinstance(elastic, ModalCompliance) and bearing.inlet == "max-gap":
                raise InputError(
                    "elastic = 'fe' cannot be combined with inlet = 'max-gap' (it turns the film "
                    "against the eye; allowed: 'none', with or without a supply)"
                )
        self.scales = FilmScales(
            radius=bearing.radius,
            clearance=bearing.clearance,
            viscosity=bearing.viscosity,
            omega_ref=omega_ref,
        )
        if degree not in (1, 2):
            raise out_of_range("degree", degree, "1 or 2")
        sigmas = [x.sigma for x in (roughness, contact) if x is not None]
        if sigmas and not math.isclose(min(sigmas), max(sigmas), rel_tol=1e-12):
            raise InputError(
                "roughness.sigma and contact.sigma differ (allowed: the same composite roughness)"
            )
        self.sigma = sigmas[0] if sigmas else 0.0
        R = bearing.radius
        # aligned surfaces, edges at the same pressure, a supply on the mid-plane: the film is
        # symmetric about the mid-plane, so only its half z >= 0 is solved (half the unknowns) and
        # every integral over the film is doubled (solver.film.mesh)
        if mesh_size is None:
            mesh_size = default_mesh_size(bearing.width, R)
        self.mesh_spec = FilmMeshSpec(
            width=bearing.width / R, element_size=mesh_size, supply=bearing.supply, half=half
        )
        self.mesh, self.cell_tags, self.facet_tags = film_mesh(self.mesh_spec, comm)
        self.comm = self.mesh.comm
        self.V = fem.FunctionSpace(self.mesh, ("Lagrange", degree))
        self.P = fem.Function(self.V, name="pressure")
        # the true pressure / p_ref: the reduced pressure mapped node by node (solver.film.viscosity)
        self.pressure = fem.Function(self.V, name="true_pressure") if piezoviscosity is not None else self.P
        self.W = fem.Function(self.V, name="deformation") if elastic is not None else None  # w / c
        # the deformation's rate by implicit Euler from the last committed state (commit_history)
        self._W_previous = fem.Function(self.V) if elastic is not None else None
        self._inverse_step = fem.Constant(self.mesh, PETSc.ScalarType(0.0))
        # the last committed states, oldest first: (t_n [s], coupled unknowns x_n)
        self._history: list[tuple[float, np.ndarray]] = []
        self._start: tuple[float, np.ndarray] | None = None  # the one the current solve's rate starts from
        # the JFO solve's film-fraction rate: (1/dT, theta_reference), dtheta/dT = (theta - theta_reference) / dT
        self._jfo_rate: tuple[float, np.ndarray] | None = None
        self._jfo_solution = None  # the last JFOSolution
        self.params = film.FilmParameters(self.mesh)
        self.params.set(S=self.sigma / bearing.clearance if self.sigma > 0 else 1.0)
        # the flow floor of the elastic film: a quarter of the roughness (h/sigma < 0.25 is asperity
        # contact; the flow factors are held below 0.5), or 1e-3 c on smooth surfaces
        floor = 0.25 * self.sigma / bearing.clearance if self.sigma > 0 else 1e-3
        self.geometry = film.FilmGeometry(
            self.mesh,
            self.params,
            deformation=self.W,
            previous_deformation=self._W_previous,
            inverse_step=self._inverse_step,
            flow_floor=floor,
        )
        self.roughness, self.contact = roughness, contact
        self.slip_regularisation = slip_regularisation
        self._build_forms()
        self._owned_cells = np.arange(self.mesh.topology.index_map(2).size_local, dtype=np.int32)
        cell_nodes = self.mesh.geometry.dofmap.array.reshape(-1, 3)[: len(self._owned_cells)]
        x = self.mesh.geometry.x[cell_nodes]
        angle = np.arctan2(x[..., 1], x[..., 0])
        self._vertex_cos, self._vertex_sin = np.cos(angle), np.sin(angle)
        # the same at the geometry's nodes, and each cell's three nodes (contiguous columns): _contact_cells
        node_angle = np.arctan2(self.mesh.geometry.x[:, 1], self.mesh.geometry.x[:, 0])
        self._node_cos, self._node_sin = np.cos(node_angle), np.sin(node_angle)
        self._cell_nodes = [np.ascontiguousarray(cell_nodes[:, k]) for k in range(3)]
        spread = np.ptp(np.unwrap(angle, axis=1), axis=1)
        self._cell_extent = float(np.max(spread, initial=0.0))  # rad, the largest angular extent of a cell
        self.bcs = self._boundary_conditions()
        self.solver = CavitatingSolver(
            self._a,
            self._l,
            self.P,
            self.bcs,
            lower=self._reduced(bearing.cavitation_pressure) / self.scales.pressure,
            options=options,
        )
        self._operator = None
        self._pressure_torque = None  # PressureTorque: serial, P1
        if self.comm.size == 1 and degree == 1:  # operator and source from precomputed tensors (film.tensors)
            coefficients = film.reynolds_coefficients(self.geometry, self.roughness)
            names = list(self._midpoint_integrands)
            self._operator = MidpointOperator(
                self.V,
                self.solver.A,
                coefficients,
                self.bcs,
                integrals=[self._midpoint_integrands[n] for n in names],
            )
            self._operator_integral_names = names
            self._scalars = [(keys, f) for keys, f in self._scalars if not set(keys) <= set(names)]
            if elastic is None and set(names) <= set(RigidMidpointCoefficients.INTEGRALS):
                # the coefficients at the midpoints in numpy rather than by the compiled Expression (film.tensors)
                self._operator.fast = RigidMidpointCoefficients(
                    self._operator, self.params, self.roughness, names
                )
            self.solver.assembler = self._operator.assemble
            self.solver.update()
            # the pressure part of the viscous torques (the "moment" group) from tensors (film.tensors)
            self._pressure_torque = PressureTorque(
                self.V,
                self.roughness,
                float(self.params.S.value),
                flow_floor=None if elastic is None else floor,
            )
            self._scalars = [
                (keys, f) for keys, f in self._scalars if not set(keys) <= set(_PRESSURE_TORQUES)
            ]
        self._dofs = self.V.dofmap.index_map.size_global * self.V.dofmap.index_map_bs
        self._owned_coords = self.V.tabulate_dof_coordinates()[: self.V.dofmap.index_map.size_local].copy()
        # the mass-conserving film (with an elastic bushing: the kinematic sensitivities of its residual)
        self._jfo = self._jfo_film() if cavitation == "jfo" else None
        self._ehd = self._elastic_film(options) if elastic is not None else None
        self._jfo_derivatives = None  # the JFO residual's kinematic derivatives at the cell midpoints
        self._limiter: TransportLimiter | None = None  # the film fraction's limited transport (transport)
        self._limited = None  # its factors for the current committed film fraction (LimitedTransport)
        self._limited_key: tuple | None = None  # (time, film fraction) they were computed from
        self._upwind_key: tuple | None = None  # the committed state whose solves fell back to upwinding
        if self._jfo is not None:
            is_bc = np.zeros(len(self._owned_coords), dtype=bool)
            for dofs, _ in self._jfo.prescribed.values():
                is_bc[dofs] = True
            self._jfo_derivatives = MidpointJFO(
                self._operator, self._jfo_coefficients(), list(self.geometry.variables().values()), is_bc
            )
            layout = self._jfo.csr_layout()
            if not (
                np.array_equal(layout[0], self._operator.indptr)
                and np.array_equal(layout[1], self._operator.indices)
            ):
                raise RuntimeError("the JFO film's matrices and the operator's have different CSR layouts")
            if transport == "limited":
                self._limiter = TransportLimiter(*layout)
                # the flow's orientation and couplings for the limiter: the Couette matrix of a unit flux
                # along +theta (the film's own flux reverses with the sliding; LimitedTransport picks the
                # orientation edge by edge), so the factors do not depend on the state being solved
                self._unit_couette = self._jfo_derivatives.T_C @ np.ones(len(self._operator.cells))
        # nodal areas of the film (integral of each basis function): the cavitated area
        self._nodal_areas = fem_petsc.assemble_vector(
            _form(ufl.TestFunction(self.V) * ufl.dx(domain=self.mesh))
        )
        self._nodal_areas.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._last: Kinematics | None = None
        self.stats = FilmStats()
        # with the max-gap inlet the solution frame turns with the eccentricity (serial: FrameTurn)
        self._turn = (
            FrameTurn(self._owned_coords) if bearing.inlet == "max-gap" and self.comm.size == 1 else None
        )
        self._fields = None  # output Functions and the expressions they interpolate (fields_si), built once

    # -- setup ----------------------------------------------------------------------------------
    def _elastic_film(self, options) -> ElasticFilm:
        """The coupled VI of pressure and deformation on this film's operator (solver.film.ehd)."""
        g, R = self.geometry, self.bearing.radius
        k_theta, k_z, f = film.reynolds_coefficients(g, self.roughness)
        P_c = ufl.as_ufl(0.0)
        if self.contact is not None:
            P_c = self.contact.pressure(g.H / self.params.S, mod=ufl) / self.scales.pressure
        # expanded here: FFCx lowers dW/dtheta = grad(W).t inside its variable before it applies
        # derivatives, and the derivative with respect to the lowered variable comes out zero
        derivatives = [
            expand_derivatives(e)
            for e in (
                ufl.diff(k_theta, g.W),
                ufl.diff(k_z, g.W),
                ufl.diff(f, g.W),
                ufl.diff(f, g.dW_dtheta),
                P_c,
                ufl.diff(P_c, g.W),
            )
        ]
        coords = self._owned_coords
        shapes = self.elastic.shapes(
            np.arctan2(coords[:, 1], coords[:, 0]), coords[:, 2] * R, self._operator.nodal_areas, self.scales
        )
        n = len(coords)
        pressure_map = None
        if self.piezo is not None:

            def pressure_map(Q: np.ndarray):
                p = self._true_pressure(Q)
                return p, self.piezo.ratio(p * self.scales.pressure)

        q_limit = None if self.piezo is None else self.piezo.q_limit / self.scales.pressure
        if self._jfo is not None:  # the mass-conserving film on the elastic bushing (solver.film.ehd_jfo)
            cavitation = self._reduced(self.bearing.cavitation_pressure) / self.scales.pressure
            ehd = ElasticJFOFilm(
                self._operator,
                self.P,
                self.W,
                np.full(n, cavitation),
                derivatives,
                shapes,
                self._jfo_coefficients(),
                g.W,
                self._jfo.prescribed,
                pressure_map=pressure_map,
                q_limit=q_limit,
            )
        else:
            lower = self.solver.lower.x.array[:n].copy()
            ehd = ElasticFilm(
                self._operator,
                self.P,
                self.W,
                lower,
                derivatives,
                shapes,
                options,
                pressure_map=pressure_map,
                q_limit=q_limit,
            )
        # the point of minimum rigid gap lies on the mid-plane (z = 0): the nodes there, by angle
        self._midplane = np.flatnonzero(np.abs(coords[:, 2]) < 1e-12)
        return ehd

    def _jfo_film(self) -> JFOSolver:
        """The mass-conserving film on this film's space and geometry (solver.film.jfo).

        The same flow factors as the Reynolds forms: D = H^3 phi_x t t + H^3 phi_y e_z e_z; the Couette
        flux per unit film fraction (U_mean h_T + U_d sigma phi_s) t, with h_T the mean gap
        (d h_T/dH = phi_c, solver.film.flow_factors.mean_gap); storage h_T and its rate phi_c dH/dT
        (rate form). Midpoint quadrature, as the Reynolds operator. The prescribed dofs hold u = P -
        P_cav (the edges and seam at ambient, the supply at its pressure): with ambient at the
        cavitation pressure the edges are a flooded boundary at P_cav (u = 0: theta = 1)."""
        g = self.geometry
        k_theta, k_z, flux, h_T, rate = self._jfo_coefficients()
        D = k_theta * ufl.outer(g.tangent, g.tangent) + k_z * ufl.outer(g.axial, g.axial)
        lower = self._reduced(self.bearing.cavitation_pressure) / self.scales.pressure
        prescribed = {name: (dofs, value - lower) for name, (dofs, value) in self._prescribed().items()}
        return JFOSolver(
            self.V,
            h_T,
            None,
            prescribed,
            D=D,
            flux=flux * g.tangent,
            rate=rate,
            quadrature_degree=1,
            options={"snes_max_it": 40},
        )  # (engine: 1.2 iterations a solve; a cycling start is retried)

    def _jfo_coefficients(self):
        """(k_theta, k_z, flux, h_T, rate) of the mass-conserving film (UFL): the Reynolds forms'
        H^3 phi_x and H^3 phi_y, the Couette flux per unit film fraction along the sliding direction,
        the mean gap and its rate phi_c dH/dT."""
        g, prm = self.geometry, self.params
        k_theta, k_z, _ = film.reynolds_coefficients(g, self.roughness)
        if self.roughness is None:
            h_T, phi_c, shear = g.H, 1.0, 0.0
        else:
            Hs = g.H / prm.S
            h_T = prm.S * self.roughness.mean_gap(Hs, mod=ufl)
            phi_c = self.roughness.contact_factor(Hs, mod=ufl)
            shear = g.U_half_diff * prm.S * self.roughness.shear_flow(Hs, mod=ufl)
        return k_theta, k_z, g.U_mean * h_T + shear, h_T, phi_c * g.dH_dT

    def _build_forms(self) -> None:
        g, P, s = self.geometry, self.P, self.scales
        # outputs use the true pressure (the film's unknown P is the reduced one with piezoviscosity)
        # and the Couette stresses mu(p) / mu0 (solver.film.viscosity)
        p = self.pressure
        v, dP = ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
        # The coefficients (H^3, flow factors, sqrt in theta) would make UFL pick a very high
        # quadrature degree; they are smooth on an element, so degree 2k - 1 (the midpoint rule for
        # P1) keeps the discretisation error of order h^2: at the engine's hardest state the film
        # load on the default mesh is 0.1 % from converged (0.8 % with degree 2k), at 2.5 x less
        # assembly time (bench/film_mesh_convergence.py). The hydrodynamic forces and the pressure
        # part of the viscous torques take degree 2k: the film's moment balance (T_j + T_b + e x F
        # = 0) rests on an integration by parts between them that only a more accurate rule keeps
        # to 1e-5.
        k = self.V.ufl_element().degree()
        dx = ufl.dx(domain=self.mesh, metadata={"quadrature_degree": 2 * k - 1})
        dx_moment = ufl.dx(domain=self.mesh, metadata={"quadrature_degree": 2 * k})
        # functionals are evaluated per group: (measure, only on the cells where asperities touch)
        groups = {"film": (dx, False), "moment": (dx_moment, False), "contact": (dx, True)}
        whole = float(self.mesh_spec.multiplicity)  # integrals over the whole film / over the mesh
        residual = film.reynolds_integrand(P, v, g, self.roughness)
        self._a = _form(ufl.derivative(residual * dx, P, dP))
        self._l = _form(ufl.replace(residual, {P: ufl.zero()}) * dx)
        couette_j, couette_b, pressure_part = film.shear_traction_integrands(p, g, self.roughness)
        if self.piezo is not None:
            ratio = self.piezo.ratio(s.pressure * p, mod=ufl)
            couette_j, couette_b = ratio * couette_j, ratio * couette_b
        # functional name -> (dimensionless integrand, SI scale, Jacobian row it adds to, group)
        self._outputs = {
            "hydro_x": (-p * g.normal[0], whole * s.force, "force_x", "moment"),
            "hydro_y": (-p * g.normal[1], whole * s.force, "force_y", "moment"),
            "viscous_couette_journal": (couette_j, whole * s.shear_torque, "torque_journal", "film"),
            "viscous_couette_bushing": (couette_b, whole * s.shear_torque, "torque_bushing", "film"),
            "viscous_pressure_journal": (pressure_part, whole * s.shear_torque, "torque_journal", "moment"),
            "viscous_pressure_bushing": (pressure_part, whole * s.shear_torque, "torque_bushing", "moment"),
        }
        extra = {}
        if self.contact is not None:
            slip_reg = self.slip_regularisation / s.speed
            P_c, tau_c, area = film.asperity_integrands(g, self.contact, s.pressure, slip_reg)
            torque_scale = whole * s.pressure * self.bearing.radius**3
            self._outputs.update(
                {
                    "asperity_x": (-P_c * g.normal[0], whole * s.force, "force_x", "contact"),
                    "asperity_y": (-P_c * g.normal[1], whole * s.force, "force_y", "contact"),
                    # the contact normals pass through the bushing centre, so on the journal they have the
                    # moment -e x F_asperity about its centre (the film's moment balance, T_j + T_b + e x F = 0)
                    "asperity_torque_journal": (
                        tau_c
                        + self.bearing.clearance
                        / self.bearing.radius
                        * P_c
                        * (g.eps_x * g.normal[1] - g.eps_y * g.normal[0]),
                        torque_scale,
                        "torque_journal",
                        "contact",
                    ),
                    "asperity_torque_bushing": (-tau_c, torque_scale, "torque_bushing", "contact"),
                }
            )
            extra = {"contact_area": whole * area, "asperity_normal": whole * P_c}
        self._extra_names = list(extra)
        # Hydrodynamic forces are linear in P with weights independent of the kinematics: g_i . P.
        self._force_vectors = {}
        for name in ("hydro_x", "hydro_y"):
            integrand, _, _, group = self._outputs[name]
            vec = fem_petsc.assemble_vector(_form(ufl.derivative(integrand * groups[group][0], p, v)))
            vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            self._force_vectors[name] = vec
        # All other functionals of a solve in one pass over the cells per group.
        scalars = {
            name: (e, group)
            for name, (e, _, _, group) in self._outputs.items()
            if name not in self._force_vectors
        }
        scalars.update({name: (e, "contact") for name, e in extra.items()})
        self._scalars = _functionals_by_group(self.mesh, scalars, groups)
        # the midpoint-rule functionals independent of P (the Couette torques): the tensor operator
        # can integrate them in its own evaluation of the coefficients (see _setup)
        self._midpoint_integrands = {
            name: e
            for name, (e, group) in scalars.items()
            if group == "film" and _is_zero(ufl.derivative(e, p, v))
        }
        variables = list(g.variables().values())
        # Jacobian pieces: dr/dtheta at fixed P; per Jacobian row (outputs summed with their SI
        # scales) the explicit dE/dtheta that are not identically zero, and dE/dP as a vector.
        dr_integrands = [(ufl.diff(residual, var), dx) for var in variables]
        explicit: dict[tuple[int, int, str], tuple[object, str]] = {}
        gradients: list[tuple[int, object, object]] = []
        w_gradients: list[tuple[int, object, object]] = []
        for i, row in enumerate(_JACOBIAN_ROWS):
            for group, (measure, _) in groups.items():
                members = [
                    (name, e, scale)
                    for name, (e, scale, r, gr) in self._outputs.items()
                    if r == row and gr == group and name not in self._force_vectors
                ]
                if not members:  # (smooth film: hydrodynamic forces only)
                    continue
                combined = sum(scale * e for _, e, scale in members)
                for j, var in enumerate(variables):
                    if not _is_zero(ufl.diff(combined, var)):
                        explicit[(i, j, group)] = (ufl.diff(combined, var), group)
                gradient = ufl.derivative(combined, p, v)
                if not _is_zero(gradient):  # dE/dp != 0: the pressure part of the viscous torques
                    gradients.append((i, gradient, measure))
                if self.W is not None:  # dE/dW: outputs that depend on the film thickness
                    gradient_W = ufl.derivative(combined, self.W, v)
                    if not _is_zero(gradient_W):
                        w_gradients.append((i, gradient_W, measure))
        # the residual derivatives and the gradients in one kernel (they share H and the flow factors)
        self._n_inputs = len(variables)
        self._gradient_rows = [i for i, _, _ in gradients]
        self._w_gradient_rows = [i for i, _, _ in w_gradients]
        self._jacobian_vectors = BlockedVectors(
            self.V, v, dr_integrands + [(e, m) for _, e, m in gradients + w_gradients]
        )
        self._explicit = _functionals_by_group(self.mesh, explicit, groups)
        # Side and supply flows: the consistent flux r(P; w) with w = 1 on the edge / supply dofs (module doc).
        edges = np.concatenate(
            [self.facet_tags.find(TAGS["edge_minus"]), self.facet_tags.find(TAGS["edge_plus"])]
        )
        self._side_flow_form = self._flux_form(fem.locate_dofs_topological(self.V, 1, edges), residual, v, dx)
        self._supply_flow_form = None
        if self.mesh_spec.supply is not None:
            supply_dofs = fem.locate_dofs_topological(self.V, 2, self.cell_tags.find(TAGS["supply"]))
            self._supply_flow_form = self._flux_form(supply_dofs, residual, v, dx)

    def _flux_form(self, dofs: np.ndarray, residual, v, dx):
        """The compiled form of ``r(P; w)`` over the whole film, w = 1 on ``dofs`` (local) and 0 elsewhere:
        the flow that the discrete equation lets through those dofs (the sum of their residuals).

        w vanishes outside the cells that have one of the dofs, so only those cells are integrated
        (every cell with such a dof: also those that touch the dofs' boundary at a vertex only)."""
        indicator = fem.Function(self.V)
        indicator.x.array[dofs] = 1.0
        cell_dofs = self.V.dofmap.list.array.reshape(-1, self.V.dofmap.dof_layout.num_dofs)
        cells = np.flatnonzero(indicator.x.array[cell_dofs].any(axis=1)).astype(np.int32)
        marker = meshtags(self.mesh, 2, cells, np.ones(len(cells), dtype=np.int32))
        dx_cells = ufl.dx(domain=self.mesh, subdomain_data=marker, subdomain_id=1, metadata=dx.metadata())
        whole = float(self.mesh_spec.multiplicity)
        return _form(whole * ufl.replace(residual, {v: indicator}) * dx_cells)

    def _prescribed(self) -> dict[str, tuple[np.ndarray, float]]:
        """The film's prescribed dofs by name ("edges", "seam" with the max-gap inlet, "supply") and
        the film unknown there (P: the reduced pressure / p_ref)."""
        edges = np.concatenate(
            [self.facet_tags.find(TAGS["edge_minus"]), self.facet_tags.find(TAGS["edge_plus"])]
        )
        out = {"edges": (fem.locate_dofs_topological(self.V, 1, edges), 0.0)}
        if self.bearing.inlet == "max-gap":  # the seam, theta = 0 (solver.film.mesh), at ambient pressure
            x = self.V.tabulate_dof_coordinates()
            out["seam"] = (np.flatnonzero((np.abs(x[:, 1]) < 1e-10) & (x[:, 0] > 0)).astype(np.int32), 0.0)
        if self.mesh_spec.supply is not None:  # hole or groove: the dofs of the supply cells
            cells = self.cell_tags.find(TAGS["supply"])
            out["supply"] = (
                fem.locate_dofs_topological(self.V, 2, cells),
                self._reduced(self.bearing.supply_pressure) / self.scales.pressure,
            )
        return out

    def _boundary_conditions(self) -> list:
        bcs = []
        for dofs, value in self._prescribed().values():
            function = fem.Function(self.V)
            function.x.array[:] = value
            bcs.append(fem.dirichletbc(function, dofs))
        return bcs

    @property
    def has_history(self) -> bool:
        """True when a solve depends on committed film states: an elastic bushing (its deformation's
        rate) or the mass-conserving film (its film fraction)."""
        return self._ehd is not None or self._jfo is not None

    def history_state(self) -> np.ndarray | None:
        """The film state of the last solve, a copy, for ``commit_history``: the coupled unknowns
        (pressure, then the elastic ones) of an elastic bushing, the JFO unknown u (theta = 1 +
        min(u, 0)) of the mass-conserving film; None without history."""
        if self._ehd is not None:
            return self._ehd.state()
        if self._jfo is not None:
            return self._jfo.u.x.array[: len(self._owned_coords)].copy()
        return None

    def commit_history(self, state: np.ndarray, time_s: float) -> None:
        """Make ``state`` (from history_state) at ``time_s`` the start of the deformation's rate
        (of the film fraction's, JFO) for solves after ``time_s`` (and the start of a solve that fails
        from the last one). Committed states at or after ``time_s`` are dropped (a history replayed
        from an earlier time)."""
        if not self.has_history:
            return
        if self.bearing.inlet == "max-gap":  # W_n (theta_n) would have to turn with the solution frame
            raise InputError(
                "a film with history (elastic bushing or cavitation 'jfo') needs inlet 'none', with "
                "or without a supply (allowed with 'max-gap': quasi-static solves only)"
            )
        earlier = [entry for entry in self._history if entry[0] < time_s]
        self._history = [*earlier[len(earlier) - (self.HISTORY - 1) :], (time_s, state.copy())]

    def start_from(self, state: np.ndarray) -> None:
        """Make ``state`` (from history_state) the next solve's warm start: the state one
        integrator step before is a far better start than a solve of another time."""
        if self._ehd is not None:
            self._ehd.start_from(state)
        elif self._jfo is not None:
            self._jfo.u.x.array[: len(state)] = state

    def committed_history(self) -> list[tuple[float, np.ndarray]]:
        """The committed states kept, oldest first: (time [s], coupled unknowns), copies (for a
        checkpoint: committed again in that order, they restore the deformation's history); [] if rigid."""
        return [(time_s, state.copy()) for time_s, state in self._history]

    #: committed states kept: a solve at the time of the last commit takes its rate from the two before
    HISTORY = 3
    #: the largest step ratio h / h_previous with which the rate is second order (variable-step BDF2 is
    #: zero-stable below 1 + sqrt(2)); above it (a step grown fast) the rate is implicit Euler
    BDF2_MAX_RATIO = 2.4

    def rate_history(self, time_s: float | None) -> list[tuple[float, np.ndarray]]:
        """The committed states a solve at ``time_s`` takes its deformation rate from: the two latest
        strictly before ``time_s``, oldest first ([]: quasi-static)."""
        if time_s is None:
            return []
        return [entry for entry in self._history if entry[0] < time_s][-2:]

    def _bdf2(self, time_s: float | None, field) -> tuple[float, np.ndarray] | None:
        """A field's rate at ``time_s`` as ``inverse_step (f - reference)``, f its unknown value there:
        the variable-step BDF2 derivative through the two committed states before ``time_s``
        (second order in the step), ``df/dt = [(1 + 2w)/(1 + w) f - (1 + w) f_n + w^2/(1 + w) f_n-1] / h``
        with ``h = t - t_n``, ``w = h / (t_n - t_n-1)``; implicit Euler from the last one when there is
        only one (or w is above BDF2_MAX_RATIO). Returns (inverse_step [1/s], reference), None without
        a committed state (quasi-static); ``field(state)`` is the field in a committed state. Sets the
        solve's fall-back start (the last committed state)."""
        history = self.rate_history(time_s)
        self._start = history[-1] if history else None
        if not history:
            return None
        t_n, x_n = history[-1]
        h = time_s - t_n
        inverse_step, reference = 1.0 / h, field(x_n)
        if len(history) == 2:
            t_m, x_m = history[0]
            w = h / (t_n - t_m)
            if w <= self.BDF2_MAX_RATIO:
                inverse_step = (1 + 2 * w) / ((1 + w) * h)
                reference = ((1 + w) * reference - w**2 / (1 + w) * field(x_m)) / (inverse_step * h)
        return inverse_step, reference

    def _set_rate(self, time_s: float | None) -> None:
        """The deformation's rate in the squeeze term, ``inverse_step (W - W_previous)``, by ``_bdf2``
        (quasi-static without a committed state)."""
        n, ehd = self._ehd.n, self._ehd
        rate = self._bdf2(time_s, lambda x: ehd.deformation(x[n:]))
        if rate is None:
            self._inverse_step.value = 0.0
            return
        self._inverse_step.value = rate[0] / self.scales.omega_ref
        self._W_previous.x.array[:n] = rate[1]

    def _true_pressure(self, Q: np.ndarray) -> np.ndarray:
        """p / p_ref from the reduced pressure Q / p_ref, node by node (solver.film.viscosity)."""
        return self.piezo.pressure(Q * self.scales.pressure) / self.scales.pressure

    def _pressure_slope(self) -> np.ndarray:
        """dp/dq = mu(p) / mu0 at the nodes of the last solution."""
        return self.piezo.ratio(self.pressure.x.array * self.scales.pressure)

    def _reduced(self, p: float) -> float:
        """The film's unknown for a pressure p [Pa]: p, or the reduced pressure with piezoviscosity."""
        return p if self.piezo is None else float(self.piezo.reduced(p))

    @property
    def max_eccentricity_ratio(self) -> float:
        """|e| / c below which the film is defined: 1 when rigid; with an elastic bushing the pin may
        go further, into the deformed bushing (up to ELASTIC_MAX_ECCENTRICITY)."""
        return 1.0 if self.elastic is None else ELASTIC_MAX_ECCENTRICITY

    @property
    def dofs(self) -> int:
        """Global number of pressure unknowns."""
        return self._dofs

    # -- solve ----------------------------------------------------------------------------------
    def set_kinematics(self, kin: Kinematics) -> None:
        """Update the film's constants from SI kinematics (bushing frame)."""
        s, c = self.scales, self.bearing.clearance
        eps = np.asarray(kin.ecc, float) / c
        if not math.hypot(*eps) < self.max_eccentricity_ratio:
            raise out_of_range(
                "eccentricity ratio", f"{math.hypot(*eps):.6g}", f"[0, {self.max_eccentricity_ratio:g})"
            )
        rate = np.asarray(kin.ecc_rate, float) / s.eccentricity_rate
        U2 = self.bearing.radius * (kin.omega_journal - kin.omega_bushing) / s.speed  # journal, bushing frame
        U1 = 0.0
        self.params.set(
            eps_x=eps[0],
            eps_y=eps[1],
            deps_x=rate[0],
            deps_y=rate[1],
            U_mean=(U1 + U2) / 2,
            U_half_diff=(U1 - U2) / 2,
        )

    def _frame_angle(self, kin: Kinematics) -> float:
        """Angle beta by which the solution frame is turned from the bushing frame.

        With the max-gap inlet the maximum gap (opposite the eccentricity, or opposite the squeeze
        velocity when concentric) is put on the seam at theta = 0; otherwise beta = 0.
        """
        if self.bearing.inlet != "max-gap":
            return 0.0
        e, rate = np.asarray(kin.ecc), np.asarray(kin.ecc_rate)
        if np.linalg.norm(e) > 1e-9 * self.bearing.clearance:
            return math.atan2(e[1], e[0]) + math.pi
        if np.linalg.norm(rate) > 0:
            return math.atan2(rate[1], rate[0]) + math.pi
        return 0.0

    def solve(self, kin: Kinematics, time_s: float | None = None) -> FilmResult:
        """Solve the film for the given kinematics (warm start from the last pressure).

        With an elastic bushing, ``time_s`` [s] puts the deformation's rate in the squeeze term: BDF2
        through the two latest states committed (``commit_history``) before ``time_s`` (implicit
        Euler after the first commit; ``_set_rate``), so that a state solved again at the time of the
        last commit keeps its rate; without ``time_s`` (or before any commit) the deformation is
        quasi-static.
        """
        start = time.perf_counter()
        stats = self.stats
        stats.solves += 1
        if self._ehd is not None:
            self._set_rate(time_s)
        if self._jfo is not None:
            self._jfo_rate = self._film_fraction_rate(time_s)
            self._limit_transport()
            if self._ehd is not None:
                self._ehd.rate = self._jfo_rate
        try:
            try:
                result = self._solve(kin, start)
            except FilmNotConverged as err:
                if self._jfo_derivatives is None or self._jfo_derivatives.limited is None:
                    raise
                # the limited transport's matrix is no M-matrix (each edge's downwind entry is +alpha d):
                # where the storage does not dominate (a closing gap's mdot < 0) semismooth Newton can
                # cycle. The committed state's step then falls back to upwinding: every solve until the
                # next commit (a retried step's too), so the integrator sees one residual per step
                stats.vi_iterations += err.iterations
                self._upwind_key = self._limited_key
                stats.transport_fallbacks += 1
                log.debug(
                    "JFO film: limited transport did not converge (%s); upwind until the next commit", err
                )
                self._limit_transport()
                result = self._solve(kin, start)
        except FilmNotConverged as err:
            stats.failures += 1
            stats.vi_iterations += err.iterations
            raise
        finally:
            stats.solve_seconds += time.perf_counter() - start
        stats.vi_iterations += result.iterations
        return result

    def _solve(self, kin: Kinematics, start: float) -> FilmResult:
        beta = self._frame_angle(kin)
        if self._turn is not None and self._last is not None:
            # the warm start in the new frame: the last pressure turned with the frame
            delta = (beta - self._beta + math.pi) % (2 * math.pi) - math.pi
            if abs(delta) > self.TURN_THRESHOLD:
                n = self._turn.size
                self.P.x.array[:n] = self._turn(self.P.x.array[:n], delta)
                if isinstance(self.elastic, WinklerLayer):  # its unknowns are the nodal deformation
                    self._ehd.q = self._turn(self._ehd.q, delta)
        rot = _rotation(-beta)
        solved = Kinematics(
            tuple(rot @ kin.ecc), tuple(rot @ kin.ecc_rate), kin.omega_journal, kin.omega_bushing
        )
        self.set_kinematics(solved)
        if self._ehd is not None:
            iterations = self._solve_elastic()
            if self._jfo is not None:
                self._jfo_solution = self._ehd.solution()
                self._operator.evaluate()  # (its integrals: the Couette torques of the solution)
        elif self._jfo is not None:
            iterations = self._solve_jfo()
        else:
            self.solver.update()
            iterations = self.solver.solve()
        if self.piezo is not None:
            p = self._true_pressure(self.P.x.array)
            if not np.all(np.isfinite(p)):
                raise FilmNotConverged(
                    "piezoviscous film: unbounded pressure (the reduced pressure reached its "
                    "limit); at this load the film needs an elastic bushing",
                    0,
                    iterations,
                )
            self.pressure.x.array[:] = p
        self._last, self._beta = kin, beta
        self._in_contact = self._contact_cells()  # for the functionals and the Jacobian of this state
        values = self._functionals()
        s = self.scales
        p_max, theta, z = self._pressure_peak()
        back = _rotation(beta)
        self._force_solved = np.array([values["force_x"], values["force_y"]])
        hydro = back @ np.array([values["hydro_x"], values["hydro_y"]])
        asperity = back @ np.array([values.get("asperity_x", 0.0), values.get("asperity_y", 0.0)])
        h_min = self.bearing.clearance - math.hypot(*kin.ecc)
        deformation = (0.0, 0.0)
        if self._ehd is not None:
            h_min = self._elastic_h_min()
            n = len(self._owned_coords)
            w, theta_w = deformation_peak(self.W.x.array[:n], self._owned_coords, self.bearing.clearance)
            deformation = (w, (theta_w + beta) % (2 * math.pi))
        flows = self._flows()
        contact_area = asperity_normal = asperity_p_max = 0.0
        if self.contact is not None:
            asperity_normal = values["asperity_normal"] * s.force
            contact_area = values["contact_area"] / (2 * math.pi * self.mesh_spec.width)
            if h_min / self.sigma < self.contact.support:  # (p_c = 0 above it: no evaluation)
                asperity_p_max = float(self.contact.pressure(np.array([h_min / self.sigma]))[0])
        return FilmResult(
            force=(float(hydro[0] + asperity[0]), float(hydro[1] + asperity[1])),
            hydro_force=(float(hydro[0]), float(hydro[1])),
            asperity_force=(float(asperity[0]), float(asperity[1])),
            p_max=p_max * s.pressure,
            p_max_theta=(theta + beta) % (2 * math.pi),
            p_max_z=z * self.bearing.radius,
            h_min=h_min,
            torque_journal=values["torque_journal"],
            torque_bushing=values["torque_bushing"],
            asperity_torque_journal=values.get("asperity_torque_journal", 0.0),
            asperity_normal_force=asperity_normal,
            contact_area_ratio=contact_area,
            asperity_p_max=asperity_p_max,
            side_flow=flows[0],
            supply_flow=flows[1],
            cavitated_area_ratio=self._cavitated_area(),
            oil_volume=self._oil_volume(),
            iterations=iterations,
            solve_time=time.perf_counter() - start,
            sigma=self.sigma,
            max_deformation=deformation[0],
            max_deformation_theta=deformation[1],
        )

    #: continuation of a failed elastic solve in 1/dt: from 1/(RATE_CONTINUATION_START s), by this factor
    RATE_CONTINUATION = 2.0
    RATE_CONTINUATION_START = 1e7
    RATE_CONTINUATION_SOLVES = 40  # at most, before the target (quasi-static: 1/dt = 0)

    def _solve_elastic(self) -> int:
        """The coupled solve at the current constants (solver.film.ehd). The warm start is the last
        solve, which inside a time step's Newton iteration can be a state far from this one; if the
        solve fails from there it is tried again from the committed state (the last accepted one)."""
        coords, ehd = self._owned_coords, self._ehd
        ehd.rigid_gap = 1.0 - coords[:, :2] @ np.array(
            [float(self.params.eps_x.value), float(self.params.eps_y.value)]
        )
        try:
            return ehd.solve()
        except FilmNotConverged as err:
            if self._start is None:
                raise
            iterations = err.iterations
        # From the last accepted state, continued in the deformation's rate: with a short step (a large
        # 1/dt) the deformation stays near the accepted one and the solve is easy; 1/dt is then brought
        # down to this step's in factors of RATE_CONTINUATION, each solve starting from the one before.
        target = float(self._inverse_step.value)
        self.start_from(self._start[1])
        path, value = [], self.RATE_CONTINUATION_START / self.scales.omega_ref
        while value > target * (1 + 1e-12) and len(path) < self.RATE_CONTINUATION_SOLVES:
            path.append(value)
            value /= self.RATE_CONTINUATION
        for inverse_step in [*path, target]:
            self._inverse_step.value = inverse_step
            try:
                iterations += ehd.solve()
            except FilmNotConverged as again:
                self._inverse_step.value = target
                dt = 1 / (inverse_step * self.scales.omega_ref) if inverse_step > 0 else math.inf
                raise FilmNotConverged(
                    f"elastic film solve did not converge (also continued from the last "
                    f"accepted state, to dt = {dt:.3g} s)",
                    again.reason,
                    iterations + again.iterations,
                ) from None
        return iterations

    def _film_fraction_rate(self, time_s: float | None) -> tuple[float, np.ndarray] | None:
        """The film fraction's rate for a JFO solve at ``time_s``, as ``(theta - theta_ref) / dT`` by
        ``_bdf2``: (dT dimensionless, theta_ref), None (quasi-static) without a committed state."""
        n = len(self._owned_coords)  # (a state is u, or (u, q) with an elastic bushing)
        rate = self._bdf2(time_s, lambda x: 1.0 + np.minimum(x[:n], 0.0))
        return None if rate is None else (self.scales.omega_ref / rate[0], rate[1])

    def _limit_transport(self) -> None:
        """The limited transport's factors (solver.film.jfo.TransportLimiter) from the last committed film
        fraction before this solve (``_film_fraction_rate`` set it as the fall-back start), computed once
        per committed state; none (upwind) for a quasi-static solve, with transport 'upwind', and for the
        committed state whose limited solve did not converge (``solve``)."""
        limited = None
        if self._limiter is not None and self._jfo_rate is not None and self._start is not None:
            n = len(self._owned_coords)
            t_n, x_n = self._start
            key = (t_n, x_n[:n].tobytes())
            if key != self._limited_key:
                self._limited = self._limiter.limit(self._unit_couette, 1.0 + np.minimum(x_n[:n], 0.0))
                self._limited_key = key
            limited = None if key == self._upwind_key else self._limited
        self._jfo_derivatives.limited = limited
        if self._ehd is not None:
            self._ehd.mid.limited = limited

    def _solve_jfo(self) -> int:
        """The mass-conserving film at the current constants, with the film fraction's rate from the
        committed states (``_film_fraction_rate``; quasi-static without one); P = P_cav + max(u, 0)."""
        jfo, n = self._jfo, len(self._owned_coords)
        # the forms' midpoint rule without dolfinx's assembly; the operator's integrals (the Couette
        # torques) from the same evaluation
        matrices, self._operator.integrals = self._jfo_derivatives.operator()
        jfo.set_operator(*matrices, limited=self._jfo_derivatives.limited)
        dT, theta_old = self._jfo_rate if self._jfo_rate is not None else (None, None)
        # from the last solve; if semismooth Newton cycles from there (a far state of a Newton iteration),
        # from the last committed state, then from the full film (whose first step is the Reynolds
        # solution without cavitation, and which has converged where the others cycled)
        starts = [None, *([self._start[1]] if self._start is not None else []), np.ones(n)]
        iterations = 0
        for k, start in enumerate(starts):
            try:
                solution = jfo.solve(dT, theta_old=theta_old, start=start)
                break
            except FilmNotConverged as err:
                iterations += err.iterations
                if k == len(starts) - 1:
                    raise FilmNotConverged(
                        "mass-conserving film did not converge (also from the last committed "
                        "state and from the full film)",
                        err.reason,
                        iterations,
                    ) from None
        solution = dataclasses.replace(solution, iterations=solution.iterations + iterations)
        self._jfo_solution = solution
        self.P.x.array[:n] = self.solver.lower.x.array[:n] + solution.pressure
        self.P.x.scatter_forward()
        return solution.iterations

    def _flows(self) -> tuple[float, float]:
        """(side flow, supply flow) [m^3/s] of the last solve: the consistent fluxes (module docstring)."""
        s, whole = self.scales, float(self.mesh_spec.multiplicity)
        if self._jfo is not None:
            outflow = self._jfo_solution.outflow
            return outflow["edges"] * whole * s.flow, -outflow.get("supply", 0.0) * whole * s.flow
        supply = (
            self._assemble(self._supply_flow_form) * s.flow if self._supply_flow_form is not None else 0.0
        )
        return -self._assemble(self._side_flow_form) * s.flow, supply

    def _cavitated_area(self) -> float:
        """Ruptured film area / bearing area (nodal areas): theta < 1 (JFO), P at the cavitation bound
        (Reynolds)."""
        n = len(self._owned_coords)
        areas = self._nodal_areas.getArray(readonly=True)
        if self._jfo is not None:
            ruptured = self._jfo_solution.theta < 1.0
        else:
            lower = self.solver.lower.x.array[:n]
            ruptured = self.P.x.array[:n] - lower <= 1e-12 * max(
                1.0, float(np.max(np.abs(lower), initial=0.0))
            )
        local = np.array([areas[ruptured].sum(), areas.sum()])
        total = local if self.comm.size == 1 else self.comm.allreduce(local, op=MPI.SUM)
        return float(total[0] / total[1])

    def _oil_volume(self) -> float:
        """Oil in the film [m^3] (JFO: the sum of the nodes' contents m theta); NaN with Reynolds."""
        if self._jfo is None:
            return math.nan
        R, c = self.bearing.radius, self.bearing.clearance
        return float(np.sum(self._jfo_solution.content)) * float(self.mesh_spec.multiplicity) * R**2 * c

    def _elastic_h_min(self) -> float:
        """Minimum film thickness of the deformed bushing [m]: the least of the nodes' and of the rigid
        minimum gap (mid-plane, along the eccentricity) plus the deformation of the nearest node there
        (so that a very stiff bushing gives the rigid c - |e| exactly)."""
        coords, n = self._owned_coords, len(self._owned_coords)
        eps = np.array([float(self.params.eps_x.value), float(self.params.eps_y.value)])
        W = self.W.x.array[:n]
        H = self._ehd.rigid_gap + W  # the rigid gap of this state, set by _solve_elastic
        at_nodes = float(np.min(H))
        if not np.any(eps):
            return at_nodes * self.bearing.clearance
        angle = math.atan2(eps[1], eps[0])
        mid = self._midplane
        nearest = mid[
            np.argmin(np.abs(np.angle(np.exp(1j * (np.arctan2(coords[mid, 1], coords[mid, 0]) - angle)))))
        ]
        at_gap = 1.0 - math.hypot(*eps) + W[nearest]
        return min(at_nodes, at_gap) * self.bearing.clearance

    def _contact_cells(self) -> np.ndarray:
        """Owned cells where the asperity pressure can be non-zero at a quadrature point.

        Greenwood-Tripp's pressure and contact area vanish exactly for h/sigma >= contact.support;
        a cell is kept when the film thickness at one of its vertices is below that plus the most it
        can fall toward the cell's interior (|eps| times the cell's angular extent).
        """
        if self.contact is None:
            return np.zeros(0, dtype=np.int32)
        eps_x, eps_y = float(self.params.eps_x.value), float(self.params.eps_y.value)
        limit = (
            self.contact.support * self.sigma / self.bearing.clearance
            + math.hypot(eps_x, eps_y) * self._cell_extent
        )
        if self.W is not None:  # the deformation at the vertices (P1: the cells' dofs)
            H = (
                1.0
                - eps_x * self._vertex_cos
                - eps_y * self._vertex_sin
                + self.W.x.array[self._operator.dofs]
            )
            return self._owned_cells[H.min(axis=1) < limit]
        below = 1.0 - eps_x * self._node_cos - eps_y * self._node_sin < limit  # at the nodes
        a, b, c = self._cell_nodes
        return self._owned_cells[below[a] | below[b] | below[c]]

    def _integrate(self, functionals: QuadratureFunctionals) -> np.ndarray:
        """A group of functionals at the last solved state (contact groups on its contact cells only)."""
        return functionals(self._in_contact if functionals.contact_only else None)

    def _assemble(self, form) -> float:
        value = fem.assemble_scalar(form)
        return value if self.comm.size == 1 else self.comm.allreduce(value, op=MPI.SUM)

    def _functionals(self) -> dict[str, float]:
        """SI values of every functional, and of the Jacobian rows (in the solution frame)."""
        raw = {k: vec.dot(self.pressure.vector) for k, vec in self._force_vectors.items()}
        if self._operator is not None:  # integrated with the operator's coefficients, at this state
            raw.update(zip(self._operator_integral_names, self._operator.integrals))
        if self._pressure_torque is not None:
            n = self._pressure_torque.B.shape[1]
            value = self._pressure_torque(
                self.pressure.x.array[:n],
                float(self.params.eps_x.value),
                float(self.params.eps_y.value),
                None if self.W is None else self.W.x.array[:n],
            )
            raw.update(dict.fromkeys(_PRESSURE_TORQUES, value))
        for names, functionals in self._scalars:
            raw.update(zip(names, self._integrate(functionals)))
        values = {k: raw[k] * scale for k, (_, scale, _, _) in self._outputs.items()}
        values.update({k: raw[k] for k in self._extra_names})
        for row in _JACOBIAN_ROWS:
            values[row] = sum(values[k] for k, (_, _, r, _) in self._outputs.items() if r == row)
        return values

    def _pressure_peak(self) -> tuple[float, float, float]:
        """(P_max, theta, Z) over the dofs, reduced over ranks."""
        coords = self._owned_coords
        n_owned = len(coords)
        values = self.pressure.x.array[:n_owned]
        if n_owned:
            i = int(np.argmax(values))
            local = (
                float(values[i]),
                math.atan2(coords[i, 1], coords[i, 0]) % (2 * math.pi),
                float(coords[i, 2]),
            )
        else:
            local = (-math.inf, 0.0, 0.0)
        return local if self.comm.size == 1 else max(self.comm.allgather(local))

    def jacobian(self) -> FilmJacobian:
        """Exact derivatives of forces and torques w.r.t. (ecc_x, ecc_y, ecc_rate_x, ecc_rate_y, omega_rel), SI."""
        if self._last is None:
            raise RuntimeError("jacobian() needs a solve() first")
        start = time.perf_counter()
        try:
            return self._jacobian()
        finally:
            self.stats.jacobians += 1
            self.stats.jacobian_seconds += time.perf_counter() - start

    def _jacobian(self) -> FilmJacobian:
        vectors = self._jacobian_vectors()
        n_in, n_grad = self._n_inputs, len(self._gradient_rows)
        dr, gradients, w_gradients = vectors[:n_in], vectors[n_in : n_in + n_grad], vectors[n_in + n_grad :]
        for vec in dr:
            fem_petsc.set_bc(vec, self.bcs, scale=0.0)
        if self._ehd is not None:  # pressure and deformation together (solver.film.ehd, ehd_jfo)
            names = list(self.geometry.variables())
            dr_film = (
                [v.getArray().copy() for v in dr]
                if self._jfo is None
                else self._jfo_derivatives.kinematic_derivatives(self._ehd.u, self._ehd.rate)
            )
            d = self._ehd.sensitivities(self._ehd.residual_derivatives(dr_film, names))
            n = self._ehd.n
            dP_arrays = [d_k[:n] for d_k in d]
            dW = [self._ehd.deformation(d_k[n:]) for d_k in d]
        elif self._jfo is not None:  # the mass-conserving film's own (solver.film.jfo)
            n = len(self._owned_coords)
            dr_u = self._jfo_derivatives.kinematic_derivatives(self._jfo.u.x.array[:n], self._jfo_rate)
            dP_arrays = self._jfo.sensitivities(dr_u)
        if self._ehd is not None or self._jfo is not None:
            dP = []
            for d_k in dP_arrays:
                vec = dr[0].duplicate()
                vec.setArray(d_k)
                dP.append(vec)
        else:
            dP = self.solver.sensitivities(dr)
        if self.piezo is not None:  # of the true pressure: dp = (mu(p) / mu0) dq node by node
            slope = self._pressure_slope()
            for vec in dP:
                vec.getArray()[:] *= slope[: len(vec.getArray())]
        s = self.scales
        # In the solution frame, SI outputs per dimensionless input (eps, deps, U_mean, U_half_diff).
        J = np.zeros((4, self._n_inputs))
        for keys, functionals in self._explicit:
            for (i, j, _), value in zip(keys, self._integrate(functionals)):
                J[i, j] += value
        for i, row in enumerate(_JACOBIAN_ROWS):
            for name, (_, scale, r, _) in self._outputs.items():
                if r == row and name in self._force_vectors:
                    J[i] += scale * np.array([self._force_vectors[name].dot(d) for d in dP])
        for i, gradient in zip(self._gradient_rows, gradients):
            J[i] += np.array([gradient.dot(d) for d in dP])
        for i, gradient in zip(self._w_gradient_rows, w_gradients):  # through the deformation
            values = gradient.getArray(readonly=True)
            J[i] += np.array([values @ d for d in dW])
        for vec in dP:
            vec.destroy()
        # Relative speed Omega = omega_j - omega_b: U_mean = Omega / (2 omega_ref), U_half_diff = -U_mean.
        J = np.column_stack([J[:, :4], (J[:, 4] - J[:, 5]) / (2 * s.omega_ref)])
        if self.bearing.inlet == "max-gap" and math.hypot(*self._last.ecc) > 1e-9 * self.bearing.clearance:
            # In the solution frame the eccentricity is (-a, 0) and turning it (d eps'_y = -a dphi)
            # turns the inlet line with it. Turning eps and its rate together is a symmetry
            # (F -> S F dphi, M unchanged), so at fixed rate:
            # dF/dphi = S F' - J'_rate S deps',  dM/dphi = -J'_M,rate S deps'.
            a = math.hypot(*self._last.ecc) / self.bearing.clearance
            S = np.array([[0.0, -1.0], [1.0, 0.0]])
            rate = _rotation(-self._beta) @ np.asarray(self._last.ecc_rate) / s.eccentricity_rate
            d_dphi = -J[:, 2:4] @ (S @ rate)
            d_dphi[:2] += S @ self._force_solved
            J[:, 1] = d_dphi / (-a)
        rot, rot_back = _rotation(self._beta), _rotation(-self._beta)
        J[:2, :2] = rot @ J[:2, :2] @ rot_back
        J[:2, 2:4] = rot @ J[:2, 2:4] @ rot_back
        J[:2, 4] = rot @ J[:2, 4]
        J[2:, :2] = J[2:, :2] @ rot_back
        J[2:, 2:4] = J[2:, 2:4] @ rot_back
        in_scale = np.array([self.bearing.clearance] * 2 + [s.eccentricity_rate] * 2 + [1.0])[None, :]
        return FilmJacobian(J / in_scale)

    # -- fields ---------------------------------------------------------------------------------
    def fields_si(self) -> dict[str, fem.Function]:
        """Pressure [Pa], film thickness [m] (and asperity pressure [Pa]) as Functions on the film mesh,
        for output: the same Functions on every call, holding the current solution."""
        with _quiet_jit():
            return self._fields_si()

    def _fields_si(self) -> dict[str, fem.Function]:
        if self._fields is None:  # Functions and compiled expressions, reused by every call
            points = self.V.element.interpolation_points()
            functions = {
                "pressure": fem.Function(self.V, name="pressure_Pa"),
                "film_thickness": fem.Function(self.V, name="film_thickness_m"),
            }
            if self.W is not None:
                functions["deformation"] = fem.Function(self.V, name="deformation_m")
            if self._jfo is not None:
                functions["film_fraction"] = fem.Function(self.V, name="film_fraction")
            expressions = {"film_thickness": fem.Expression(self.geometry.H * self.bearing.clearance, points)}
            if self.contact is not None:
                functions["asperity_pressure"] = fem.Function(self.V, name="asperity_pressure_Pa")
                Hs = self.geometry.H / self.params.S
                expressions["asperity_pressure"] = fem.Expression(self.contact.pressure(Hs, mod=ufl), points)
            self._fields = functions, expressions
        functions, expressions = self._fields
        functions["pressure"].x.array[:] = self.pressure.x.array * self.scales.pressure
        if self.W is not None:
            functions["deformation"].x.array[:] = self.W.x.array * self.bearing.clearance
        if self._jfo is not None:
            functions["film_fraction"].x.array[: len(self._jfo_solution.theta)] = self._jfo_solution.theta
        for name, expression in expressions.items():
            functions[name].interpolate(expression)
        return functions

    def close(self) -> None:
        if self._ehd is not None:
            self._ehd.close()
        if self._jfo is not None:
            self._jfo.close()
        self._nodal_areas.destroy()
        self.solver.close()
        self._jacobian_vectors.close()
        for vec in self._force_vectors.values():
            vec.destroy()

    def __enter__(self) -> FilmModel:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class BlockedVectors:
    """Several linear forms in the test function of a scalar space, assembled in one pass.

    ``integrands`` are (integrand, measure) pairs; integrands of the same measure share one kernel.

    The integrands become the components of one form in the blocked (vector) space of the same
    element, so the kernel computes their common subexpressions (film thickness, flow factors) once
    per quadrature point instead of once per form; the components are then copied into vectors of
    the scalar space (reused between calls: do not keep them across calls).
    """

    def __init__(self, V, v, integrands: list[tuple[object, object]]):
        element = V.ufl_element()
        self.size = len(integrands)
        blocked = fem.VectorFunctionSpace(V.mesh, (element.family(), element.degree()), dim=self.size)
        w = ufl.TestFunction(blocked)
        self.form = _form(
            sum(ufl.replace(e, {v: w[i]}) * measure for i, (e, measure) in enumerate(integrands))
        )
        self.blocked = fem_petsc.create_vector(self.form)
        n_owned = V.dofmap.index_map.size_local
        if blocked.dofmap.index_map.size_local != n_owned:
            raise RuntimeError("blocked space distributed differently from the scalar space")
        # node k of the blocked space carries the values of scalar dof order[k] (the same nodes,
        # possibly numbered differently)
        scalar_x = np.round(V.tabulate_dof_coordinates()[:n_owned], 12)
        blocked_x = np.round(blocked.tabulate_dof_coordinates()[:n_owned], 12)
        by_scalar, by_blocked = np.lexsort(scalar_x.T), np.lexsort(blocked_x.T)
        self.order = np.empty(n_owned, dtype=np.int64)
        self.order[by_blocked] = by_scalar
        if not np.allclose(scalar_x[self.order], blocked_x, atol=1e-10):
            raise RuntimeError("the blocked space's nodes differ from the scalar space's")
        self.vectors = [create_petsc_vector(V.dofmap.index_map, V.dofmap.index_map_bs) for _ in integrands]

    def __call__(self) -> list[PETSc.Vec]:
        with self.blocked.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self.blocked, self.form)
        self.blocked.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        values = self.blocked.getArray(readonly=True).reshape(-1, self.size)
        for i, vec in enumerate(self.vectors):
            vec.getArray()[self.order] = values[:, i]
            vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.vectors

    def close(self) -> None:
        for vec in [self.blocked, *self.vectors]:
            vec.destroy()


class QuadratureFunctionals:
    """Many integrals over one mesh in one pass: a vector-valued ``fem.Expression`` of the integrands
    (times the area element) at the quadrature points of every owned cell, summed with the weights.

    Equivalent to assembling each scalar form (same quadrature rule as FFCx's default of that
    degree), but one kernel call instead of one assembly per functional, which matters when a film
    solve needs ~10 of them.
    """

    def __init__(self, mesh, integrands: list, degree: int, *, contact_only: bool = False):
        points, self.weights = basix.make_quadrature(basix.CellType.triangle, degree)
        self.contact_only = contact_only  # evaluated only on the cells that FilmModel._contact_cells gives
        area = abs(ufl.JacobianDeterminant(mesh))
        self.size = len(integrands)
        self.expression = fem.Expression(ufl.as_vector([e * area for e in integrands]), points)
        self.cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
        self.comm = mesh.comm

    def __call__(self, cells: np.ndarray | None = None) -> np.ndarray:
        """The integrals over the owned cells, or over ``cells`` (where the others contribute 0)."""
        cells = self.cells if cells is None else cells
        local = np.zeros(self.size)
        if len(cells):
            values = self.expression.eval(cells).reshape(len(cells), len(self.weights), self.size)
            local = np.einsum("cqn,q->n", values, self.weights)
        return local if self.comm.size == 1 else self.comm.allreduce(local, op=MPI.SUM)


def _functionals_by_group(mesh, integrands: dict, groups: dict) -> list[tuple[list, QuadratureFunctionals]]:
    """``{key: (integrand, group)}`` -> [(keys, QuadratureFunctionals)], one per group of ``groups``
    (``{group: (measure, contact_only)}``) that has integrands."""
    members: dict[str, list] = {}
    for key, (e, group) in integrands.items():
        members.setdefault(group, []).append((key, e))
    out = []
    for group, items in members.items():
        measure, contact_only = groups[group]
        functionals = QuadratureFunctionals(
            mesh, [e for _, e in items], measure.metadata()["quadrature_degree"], contact_only=contact_only
        )
        out.append(([key for key, _ in items], functionals))
    return out


def _is_zero(expression) -> bool:
    """True when a UFL derivative is identically zero (such forms are not assembled)."""
    try:
        return isinstance(expand_derivatives(expression), ufl.constantvalue.Zero)
    except Exception:  # noqa: BLE001 - UFL cannot always simplify; then assume non-zero
        return False


def _rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


@dataclasses.dataclass(frozen=True)
class Equilibrium:
    """Static equilibrium of the journal under a load."""

    kinematics: Kinematics
    result: FilmResult
    newton_iterations: int
    force_residual: float  # N, |film force + load| at the solution


def equilibrium(
    model: FilmModel,
    load: tuple[float, float],
    *,
    omega_journal: float,
    omega_bushing: float = 0.0,
    tol: float = 1e-7,
    max_iterations: int = 60,
    guess: tuple[float, float] | None = None,
) -> Equilibrium:
    """Find the eccentricity at which the film (and asperity) force balances the load on the journal.

    Newton's method with the film's exact Jacobian, in the coordinates ``s = -ln(1 - eps/eps_lim)`` and
    the angle ``phi`` of the eccentricity: near eps = 1 the film force grows like (1 - eps)^-2 and the
    asperity force exponentially in h/sigma, both far more linear in s than in eps. Each step is
    halved until the force residual decreases. eps_lim is the model's max_eccentricity_ratio: 1 when
    rigid; an elastic bushing lets the pin go further, into the deformed bushing.

    Args:
        load: external load on the journal, bushing frame [N].
        tol: relative tolerance on the force residual, |F + W| <= tol |W|.
        guess: starting eccentricity [m]; default eps = 0.5, 50 deg ahead of the load line.

    Raises:
        InputError: the load cannot be carried below MAX_ECCENTRICITY, or Newton's method stalls.
    """
    W = np.asarray(load, float)
    W_norm = float(np.linalg.norm(W))
    if not W_norm > 0:
        raise out_of_range("load", W_norm, "> 0 N")
    c, limit = model.bearing.clearance, model.max_eccentricity_ratio
    s_max = -math.log(1 - MAX_ECCENTRICITY)
    if guess is None:
        angle = math.atan2(W[1], W[0]) + math.copysign(math.radians(50), omega_journal - omega_bushing or 1.0)
        guess = (0.5 * c * math.cos(angle), 0.5 * c * math.sin(angle))
    eps0 = min(max(math.hypot(*guess) / c, 1e-3), MAX_ECCENTRICITY * limit)
    x = np.array([-math.log(1 - eps0 / limit), math.atan2(guess[1], guess[0])])  # (s, phi)

    def ecc(x_vec):
        eps = limit * (1 - math.exp(-x_vec[0]))
        return eps, c * eps * np.array([math.cos(x_vec[1]), math.sin(x_vec[1])])

    def residual(x_vec):
        _, e_vec = ecc(x_vec)
        kin = Kinematics((float(e_vec[0]), float(e_vec[1])), (0.0, 0.0), omega_journal, omega_bushing)
        res = model.solve(kin)
        return kin, res, np.asarray(res.force) + W

    kin, res, r = residual(x)
    for iteration in range(max_iterations):
        if np.linalg.norm(r) <= tol * W_norm:
            return Equilibrium(kin, res, iteration, float(np.linalg.norm(r)))
        eps, _ = ecc(x)
        # d e / d(s, phi) = c [(eps_lim - eps) u, eps u_perp]
        u, u_perp = np.array([math.cos(x[1]), math.sin(x[1])]), np.array([-math.sin(x[1]), math.cos(x[1])])
        J = model.jacobian().force_ecc @ (c * np.column_stack([(limit - eps) * u, eps * u_perp]))
        step = -np.linalg.solve(J, r)
        lam = 1.0
        while True:
            trial = x + lam * step
            trial[0] = min(max(trial[0], 1e-4), s_max)
            try:
                kin_t, res_t, r_t = residual(trial)
            except FilmNotConverged:  # too far a step for the film (an elastic one): shorter
                r_t = np.full(2, np.inf)
            if np.linalg.norm(r_t) < np.linalg.norm(r):
                break
            lam *= 0.5
            if lam < 1e-3:
                if x[0] >= s_max * (1 - 1e-9) and np.dot(res.force, W) < 0 and res.load < W_norm:
                    raise InputError(
                        f"load = {W_norm:g} N cannot be carried (eccentricity ratio reaches "
                        f"{MAX_ECCENTRICITY * limit:g})"
                    )
                # The discrete VI force is only piecewise smooth (the active set moves node by node);
                # very near eps = 1 its kinks put a floor of ~1e-4 |W| under the residual.
                if np.linalg.norm(r) <= STALL_TOLERANCE * W_norm:
                    return Equilibrium(kin, res, iteration, float(np.linalg.norm(r)))
                raise InputError(
                    f"load = {W_norm:g} N: the equilibrium search stalled at eccentricity ratio "
                    f"{eps:.6f} (residual {np.linalg.norm(r):.3g} N)"
                )
        x, kin, res, r = trial, kin_t, res_t, r_t
    raise InputError(f"load = {W_norm:g} N: no equilibrium found in {max_iterations} Newton iterations")
