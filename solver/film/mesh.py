"""The film mesh: the bearing surface as a cylinder in 3D, meshed by gmsh, read into dolfinx.

The mesh is dimensionless: radius 1 and width ``B/R``, centred on z = 0, so that it depends only on
the width-to-radius ratio, the element size and the optional oil supply. It is a 2D manifold in 3D
(triangles), which makes the film periodic in the circumferential direction without constraints:
the seam of the cylinder is an ordinary interior edge of the mesh.

Named physical groups (``TAGS``):

- ``film`` (cells): the bearing surface,
- ``edge_minus`` / ``edge_plus`` (facets): the circles at z = -B/2 and z = +B/2 (ambient pressure),
- ``mid_plane`` (facets, half meshes only): the circle at z = 0,
- ``supply`` (cells, optional): the oil supply, held at the supply pressure: a round hole
  (``SupplyHole``, a disc on the surface), a rectangular axial groove (``AxialGroove``: an arc of the
  circumference times an axial length, centred on the mid-plane) or a full circumferential groove
  (``CircumferentialGroove``: a band of given axial width all the way round, centred on the
  mid-plane). The supply is cut into the gmsh geometry, so element edges follow its boundary.

The bushing angle theta is measured from the bushing x axis toward its y axis, so a mesh point is
(cos theta, sin theta, z/R). The mesh is made by gmsh on rank 0 of the given communicator and
distributed over it (``dolfinx.io.gmshio.model_to_mesh``).

``half=True`` meshes only the half z >= 0 (the film of aligned surfaces with edges at the same
pressure is symmetric about the mid-plane: zero axial flux there is the natural condition of the
weak form, so nothing has to be imposed); integrals over the whole film are twice those over it.
A supply hole must then be centred on the mid-plane (the grooves always are).
"""

from __future__ import annotations

import atexit
import dataclasses
import math
import signal

from mpi4py import MPI

import gmsh
import numpy as np
from dolfinx.io import gmshio

from solver.errors import InputError, out_of_range
from solver.film.supply import AxialGroove, CircumferentialGroove, Supply, SupplyHole

TAGS = {"film": 1, "supply": 2, "edge_minus": 11, "edge_plus": 12, "mid_plane": 13}


@dataclasses.dataclass(frozen=True, kw_only=True)
class FilmMeshSpec:
    """What the film mesh depends on (all lengths divided by the radius R)."""

    width: float  # B/R
    element_size: float = 0.05  # target element edge length / R
    supply: Supply | None = None  # the oil supply, tagged ``supply`` (None: none)
    order: int = 1  # geometry order of the triangles (1 or 2)
    half: bool = False  # mesh only z >= 0 (symmetric film, see the module docstring)
    #: element size / R at the edges z = +-B/2 (None: element_size everywhere), growing linearly to
    #: element_size over ``edge_layer`` / R from them (where a film cavitates next to flooded edges oil
    #: is drawn in through a layer about one element wide: docs/verification.md)
    edge_size: float | None = None
    edge_layer: float = 0.3

    def __post_init__(self) -> None:
        if not self.width > 0:
            raise out_of_range("width/radius", self.width, "> 0")
        if not 0 < self.element_size <= 1.0:
            raise out_of_range("mesh size (element size / radius)", self.element_size, "(0, 1]")
        if self.order not in (1, 2):
            raise out_of_range("mesh order", self.order, "1 or 2")
        if self.edge_size is not None and not 0 < self.edge_size <= self.element_size:
            raise out_of_range(
                "edge mesh size (element size at the edges / radius)",
                self.edge_size,
                f"(0, {self.element_size:g}], at most the element size",
            )
        if not self.edge_layer > 0:
            raise out_of_range("edge layer / radius", self.edge_layer, "> 0")
        if self.supply is not None:
            if not isinstance(self.supply, Supply):
                raise InputError(
                    f"supply = {self.supply!r} is not a supply (allowed: SupplyHole, AxialGroove, "
                    "CircumferentialGroove)"
                )
            self.supply.check(self.width, self.half)

    @property
    def multiplicity(self) -> int:
        """How many copies of the meshed part make the whole film (2 for a half mesh)."""
        return 2 if self.half else 1


def _supply_tool(occ, supply: Supply) -> tuple[int, float, float]:
    """A solid whose intersection with the film surface is the supply; returns (its tag, and the
    axial range [z_low, z_high] that the supply's piece of the surface lies in)."""
    if isinstance(supply, SupplyHole):  # a radial cylinder through the wall
        direction = (math.cos(supply.angle), math.sin(supply.angle))
        tool = occ.addCylinder(
            0.5 * direction[0],
            0.5 * direction[1],
            supply.z,
            direction[0],
            direction[1],
            0.0,
            supply.diameter / 2,
        )
        return tool, supply.z - supply.diameter / 2, supply.z + supply.diameter / 2
    # grooves: a sector of angle arc (axial) or a whole cylinder (circumferential), of radius 2 and
    # axial range |z| <= extent/2 (on a half mesh its lower half lies below the film)
    extent = supply.length if isinstance(supply, AxialGroove) else supply.width
    if isinstance(supply, AxialGroove):  # the sector starts at the x axis: turned to start at angle - arc/2
        tool = occ.addCylinder(0.0, 0.0, -extent / 2, 0.0, 0.0, extent, 2.0, angle=supply.arc)
        occ.rotate([(3, tool)], 0, 0, 0, 0, 0, 1, supply.angle - supply.arc / 2)
    else:
        tool = occ.addCylinder(0.0, 0.0, -extent / 2, 0.0, 0.0, extent, 2.0)
    return tool, -extent / 2, extent / 2


def _build_gmsh_model(spec: FilmMeshSpec) -> None:
    """Build the surface, physical groups and mesh in the current gmsh model."""
    occ = gmsh.model.occ
    half = spec.width / 2
    z_start = 0.0 if spec.half else -half
    supply = spec.supply
    # The seam of the extruded circle lies at theta = 0; a hole or an axial groove is kept away from
    # it by rotating the circle so that the seam is opposite the supply.
    seam = (supply.angle + math.pi) if isinstance(supply, (SupplyHole, AxialGroove)) else 0.0
    circle = occ.addCircle(0.0, 0.0, z_start, 1.0, angle1=0.0, angle2=2 * math.pi)
    occ.rotate([(1, circle)], 0, 0, 0, 0, 0, 1, seam)
    extruded = occ.extrude([(1, circle)], 0.0, 0.0, half - z_start)
    surfaces = [tag for dim, tag in extruded if dim == 2]
    supply_surfaces: list[int] = []
    if supply is not None:
        tool, z_low, z_high = _supply_tool(occ, supply)
        out, pieces = occ.fragment([(2, s) for s in surfaces], [(3, tool)])
        film_pieces = [tag for dim, tag in pieces[0]]
        occ.synchronize()
        occ.remove([(d, t) for d, t in out if d == 3], recursive=False)
        occ.remove([(d, t) for d, t in gmsh.model.getEntities(2) if t not in film_pieces], recursive=True)
        occ.synchronize()
        # The supply's pieces lie inside its axial range; the rest of the film reaches the edge at
        # z = B/2, outside it (every supply ends inside the width). A hole's piece is told by its centre
        # of mass, within its radius of the hole's centre on the surface (the rest of the film's is near
        # the axis): OCC's bounding boxes of the curved pieces are not tight, and for holes at 150-200
        # deg the hole's box reached beyond its axial range, so no piece was found.
        tol = 1e-6
        for t in film_pieces:
            if isinstance(supply, SupplyHole):
                centre = np.array(gmsh.model.occ.getCenterOfMass(2, t))
                hole = np.array([math.cos(supply.angle), math.sin(supply.angle), supply.z])
                if np.linalg.norm(centre - hole) < supply.diameter / 2:
                    supply_surfaces.append(t)
                continue
            bbox = gmsh.model.getBoundingBox(2, t)
            if bbox[2] >= z_low - tol and bbox[5] <= z_high + tol:
                supply_surfaces.append(t)
        surfaces = [t for t in film_pieces if t not in supply_surfaces]
        if not supply_surfaces or not surfaces:
            raise RuntimeError(f"gmsh did not cut the supply {supply} out of the film surface")
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
    if supply is not None:  # resolve the supply's rim
        rim = min(spec.element_size, supply.rim_size)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", rim)
        gmsh.model.mesh.setSize(
            gmsh.model.getBoundary([(2, s) for s in supply_surfaces], recursive=True), rim
        )
    graded = spec.edge_size is not None and spec.edge_size < spec.element_size
    # gmsh's options outlive the model: set the size's extension from the boundary for every mesh (its
    # default, 1, unless graded), so that a graded mesh does not change the next uniform one
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0 if graded else 1)
    if graded:  # toward the edges
        field = gmsh.model.mesh.field
        distance = field.add("Distance")
        field.setNumbers(distance, "EdgesList", edges["edge_minus"] + edges["edge_plus"])
        field.setNumber(distance, "NNodesByEdge", 400)
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "LcMin", spec.edge_size)
        field.setNumber(threshold, "LcMax", spec.element_size)
        field.setNumber(threshold, "DistMin", 0.0)
        field.setNumber(threshold, "DistMax", spec.edge_layer)
        field.setAsBackgroundMesh(threshold)
        low = gmsh.option.getNumber("Mesh.CharacteristicLengthMin")
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", min(low, spec.edge_size))
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay: well-shaped triangles
    gmsh.model.mesh.generate(2)
    if spec.order == 2:
        gmsh.model.mesh.setOrder(2)


_gmsh_ready = False


def initialize_gmsh() -> None:
    """Initialise gmsh once per process (gmsh 4.8 has no ``isInitialized``), and give Ctrl-C back to
    Python: gmsh's import sets SIGINT to the default action (restored only by its finalize), which ends
    the process at once, without the line an interrupted run prints (solver.cli.interrupts)."""
    global _gmsh_ready
    if not _gmsh_ready:
        gmsh.initialize(readConfigFiles=False)
        atexit.register(gmsh.finalize)
        _gmsh_ready = True
    gmsh.option.setNumber("General.Terminal", 0)
    if gmsh.oldsig is not None and signal.getsignal(signal.SIGINT) is signal.SIG_DFL:
        try:
            signal.signal(signal.SIGINT, gmsh.oldsig)
        except ValueError:  # not the main thread: signals are the main thread's
            pass


def film_mesh(spec: FilmMeshSpec, comm: MPI.Comm):
    """Generate the film mesh on ``comm``; returns ``(mesh, cell_tags, facet_tags)``.

    gmsh runs on rank 0 only; the mesh is distributed over ``comm`` by dolfinx.
    """
    rank = 0
    if comm.rank == rank:
        initialize_gmsh()
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


__all__ = [
    "TAGS",
    "AxialGroove",
    "CircumferentialGroove",
    "FilmMeshSpec",
    "Supply",
    "SupplyHole",
    "film_mesh",
]
