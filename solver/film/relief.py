"""The bore's edge relief: a profile that opens the film toward the bushing's edges.

An engine bushing's bore is not a cylinder to its edges: it is relieved over a few millimetres at each
edge by a few micrometres (a crowned or tapered edge), so that the pin does not bear on the edge where a
bonded bushing is stiffest and its deformation sharpest. The film thickness gains, at the axial coordinate
z from the mid-plane of a bearing of width B::

    h_r(z) = d ((|z| - (B/2 - l)) / l)^n   where |z| > B/2 - l,  0 elsewhere

with d the depth at the edge, l the relieved length at each edge, n = 2 ("parabolic": tangent to the bore
where the relief starts, as a crowned edge) or n = 1 ("linear": a taper). The middle B - 2 l of the bore
stays cylindrical, so the rigid film's narrowest gap, on the mid-plane, is c - |e| as without relief.

The relief adds to the film thickness H = h / c wherever the film evaluates it: the UFL forms
(solver.film.reynolds.FilmGeometry), the numpy coefficients at midpoints and quadrature points
(solver.film.tensors), the contact cells (solver.film.forms) and the elastic film's rigid gap
(solver.film.solvers); ``thickness`` is the one formula all of them call.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from solver.errors import out_of_range
from solver.film_rules import check_edge_relief_length


@dataclasses.dataclass(frozen=True, kw_only=True)
class EdgeRelief:
    """The bore's relief at both edges (module docstring).

    Args:
        depth: d, the relief at the edge [m] (0: none).
        length: l, the relieved length at each edge [m]; less than half the bearing's width.
        shape: "parabolic" (n = 2) or "linear" (n = 1).
        section: the case section named by the one-line errors (e.g. "small_end").
    """

    depth: float
    length: float
    shape: str = "parabolic"
    section: str = "small_end"

    SHAPES = ("parabolic", "linear")

    def __post_init__(self) -> None:
        if not self.depth >= 0.0:
            raise out_of_range(f"{self.section}.edge_relief_um", f"{self.depth * 1e6:g}", ">= 0")
        if not self.length > 0.0:
            raise out_of_range(f"{self.section}.edge_relief_length_mm", f"{self.length * 1e3:g}", "> 0")
        if self.shape not in self.SHAPES:
            raise out_of_range(
                f"{self.section}.edge_relief_shape", repr(self.shape), " or ".join(self.SHAPES)
            )

    def check_width(self, width: float) -> None:
        """Raise InputError unless the relief leaves the bore's middle cylindrical (l < B / 2)."""
        check_edge_relief_length(self.length, width, self.section)

    @property
    def power(self) -> int:
        return 2 if self.shape == "parabolic" else 1

    def thickness(self, z, *, radius: float, clearance: float, width: float, mod=np):
        """H_r = h_r / c at the axial coordinates z / R (a numpy array, or a UFL expression with
        ``mod=ufl``) of a bearing of ``radius`` R, radial ``clearance`` c and ``width`` B [m]."""
        start, length = (0.5 * width - self.length) / radius, self.length / radius
        s = (abs(z) - start) / length
        s = np.maximum(s, 0.0) if mod is np else mod.max_value(s, 0.0)
        return (self.depth / clearance) * s**self.power
