"""The bushings a film can have, and the interface the coupled elastic solve asks of them.

A bushing is described cheaply (``WinklerLayer``; ``FEEye``: the finite-element eye's geometry and the
number of modes kept) and becomes, in the factory (solver.film.factory), an object with the ``Bushing``
interface: deformation shapes Phi and gains g at the film's nodes (solver.film.ehd's ``W = Phi q``,
``q = g * Phi^T F``). A rigid bushing is no object: the factory builds a rigid film.

Adding a bushing: a class here with ``kind``, ``shapes`` and ``turn``, and one branch in
solver.film.factory's ``_bushing`` (the film_rules' BUSHINGS name it for the checks).
"""

from __future__ import annotations

import dataclasses
import logging
from typing import Any, Protocol

import numpy as np
import scipy.sparse

from solver.errors import out_of_range
from solver.film.scaling import FilmScales

log = logging.getLogger(__name__)


class Bushing(Protocol):
    """A deformable bushing as the coupled solve sees it (solver.film.ehd)."""

    kind: str  # "winkler" or "fe" (solver.film_rules.BUSHINGS)

    def shapes(self, theta: np.ndarray, z: np.ndarray, areas: np.ndarray, scales: FilmScales) -> tuple:
        """(Phi (n x m), g (m)) at the film's nodes (theta [rad], z [m], lumped areas / R^2)."""

    def turn(self, q: np.ndarray, turn: Any, delta: float) -> np.ndarray:
        """The unknowns q in a solution frame turned by delta (turn: solver.film.frame.FrameTurn)."""


def winkler_coefficient(thickness: float, E: float, nu: float) -> float:
    """Compliance of a thin layer bonded to a rigid housing, w = k p [m/Pa] (oedometric compression):

    .. math:: k = t (1 + \\nu)(1 - 2 \\nu) / (E (1 - \\nu))
    """
    return thickness * (1 + nu) * (1 - 2 * nu) / (E * (1 - nu))


@dataclasses.dataclass(frozen=True)
class WinklerLayer:
    """A thin elastic layer (the bushing) on a rigid housing: w = k p node by node (DESIGN 7)."""

    kind = "winkler"

    thickness: float  # m
    E: float  # Pa
    nu: float

    def __post_init__(self) -> None:
        if not self.thickness > 0:
            raise out_of_range("bushing thickness", self.thickness, "> 0 m")
        if not self.E > 0:
            raise out_of_range("bushing modulus", self.E, "> 0 Pa")
        if not 0 <= self.nu < 0.5:
            raise out_of_range("bushing Poisson ratio", self.nu, "[0, 0.5)")

    @property
    def coefficient(self) -> float:
        """k = t (1 + nu)(1 - 2 nu) / (E (1 - nu)) [m/Pa]: laterally constrained compression of the layer."""
        return winkler_coefficient(self.thickness, self.E, self.nu)

    def shapes(self, theta: np.ndarray, z: np.ndarray, areas: np.ndarray, scales: FilmScales):
        """(Phi, g) at the film's nodes (theta [rad], z [m], lumped areas / R^2)."""
        gains = self.coefficient * scales.pressure / scales.clearance / areas
        return scipy.sparse.identity(len(theta), format="csr"), gains

    def turn(self, q: np.ndarray, turn, delta: float) -> np.ndarray:
        """Its unknowns are the nodal deformation: turned with the frame."""
        return turn(q, delta)


class ModalCompliance:
    """The finite-element compliance of the eye (solver.film.compliance) reduced to its m dominant modes."""

    kind = "fe"

    def __init__(self, compliance, modes: int):
        if not 1 <= modes <= len(compliance.areas):
            raise out_of_range("compliance modes", modes, f"[1, {len(compliance.areas)}]")
        self.compliance, self.modes = compliance, modes

    def shapes(self, theta: np.ndarray, z: np.ndarray, areas: np.ndarray, scales: FilmScales):
        T = self.compliance.interpolation(theta, z)
        Psi, lam = self.compliance.modes(self.modes)
        Phi = scipy.sparse.csr_matrix(T @ Psi)
        return Phi, lam * scales.pressure * scales.radius**2 / scales.clearance

    def turn(self, q: np.ndarray, turn, delta: float) -> np.ndarray:
        """Modal unknowns belong to the eye, which does not turn (the FE eye refuses the max-gap inlet)."""
        return q


@dataclasses.dataclass(frozen=True)
class FEEye:
    """The finite-element eye and bushing as data: its geometry (solver.film.compliance.EyeGeometry) and
    the modes kept; the factory builds (or reads from the disk cache) its compliance."""

    geometry: Any  # solver.film.compliance.EyeGeometry
    modes: int
    kind = "fe"

    def __post_init__(self) -> None:
        if not 1 <= self.modes <= 1000:
            raise out_of_range("compliance modes", self.modes, "[1, 1000]")

    def build(self, comm) -> ModalCompliance:
        """The eye's compliance (from its disk cache when built before) reduced to ``modes`` modes."""
        from solver.film.compliance import eye_compliance, reference_loads  # gmsh, dolfinx

        compliance = eye_compliance(self.geometry, comm=comm)
        loads = reference_loads(compliance)
        errors = compliance.truncation_error(self.modes, np.column_stack(list(loads.values())))
        log.info(
            "eye compliance with %d modes: truncation error %s",
            self.modes,
            ", ".join(f"{name} {error:.2%}" for name, error in zip(loads, errors)),
        )
        return ModalCompliance(compliance, self.modes)


def bushing_model(
    kind: str,
    *,
    radius: float,
    width: float,
    bushing_thickness: float,
    eye_outer_radius: float,
    E_eye: float,
    nu_eye: float,
    E_bushing: float,
    nu_bushing: float,
    shank_half_angle_deg: float,
    modes: int,
    comm=None,
    shank_angle_deg: float = 180.0,
):
    """The bushing's description for a FilmSpec: None (rigid), a WinklerLayer, or the finite-element eye
    (an FEEye, built by the factory) with ``modes`` modes, clamped around ``shank_angle_deg`` (the engine:
    180, the shank opposite the top of the eye in the rod frame). Cheap: nothing is meshed here."""
    if kind == "none":
        return None
    if kind == "winkler":
        return WinklerLayer(thickness=bushing_thickness, E=E_bushing, nu=nu_bushing)
    if kind != "fe":
        raise out_of_range("elastic", repr(kind), "'none', 'winkler' or 'fe'")
    from solver.film.compliance import EyeGeometry  # (its module loads gmsh: only for the FE eye)

    geometry = EyeGeometry(
        bore_radius=radius,
        width=width,
        bushing_thickness=bushing_thickness,
        eye_outer_radius=eye_outer_radius,
        E_eye=E_eye,
        nu_eye=nu_eye,
        E_bushing=E_bushing,
        nu_bushing=nu_bushing,
        shank_angle_deg=shank_angle_deg,
        shank_half_angle_deg=shank_half_angle_deg,
    )
    return FEEye(geometry, modes)
