"""The finite-element eye's geometry and mesh (gmsh): ``EyeGeometry``, ``eye_mesh`` and the facet tags.
The compliance built on it, and its cache: solver.film.compliance (whose module docstring describes the
mesh: element edge ``DEFAULT_ELEMENT_SIZE`` R in the eye, the bushing thickness on the bore)."""

from __future__ import annotations

import dataclasses
import math

from mpi4py import MPI

import gmsh
from dolfinx.io import gmshio

from solver.errors import out_of_range
from solver.film.mesh import initialize_gmsh

DEFAULT_ELEMENT_SIZE = 0.3  # element edge in the eye / R (see Mesh in solver.film.compliance)
TAGS = {"bushing": 1, "eye": 2, "bore": 11, "symmetry": 12, "clamp": 13}


@dataclasses.dataclass(frozen=True, kw_only=True)
class EyeGeometry:
    """The small-end eye with its bushing (SI units)."""

    bore_radius: float  # m, film surface = bushing inner radius (the pin radius R; clearance negligible)
    width: float  # m, axial width of eye and bushing (= bearing width B)
    bushing_thickness: float  # m, bronze bushing wall t; 0: no bushing (the eye bore is the film surface)
    eye_outer_radius: float  # m, outer radius of the eye r_o > R + t
    E_eye: float = 210e9  # Pa, rod/eye (steel)
    nu_eye: float = 0.3
    E_bushing: float = 115e9  # Pa, bushing (bronze)
    nu_bushing: float = 0.33
    shank_angle_deg: float = 180.0  # bushing angle theta_s of the middle of the eye-shank junction
    shank_half_angle_deg: float = 30.0  # half angle alpha of the clamped arc of the eye's outer surface

    def __post_init__(self) -> None:
        for name in ("bore_radius", "width", "E_eye", "E_bushing"):
            if not getattr(self, name) > 0:
                raise out_of_range(f"eye.{name}", getattr(self, name), "> 0")
        if not self.bushing_thickness >= 0:
            raise out_of_range("eye.bushing_thickness", self.bushing_thickness, ">= 0")
        inner = self.bore_radius + self.bushing_thickness
        if not self.eye_outer_radius > inner:
            raise out_of_range(
                "eye.eye_outer_radius",
                self.eye_outer_radius,
                f"> bore radius + bushing thickness = {inner:g}",
            )
        for name in ("nu_eye", "nu_bushing"):
            if not 0 <= getattr(self, name) < 0.5:
                raise out_of_range(f"eye.{name}", getattr(self, name), "[0, 0.5)")
        if not 0 < self.shank_half_angle_deg < 180:
            raise out_of_range("eye.shank_half_angle_deg", self.shank_half_angle_deg, "(0, 180)")

    @property
    def eye_inner_radius(self) -> float:
        """Radius of the eye-bushing interface R + t [m]."""
        return self.bore_radius + self.bushing_thickness


# ---------------------------------------------------------------------------------------------------
# The mesh


def _support_angles(geometry: EyeGeometry, clamp: bool) -> list[float]:
    """Angles where the eye and bushing are split into sectors: the ends of the clamped arc, or (no
    clamp) the axes, whose bore points at z = 0 then are mesh vertices for the point supports."""
    if clamp:
        theta_s, alpha = math.radians(geometry.shank_angle_deg), math.radians(geometry.shank_half_angle_deg)
        return [theta_s - alpha, theta_s + alpha]
    return [0.0, math.pi / 2, math.pi, 3 * math.pi / 2]


def _build_gmsh_model(
    geometry: EyeGeometry, element_size: float, bore_element_size: float, clamp: bool
) -> None:
    """Eye and bushing (lengths / R) as annular sectors, fragmented into one conforming mesh."""
    occ = gmsh.model.occ
    R = geometry.bore_radius
    half_width = geometry.width / 2 / R
    r_bore, r_interface, r_outer = 1.0, geometry.eye_inner_radius / R, geometry.eye_outer_radius / R

    def sector(r_in: float, r_out: float, start: float, end: float) -> list[tuple[int, int]]:
        outer = occ.addCylinder(0, 0, 0, 0, 0, half_width, r_out, angle=end - start)
        inner = occ.addCylinder(0, 0, 0, 0, 0, half_width, r_in, angle=end - start)
        piece, _ = occ.cut([(3, outer)], [(3, inner)])
        occ.rotate(piece, 0, 0, 0, 0, 0, 1, start)
        return piece

    cuts = _support_angles(geometry, clamp)
    ends = list(zip(cuts, cuts[1:] + [cuts[0] + 2 * math.pi]))
    bushing = [p for a, b in ends for p in sector(r_bore, r_interface, a, b)] if r_interface > r_bore else []
    eye = [p for a, b in ends for p in sector(r_interface, r_outer, a, b)]
    _, pieces = occ.fragment(bushing + eye, [])
    occ.synchronize()
    groups = {
        "bushing": [t for piece in pieces[: len(bushing)] for _, t in piece],
        "eye": [t for piece in pieces[len(bushing) :] for _, t in piece],
        "bore": [],
        "symmetry": [],
        "clamp": [],
    }
    theta_s, alpha = math.radians(geometry.shank_angle_deg), math.radians(geometry.shank_half_angle_deg)
    for _, tag in gmsh.model.getEntities(2):  # a cylindrical face lies on the clamped arc or off it
        if gmsh.model.getBoundingBox(2, tag)[5] < 1e-6:  # (gmsh pads bounding boxes by 1e-7)
            groups["symmetry"].append(tag)
        elif gmsh.model.getType(2, tag) == "Cylinder":
            low, high = gmsh.model.getParametrizationBounds(2, tag)
            x, y, _ = gmsh.model.getValue(2, tag, [(a + b) / 2 for a, b in zip(low, high)])
            radius = math.hypot(x, y)
            on_arc = abs(math.remainder(math.atan2(y, x) - theta_s, math.tau)) < alpha
            if abs(radius - r_bore) < 1e-6:
                groups["bore"].append(tag)
            elif clamp and abs(radius - r_outer) < 1e-6 and on_arc:
                groups["clamp"].append(tag)
    for name, tags in groups.items():
        if tags:
            dim = 3 if name in ("bushing", "eye") else 2
            gmsh.model.addPhysicalGroup(dim, tags, TAGS[name])
            gmsh.model.setPhysicalName(dim, TAGS[name], name)
    _set_sizes(
        groups["bushing"] or groups["eye"],
        element_size,
        bore_element_size,
        (r_bore, r_interface),
        r_outer if clamp else None,
    )
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(2)


def _set_sizes(
    inner_volumes: list[int],
    element_size: float,
    bore_element_size: float,
    bore_radii: tuple[float, float],
    clamp_radius: float | None,
) -> None:
    """Element sizes: ``element_size`` in the eye, ``bore_element_size`` on the bore and the bushing
    (the points of the innermost volumes at the bore radii), and a sixth of the element size at the
    clamp's edges (the axial lines at the ends of the arc, where the stress is singular), graded
    back to the element size over one element size."""
    # set every option the film mesh also sets: gmsh options outlive the model
    gmsh.option.setNumber("Mesh.CharacteristicLengthMin", 0.0)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMax", element_size)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay surfaces
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay: deterministic (HXT is not: threads)
    points = gmsh.model.getBoundary([(3, t) for t in inner_volumes], combined=False, recursive=True)
    bore_points = [(0, t) for d, t in points if d == 0 and _on_radius(t, *bore_radii)]
    gmsh.model.mesh.setSize(bore_points, bore_element_size)
    if clamp_radius is None:
        return
    edges = [t for _, t in gmsh.model.getEntities(1) if _is_axial_line(t, clamp_radius)]
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "CurvesList", edges)
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance)
    field.setNumber(threshold, "SizeMin", element_size / 6)
    field.setNumber(threshold, "SizeMax", element_size)
    field.setNumber(threshold, "DistMin", 0.0)
    field.setNumber(threshold, "DistMax", element_size)
    field.setAsBackgroundMesh(threshold)


def _is_axial_line(curve: int, radius: float) -> bool:
    """Whether a gmsh curve is a line along z at the given radius (lengths / R)."""
    x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, curve)
    return abs(x1 - x0) < 1e-6 and abs(y1 - y0) < 1e-6 and abs(math.hypot(x0, y0) - radius) < 1e-6


def _on_radius(point: int, *radii: float) -> bool:
    """Whether a gmsh point lies on one of the given radii (lengths / R)."""
    x, y, _ = gmsh.model.getValue(0, point, [])
    return any(abs(math.hypot(x, y) - r) < 1e-6 for r in radii)


def eye_mesh(
    geometry: EyeGeometry,
    comm: MPI.Comm,
    *,
    element_size: float,
    bore_element_size: float,
    clamp: bool = True,
):
    """The eye's mesh (lengths / R) on ``comm``: ``(mesh, cell_tags, facet_tags)`` with ``TAGS``.

    gmsh runs on rank 0; dolfinx distributes the mesh over ``comm``.
    """
    if comm.rank == 0:
        initialize_gmsh()
        gmsh.model.add("eye")
        try:
            _build_gmsh_model(geometry, element_size, bore_element_size, clamp)
        except Exception:
            gmsh.model.remove()
            raise
    try:
        return gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)
    finally:
        if comm.rank == 0:
            gmsh.model.remove()


__all__ = ["DEFAULT_ELEMENT_SIZE", "TAGS", "EyeGeometry", "eye_mesh"]
