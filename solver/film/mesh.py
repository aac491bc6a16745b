"""The film mesh: the bearing surface as a cylinder in 3D, meshed by gmsh, read into dolfinx.

The mesh is dimensionless: radius 1 and width ``B/R``, centred on z = 0, so that it depends only on
the width-to-radius ratio, the element size and the optional supply hole. It is a 2D manifold in 3D
(triangles), which makes the film periodic in the circumferential direction without constraints:
the seam of the cylinder is an ordinary interior edge of the mesh.

Named physical groups (``TAGS``):

- ``film`` (cells): the bearing surface,
- ``edge_minus`` / ``edge_plus`` (facets): the circles at z = -B/2 and z = +B/2 (ambient pressure),
- ``mid_plane`` (facets, half meshes only): the circle at z = 0,
- ``supply`` (cells, optional): an oil hole, a disc of given diameter on the surface, held at the
  supply pressure.

The bushing angle theta is measured from the bushing x axis toward its y axis, so a mesh point is
(cos theta, sin theta, z/R). The mesh is made by gmsh on rank 0 of the given communicator and
distributed over it (``dolfinx.io.gmshio.model_to_mesh``).

``half=True`` meshes only the half z >= 0 (the film of aligned surfaces with edges at the same
pressure is symmetric about the mid-plane: zero axial flux there is the natural condition of the
weak form, so nothing has to be imposed); integrals over the whole film are twice those over it.
A supply hole must then be centred on the mid-plane.
"""

from __future__ import annotations

import atexit
import dataclasses
import math

from mpi4py import MPI

import gmsh
import numpy as np
from dolfinx.io import gmshio

from solver.errors import out_of_range

TAGS = {"film": 1, "supply": 2, "edge_minus": 11, "edge_plus": 12, "mid_plane": 13}


@dataclasses.dataclass(frozen=True, kw_only=True)
class SupplyHole:
    """A circular oil-supply hole on the bushing surface (dimensionless: lengths / R)."""

    angle: float  # rad, bushing angle theta of the hole centre
    z: float = 0.0  # axial position of the centre / R
    diameter: float = 0.2  # hole diameter / R


@dataclasses.dataclass(frozen=True, kw_only=True)
class FilmMeshSpec:
    """What the film mesh depends on (all lengths divided by the radius R)."""

    width: float  # B/R
    element_size: float = 0.05  # target element edge length / R
    hole: SupplyHole | None = None
    order: int = 1  # geometry order of the triangles (1 or 2)
    half: bool = False  # mesh only z >= 0 (symmetric film, see the module docstring)

    def __post_init__(self) -> None:
        if not self.width > 0:
            raise out_of_range("width/radius", self.width, "> 0")
        if not 0 < self.element_size <= 1.0:
            raise out_of_range("mesh size (element size / radius)", self.element_size, "(0, 1]")
        if self.order not in (1, 2):
            raise out_of_range("mesh order", self.order, "1 or 2")
        if self.hole is not None:
            if not 0 < self.hole.diameter < min(self.width, math.pi):
                raise out_of_range("supply hole diameter / radius", self.hole.diameter, f"(0, {min(self.width, math.pi):.3g})")
            if not abs(self.hole.z) + self.hole.diameter / 2 < self.width / 2:
                raise out_of_range("supply hole axial position / radius", self.hole.z, "inside the bearing width")
            if self.half and self.hole.z != 0.0:
                raise out_of_range("supply hole axial position / radius", self.hole.z, "0 on a half mesh")

    @property
    def multiplicity(self) -> int:
        """How many copies of the meshed part make the whole film (2 for a half mesh)."""
        return 2 if self.half else 1


def _build_gmsh_model(spec: FilmMeshSpec) -> None:
    """Build the surface, physical groups and mesh in the current gmsh model."""
    occ = gmsh.model.occ
    half = spec.width / 2
    z_start = 0.0 if spec.half else -half
    # The seam of the extruded circle lies at theta = 0; a hole is kept away from it by rotating
    # the circle so that the seam is opposite the hole.
    seam = (spec.hole.angle + math.pi) if spec.hole is not None else 0.0
    circle = occ.addCircle(0.0, 0.0, z_start, 1.0, angle1=0.0, angle2=2 * math.pi)
    occ.rotate([(1, circle)], 0, 0, 0, 0, 0, 1, seam)
    extruded = occ.extrude([(1, circle)], 0.0, 0.0, half - z_start)
    surfaces = [tag for dim, tag in extruded if dim == 2]
    supply_surfaces: list[int] = []
    if spec.hole is not None:
        h = spec.hole
        direction = (math.cos(h.angle), math.sin(h.angle), 0.0)
        tool = occ.addCylinder(0.5 * direction[0], 0.5 * direction[1], h.z, direction[0], direction[1], 0.0, h.diameter / 2)
        out, pieces = occ.fragment([(2, s) for s in surfaces], [(3, tool)])
        film_pieces = [tag for dim, tag in pieces[0]]
        occ.synchronize()
        occ.remove([(d, t) for d, t in out if d == 3], recursive=False)
        occ.remove([(d, t) for d, t in gmsh.model.getEntities(2) if t not in film_pieces], recursive=True)
        occ.synchronize()
        # The piece inside the tool cylinder is the hole: the one whose centre of mass is nearest.
        centre = np.array([direction[0], direction[1], h.z])
        distance = [np.linalg.norm(np.array(occ.getCenterOfMass(2, t)) - centre) for t in film_pieces]
        supply_surfaces = [film_pieces[int(np.argmin(distance))]]
        surfaces = [t for t in film_pieces if t not in supply_surfaces]
    occ.synchronize()
    edges: dict[str, list[int]] = {"edge_minus": [], "edge_plus": [], "mid_plane": []}
    for dim, tag in gmsh.model.getEntities(1):
        bbox = gmsh.model.getBoundingBox(dim, tag)
        for name, z in (("edge_minus", -half), ("edge_plus", half), ("mid_plane", 0.0)):
            if abs(bbox[2] - z) < 1e-5 and abs(bbox[5] - z) < 1e-5 and (name != "mid_plane" or spec.half):
                edges[name].append(tag)
    gmsh.model.addPhysicalGroup(2, surfaces, TAGS["film"])
    gmsh.model.setPhysicalName(2, TAGS["film"], "film")
    if supply_surfaces:
        gmsh.model.addPhysicalGroup(2, supply_surfaces, TAGS["supply"])
        gmsh.model.setPhysicalName(2, TAGS["supply"], "supply")
    for name, tags in edges.items():
        if not tags:
            continue
        gmsh.model.addPhysicalGroup(1, tags, TAGS[name])
        gmsh.model.setPhysicalName(1, TAGS[name], name)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMin", spec.element_size)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMax", spec.element_size)
    if spec.hole is not None:  # resolve the hole's rim
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", min(spec.element_size, spec.hole.diameter / 6))
        gmsh.model.mesh.setSize(gmsh.model.getBoundary([(2, s) for s in supply_surfaces], recursive=True),
                                min(spec.element_size, spec.hole.diameter / 6))
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay: well-shaped triangles
    gmsh.model.mesh.generate(2)
    if spec.order == 2:
        gmsh.model.mesh.setOrder(2)


_gmsh_ready = False


def _initialize_gmsh() -> None:
    """Initialise gmsh once per process (gmsh 4.8 has no ``isInitialized``)."""
    global _gmsh_ready
    if not _gmsh_ready:
        gmsh.initialize(readConfigFiles=False)
        atexit.register(gmsh.finalize)
        _gmsh_ready = True
    gmsh.option.setNumber("General.Terminal", 0)


def film_mesh(spec: FilmMeshSpec, comm: MPI.Comm):
    """Generate the film mesh on ``comm``; returns ``(mesh, cell_tags, facet_tags)``.

    gmsh runs on rank 0 only; the mesh is distributed over ``comm`` by dolfinx.
    """
    rank = 0
    if comm.rank == rank:
        _initialize_gmsh()
        gmsh.model.add("film")
        try:
            _build_gmsh_model(spec)
        except Exception:
            gmsh.model.remove()
            raise
    try:
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, rank, gdim=3)
    finally:
        if comm.rank == rank:
            gmsh.model.remove()
    mesh.name = "film"
    return mesh, cell_tags, facet_tags


__all__ = ["TAGS", "FilmMeshSpec", "SupplyHole", "film_mesh"]
