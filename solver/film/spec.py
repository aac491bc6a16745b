"""What a film is made of, as frozen data checked once: ``FilmSpec``.

A FilmSpec names the bearing (geometry, oil, inlet, supply), the surface (roughness, contact), the
cavitation law, the bushing (None: rigid; solver.film.bushings.WinklerLayer; FEEye, the finite-element
eye as data, or an already built ModalCompliance), the piezoviscosity law and the numerics. Building one
checks every compatibility rule (solver.film_rules.check_film, the rules the case loader and the command
line check too); nothing is meshed or assembled here. ``solver.film.factory.make_film(spec, comm)``
turns it into a film.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from solver.film.types import Bearing
from solver.film_rules import check_film


@dataclasses.dataclass(frozen=True, kw_only=True)
class FilmSpec:
    """A film's specification (module docstring).

    Args:
        bearing: geometry and oil.
        omega_ref: reference angular speed of the scaling [rad/s].
        mesh_size: element size / R (None: default_mesh_size of the bearing).
        mesh_edge_size: element size / R at the bushing's edges, graded to mesh_size over 0.3 R (None:
            uniform; solver.film.mesh.FilmMeshSpec.edge_size).
        degree: polynomial degree of the pressure (1 or 2).
        roughness: Patir-Cheng flow factors (solver.film.flow_factors.PatirCheng); None: smooth film.
        contact: Greenwood-Tripp asperity contact (solver.film.contact.GreenwoodTripp); None: no contact.
        slip_regularisation: sliding speed [m/s] below which asperity friction is smoothed to zero.
        options: PETSc options over solver.film.cavitation.DEFAULT_OPTIONS.
        half: solve the half z >= 0 of the film (it is symmetric about the mid-plane); False meshes
            the whole width (same results to the discretisation error, twice the unknowns).
        bushing: None (rigid), a WinklerLayer, an FEEye or a ModalCompliance (solver.film.bushings).
            Serial, P1; pressure and deformation are then solved together (solver.film.ehd).
        piezoviscosity: the oil's pressure-viscosity law (solver.film.viscosity.Barus or Roelands);
            None: iso-viscous. The film is then solved for the reduced pressure.
        cavitation: "reynolds" (the VI p >= p_cav) or "jfo" (mass-conserving, solver.film.jfo: serial
            P1; the film fraction is film state, committed like the deformation).
        transport: the JFO film fraction's transport, "limited" or "upwind" (solver.film.transport).
        cavitated_shear: the JFO film's Couette shear in the cavitated zone: "film-fraction" (theta mu U /
            h: only the oil streamers shear; solver.film.forms) or "full" (mu U / h, the full film's,
            as the Reynolds film; the behaviour before 2026-11-27). No effect on a Reynolds film.
        quasi_static: solved without time (the bearing command, equilibria): no history is committed,
            so the max-gap inlet is allowed with a history (solver.film_rules).
        joint: the engine's joint whose case section chose the bushing ("small_end", "big_end",
            "pin_boss"): the section its one-line errors name.
        edge_relief: the bore's relief at both edges (solver.film.relief.EdgeRelief), or None: a
            cylindrical bore.
    """

    bearing: Bearing
    omega_ref: float
    mesh_size: float | None = None
    mesh_edge_size: float | None = None
    degree: int = 1
    roughness: Any = None
    contact: Any = None
    slip_regularisation: float = 1e-3
    options: dict | None = None
    half: bool = True
    bushing: Any = None
    piezoviscosity: Any = None
    cavitation: str = "reynolds"
    transport: str = "limited"
    cavitated_shear: str = "film-fraction"
    quasi_static: bool = False
    joint: str = "small_end"
    edge_relief: Any = None

    def __post_init__(self) -> None:
        self.check()

    @property
    def bushing_kind(self) -> str:
        """ "none" (rigid), "winkler" or "fe"."""
        return "none" if self.bushing is None else self.bushing.kind

    @property
    def has_history(self) -> bool:
        """A solve depends on committed film states: an elastic bushing (its deformation's rate) or the
        mass-conserving film (its film fraction)."""
        return self.bushing is not None or self.cavitation == "jfo"

    @property
    def sigma(self) -> float:
        """The composite roughness [m] (0: smooth)."""
        sigmas = [x.sigma for x in (self.roughness, self.contact) if x is not None]
        return sigmas[0] if sigmas else 0.0

    def check(self, ranks: int = 1) -> None:
        """Every compatibility rule (solver.film_rules.check_film) on ``ranks`` processes."""
        check_film(
            cavitation=self.cavitation,
            bushing=self.bushing_kind,
            inlet=self.bearing.inlet,
            supply=self.bearing.supply is not None,
            cavitation_pressure=self.bearing.cavitation_pressure,
            degree=self.degree,
            transport=self.transport,
            cavitated_shear=self.cavitated_shear,
            ranks=ranks,
            quasi_static=self.quasi_static,
            sigmas=tuple(x.sigma for x in (self.roughness, self.contact) if x is not None),
            joint=self.joint,
        )
        if self.edge_relief is not None:
            self.edge_relief.check_width(self.bearing.width)
