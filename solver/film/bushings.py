"""The bushings a film can have, and the interface the coupled elastic solve asks of them.

A bushing is described cheaply (``WinklerLayer``; ``FEEye``: the finite-element eye's geometry and its
basis) and becomes, in the factory (solver.film.factory), an object with the ``Bushing`` interface:
deformation shapes Phi and gains g at the film's nodes (solver.film.ehd's ``W = Phi q``,
``q = g * Phi^T F``). A rigid bushing is no object: the factory builds a rigid film. Deformations add:
``Superposed`` joins bushings' shapes and gains (the FE eye's layer basis: the bushing layer node by node,
a ``WinklerLayer``, plus the remainder's modes, a ``ModalCompliance``).

Adding a bushing: a class here with ``kind``, ``shapes`` and ``turn``, and one branch in
solver.film.factory's ``_bushing`` (the film_rules' BUSHINGS name it for the checks).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import Any, Protocol

import numpy as np
import scipy.sparse

from solver.errors import out_of_range
from solver.film.scaling import FilmScales

log = logging.getLogger(__name__)

#: the FE eye's modes are the fewest whose truncation error under the reference loads is within this (the
#: elastic engine cases' answers are those of every mode within 0.2 % with it: docs/verification.md)
DEFAULT_TOLERANCE = 0.001


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


def bonded_layer_coefficient(thickness: float, E: float, nu: float, radius: float = math.inf) -> float:
    """Compliance w = k p [m/Pa] of a bushing of bore radius ``radius`` bonded to a rigid housing under a
    uniform bore pressure: the plane-strain ring a = R <= r <= b = R + t with u(b) = 0 (exact; the eye
    is long and bonded, so eps_z = 0), and the flat layer (``winkler_coefficient``) when R is infinite:

    .. math:: k = (b^2 - a^2) / (a (2 (\\lambda + \\mu) + 2 \\mu b^2 / a^2))

    It is k_flat (1 - O(t / R)): 0.975 k_flat for t = 0.05 R and nu = 0, 0.994 for t = 0.15 R and
    nu = 0.33.
    """
    if math.isinf(radius):
        return winkler_coefficient(thickness, E, nu)
    a, b = radius, radius + thickness
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    return (b * b - a * a) / (a * (2 * (lam + mu) + 2 * mu * b * b / (a * a)))


@dataclasses.dataclass(frozen=True)
class WinklerLayer:
    """A thin elastic layer (the bushing) on a rigid housing: w = k p node by node (DESIGN 7); flat (the
    ``winkler`` bushing), or curved with its bore ``radius`` (the FE eye's local part)."""

    kind = "winkler"

    thickness: float  # m
    E: float  # Pa
    nu: float
    radius: float = math.inf  # m, the bore's: k of the bonded ring (bonded_layer_coefficient)

    def __post_init__(self) -> None:
        if not self.thickness > 0:
            raise out_of_range("bushing thickness", self.thickness, "> 0 m")
        if not self.E > 0:
            raise out_of_range("bushing modulus", self.E, "> 0 Pa")
        if not 0 <= self.nu < 0.5:
            raise out_of_range("bushing Poisson ratio", self.nu, "[0, 0.5)")

    @property
    def coefficient(self) -> float:
        """k = t (1 + nu)(1 - 2 nu) / (E (1 - nu)) [m/Pa]: laterally constrained compression of the layer
        (with a finite radius, of the bonded ring: bonded_layer_coefficient)."""
        return bonded_layer_coefficient(self.thickness, self.E, self.nu, self.radius)

    def shapes(self, theta: np.ndarray, z: np.ndarray, areas: np.ndarray, scales: FilmScales):
        """(Phi, g) at the film's nodes (theta [rad], z [m], lumped areas / R^2)."""
        gains = self.coefficient * scales.pressure / scales.clearance / areas
        return scipy.sparse.identity(len(theta), format="csr"), gains

    def turn(self, q: np.ndarray, turn, delta: float) -> np.ndarray:
        """Its unknowns are the nodal deformation: turned with the frame."""
        return turn(q, delta)


class ModalCompliance:
    """The finite-element compliance of the eye (solver.film.compliance) reduced to m modes: of the whole
    compliance, or with a ``local`` coefficient k of its remainder after the bushing layer's local part
    (``Compliance.modes``)."""

    kind = "fe"

    def __init__(self, compliance, modes: int, local: float = 0.0):
        if not 1 <= modes <= len(compliance.areas):
            raise out_of_range("compliance modes", modes, f"[1, {len(compliance.areas)}]")
        self.compliance, self.modes, self.local = compliance, modes, local

    def shapes(self, theta: np.ndarray, z: np.ndarray, areas: np.ndarray, scales: FilmScales):
        T = self.compliance.interpolation(theta, z)
        Psi, lam = self.compliance.modes(self.modes, self.local)
        Phi = scipy.sparse.csr_matrix(T @ Psi)
        return Phi, lam * scales.pressure * scales.radius**2 / scales.clearance

    def turn(self, q: np.ndarray, turn, delta: float) -> np.ndarray:
        """Modal unknowns belong to the eye, which does not turn (the FE eye refuses the max-gap inlet)."""
        return q


class Superposed:
    """Bushings whose deformations add, ``W = sum_k Phi_k q_k``: the shapes side by side and the gains
    one after the other, so the coupled Newton (solver.film.ehd) sees one bushing and its unknowns are
    the parts' in turn. The FE eye's layer basis: the layer node by node and the remainder's modes."""

    def __init__(self, parts: tuple, kind: str = "fe"):
        self.parts, self.kind = tuple(parts), kind
        self._sizes: list[int] | None = None  # the parts' numbers of unknowns (set by shapes)

    def shapes(self, theta: np.ndarray, z: np.ndarray, areas: np.ndarray, scales: FilmScales):
        shapes = [part.shapes(theta, z, areas, scales) for part in self.parts]
        self._sizes = [Phi.shape[1] for Phi, _ in shapes]
        Phi = scipy.sparse.hstack([scipy.sparse.csr_matrix(Phi) for Phi, _ in shapes], format="csr")
        return Phi, np.concatenate([np.asarray(g, float) for _, g in shapes])

    def turn(self, q: np.ndarray, turn, delta: float) -> np.ndarray:
        """Each part's unknowns as that part turns them."""
        pieces = np.split(q, np.cumsum(self._sizes)[:-1])
        return np.concatenate([part.turn(piece, turn, delta) for part, piece in zip(self.parts, pieces)])


BASES = ("layer", "eigen")  # FEEye.basis


@dataclasses.dataclass(frozen=True)
class FEEye:
    """The finite-element eye and bushing as data: its geometry (solver.film.compliance.EyeGeometry) and
    its basis; the factory builds (or reads from the disk cache) its compliance.

    ``basis``: ``eigen`` (modes of the whole compliance; default) or ``layer`` (the bushing layer's local
    part node by node plus modes of the remainder: a thin bushing on a stiff housing; docs/models.md).
    ``modes``: the modes kept; 0 (default): the fewest whose truncation error under the reference loads is
    at most ``tolerance`` (default 0.001)."""

    geometry: Any  # solver.film.compliance.EyeGeometry
    modes: int = 0
    tolerance: float = DEFAULT_TOLERANCE
    basis: str = "eigen"
    grid: tuple[int, int] = (72, 5)  # the compliance's hat grid: nodes around, over the half width
    kind = "fe"

    def __post_init__(self) -> None:
        n_theta, n_z = self.grid
        if not (12 <= n_theta <= 720 and 2 <= n_z <= 65):
            raise out_of_range("compliance grid", f"{n_theta} x {n_z}", "[12, 720] x [2, 65] nodes")
        if not 0 <= self.modes <= n_theta * n_z:
            raise out_of_range(
                "compliance modes", self.modes, f"[0, {n_theta * n_z}] (the grid's nodes; 0: the tolerance's)"
            )
        if not 0 < self.tolerance < 1:
            raise out_of_range("compliance tolerance", self.tolerance, "(0, 1)")
        if self.basis not in BASES:
            raise out_of_range("compliance basis", repr(self.basis), "'layer' or 'eigen'")

    @property
    def layer(self) -> WinklerLayer | None:
        """The bushing's local part (the layer basis with a bushing), or None."""
        g = self.geometry
        if self.basis != "layer" or not g.bushing_thickness > 0:
            return None
        return WinklerLayer(g.bushing_thickness, g.E_bushing, g.nu_bushing, radius=g.bore_radius)

    def build(self, comm) -> Superposed | ModalCompliance:
        """The eye's compliance (from its disk cache when built before) in its basis (``reduce``)."""
        from solver.film.compliance import eye_compliance  # gmsh, dolfinx

        n_theta, n_z = self.grid
        return self.reduce(eye_compliance(self.geometry, n_theta=n_theta, n_z=n_z, comm=comm))

    def reduce(self, compliance) -> Superposed | ModalCompliance:
        """The bushing of a compliance (solver.film.compliance.Compliance) in this basis: its modes are
        ``modes`` or the fewest within ``tolerance``; the truncation error goes to the log."""
        from solver.film.compliance import reference_loads

        layer = self.layer
        local = layer.coefficient if layer is not None else 0.0
        loads = reference_loads(compliance)
        F = np.column_stack(list(loads.values()))
        modes = min(self.modes or compliance.modes_for(self.tolerance, F, local), compliance.size)
        errors = compliance.truncation_errors(F, local)[modes]
        log.info(
            "eye compliance, %s basis: %s%d modes%s; truncation error %s",
            self.basis,
            f"the bushing layer node by node (k = {local:.4g} m/Pa) + " if layer else "",
            modes,
            f" (chosen for {self.tolerance:.2%})" if not self.modes else "",
            ", ".join(f"{name} {error:.2%}" for name, error in zip(loads, errors)),
        )
        parts = ([layer] if layer is not None else []) + (
            [ModalCompliance(compliance, modes, local)] if modes else []
        )
        return parts[0] if self.basis == "eigen" else Superposed(parts)


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
    modes: int = 0,
    comm=None,
    shank_angle_deg: float = 180.0,
    tolerance: float = DEFAULT_TOLERANCE,
    basis: str = "eigen",
    grid: tuple[int, int] = (72, 5),
):
    """The bushing's description for a FilmSpec: None (rigid), a WinklerLayer, or the finite-element eye
    (an FEEye, built by the factory) in ``basis`` with ``modes`` modes (0: from ``tolerance``), clamped
    around ``shank_angle_deg`` (the engine: 180, the shank opposite the top of the eye in the rod frame).
    Cheap: nothing is meshed here."""
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
    return FEEye(geometry, modes, tolerance, basis, tuple(grid))
