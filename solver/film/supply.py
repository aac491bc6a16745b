"""The oil supplies on the film surface, as data (dimensionless: lengths / R): a round hole, a
rectangular axial groove or a full circumferential groove (solver.film.mesh cuts them into the mesh).

Pure data: imports no dolfinx and no gmsh (the value types of solver.film.types use them).
"""

from __future__ import annotations

import dataclasses
import math

from solver.errors import out_of_range


@dataclasses.dataclass(frozen=True, kw_only=True)
class SupplyHole:
    """A circular oil-supply hole on the bushing surface (dimensionless: lengths / R)."""

    angle: float  # rad, bushing angle theta of the hole centre
    z: float = 0.0  # axial position of the centre / R
    diameter: float = 0.2  # hole diameter / R

    @property
    def rim_size(self) -> float:
        """Element size / R at the rim: six elements across the diameter."""
        return self.diameter / 6

    def check(self, width: float, half: bool) -> None:
        """Raise InputError unless the hole fits on a film of width ``width`` (/ R)."""
        if not 0 < self.diameter < min(width, math.pi):
            raise out_of_range(
                "supply hole diameter / radius", self.diameter, f"(0, {min(width, math.pi):.3g})"
            )
        if not abs(self.z) + self.diameter / 2 < width / 2:
            raise out_of_range("supply hole axial position / radius", self.z, "inside the bearing width")
        if half and self.z != 0.0:
            raise out_of_range("supply hole axial position / radius", self.z, "0 on a half mesh")


@dataclasses.dataclass(frozen=True, kw_only=True)
class AxialGroove:
    """A rectangular axial oil groove on the bushing surface, centred on the mid-plane (dimensionless).

    It covers the bushing angles ``angle - arc/2 <= theta <= angle + arc/2`` and ``|z| <= length/2``:
    area ``arc * length`` (R^2) on the cylinder.
    """

    angle: float  # rad, bushing angle theta of the groove's centre
    arc: float  # rad, its circumferential extent, in (0, 2 pi)
    length: float  # its axial length / R, < B/R

    @property
    def area(self) -> float:
        """Its area on the unit cylinder."""
        return self.arc * self.length

    @property
    def rim_size(self) -> float:
        """Element size / R at the rim: four elements along its shorter side."""
        return min(self.arc, self.length) / 4

    def check(self, width: float, half: bool) -> None:
        """Raise InputError unless the groove fits on a film of width ``width`` (/ R)."""
        if not math.isfinite(self.angle):
            raise out_of_range("axial groove angle", self.angle, "a finite number of rad")
        if not 0 < self.arc < 2 * math.pi:
            raise out_of_range("axial groove arc", f"{math.degrees(self.arc):g} deg", "(0, 360) deg")
        if not 0 < self.length < width:
            raise out_of_range(
                "axial groove length / radius",
                f"{self.length:g}",
                f"(0, {width:g}), inside the bearing width",
            )


@dataclasses.dataclass(frozen=True, kw_only=True)
class CircumferentialGroove:
    """A full circumferential oil groove: the band ``|z| <= width/2`` all the way round (dimensionless),
    area ``2 pi width`` (R^2) on the cylinder."""

    width: float  # its axial width / R, < B/R

    @property
    def area(self) -> float:
        """Its area on the unit cylinder."""
        return 2 * math.pi * self.width

    @property
    def rim_size(self) -> float:
        """Element size / R at its two rims: four elements across the band."""
        return self.width / 4

    def check(self, width: float, half: bool) -> None:
        """Raise InputError unless the band fits on a film of width ``width`` (/ R)."""
        if not 0 < self.width < width:
            raise out_of_range(
                "circumferential groove width / radius",
                f"{self.width:g}",
                f"(0, {width:g}), inside the bearing width",
            )


Supply = SupplyHole | AxialGroove | CircumferentialGroove
