"""The film mesh: named groups, area and edges against the exact cylinder."""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem

from solver.errors import InputError
from solver.film.mesh import TAGS, AxialGroove, CircumferentialGroove, FilmMeshSpec, SupplyHole, film_mesh


def _integrate(mesh, expr, measure):
    return mesh.comm.allreduce(fem.assemble_scalar(fem.form(expr * measure)), op=MPI.SUM)


@pytest.mark.mpi
def test_mesh_area_edges_and_hole(comm):
    """Area of the faceted cylinder vs 2 pi B/R (chord error ~h^2/12 -> tolerance 1e-3 at h = 0.05);
    edge length vs 2 pi on each edge (same error); the supply hole's area vs pi d^2/4 (the rim is
    polygonal and the disc curved: 3 %)."""
    spec = FilmMeshSpec(width=1.5, element_size=0.05, supply=SupplyHole(angle=2.0, z=0.1, diameter=0.4))
    mesh, cell_tags, facet_tags = film_mesh(spec, comm)
    one = fem.Constant(mesh, 1.0)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    area = _integrate(mesh, one, dx)
    assert area == pytest.approx(2 * math.pi * 1.5, rel=1e-3)
    for name in ("edge_minus", "edge_plus"):
        assert _integrate(mesh, one, ds(TAGS[name])) == pytest.approx(2 * math.pi, rel=1e-3)
    hole_area = _integrate(mesh, one, dx(TAGS["supply"]))
    assert hole_area == pytest.approx(math.pi * 0.2**2, rel=0.03)
    # the hole sits where it was asked for
    x = ufl.SpatialCoordinate(mesh)
    centre = np.array([_integrate(mesh, x[i], dx(TAGS["supply"])) for i in range(3)]) / hole_area
    assert math.atan2(centre[1], centre[0]) == pytest.approx(2.0, abs=0.01)
    assert centre[2] == pytest.approx(0.1, abs=0.01)


@pytest.mark.mpi
def test_half_mesh_covers_z_above_the_mid_plane(comm):
    """The half mesh: area pi B/R (half the cylinder, same chord error as above: 1e-3), the outer edge
    and the mid-plane circle each 2 pi long, no edge at z = -B/2, every node at z >= 0, and a hole on
    the mid-plane cut in half (half the disc area, 3 % for its polygonal rim)."""
    spec = FilmMeshSpec(width=1.5, element_size=0.05, supply=SupplyHole(angle=2.0, diameter=0.4), half=True)
    mesh, cell_tags, facet_tags = film_mesh(spec, comm)
    one = fem.Constant(mesh, 1.0)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    assert spec.multiplicity == 2
    assert _integrate(mesh, one, dx) == pytest.approx(math.pi * 1.5, rel=1e-3)
    for name in ("edge_plus", "mid_plane"):
        assert _integrate(mesh, one, ds(TAGS[name])) == pytest.approx(2 * math.pi, rel=1e-3)
    assert _integrate(mesh, one, ds(TAGS["edge_minus"])) == 0.0
    assert comm.allreduce(float(mesh.geometry.x[:, 2].min(initial=0.0)), op=MPI.MIN) >= -1e-12
    assert _integrate(mesh, one, dx(TAGS["supply"])) == pytest.approx(0.5 * math.pi * 0.2**2, rel=0.03)


@pytest.mark.mpi
@pytest.mark.parametrize("degrees", [150.0, 180.0, -167.0, 200.0])
@pytest.mark.parametrize("half", [False, True])
def test_hole_at_any_angle_is_cut(comm, degrees, half):
    """A hole at 150-200 deg (where OCC's loose bounding boxes of the curved pieces hid the hole's
    piece: 'gmsh did not cut the supply'): the supply cells are the hole, area pi d^2/4 (half of it on a
    half mesh; 3 % for the polygonal rim), centred at its angle (0.01 rad)."""
    angle = math.radians(degrees)
    spec = FilmMeshSpec(width=0.8, element_size=0.1, supply=SupplyHole(angle=angle, diameter=0.2), half=half)
    mesh, cell_tags, _ = film_mesh(spec, comm)
    one = fem.Constant(mesh, 1.0)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    hole_area = _integrate(mesh, one, dx(TAGS["supply"]))
    assert hole_area == pytest.approx((0.5 if half else 1.0) * math.pi * 0.1**2, rel=0.03)
    x = ufl.SpatialCoordinate(mesh)
    centre = [_integrate(mesh, x[i], dx(TAGS["supply"])) / hole_area for i in range(2)]
    assert abs(math.remainder(math.atan2(centre[1], centre[0]) - angle, 2 * math.pi)) < 0.01


GROOVES = [
    AxialGroove(angle=2.0, arc=math.radians(40), length=0.8),
    AxialGroove(angle=-1.0, arc=math.radians(350), length=0.3),  # nearly all round: a thin land at the seam
    CircumferentialGroove(width=0.3),
]


@pytest.mark.mpi
@pytest.mark.parametrize("half", [False, True])
@pytest.mark.parametrize("groove", GROOVES, ids=["axial-40deg", "axial-350deg", "circumferential"])
def test_groove_cells_are_the_groove(comm, groove, half):
    """The cells tagged ``supply`` are the groove: their area is its area on the cylinder (arc x length,
    or 2 pi x width; halved on a half mesh) to the chord error of the faceted surface, 1 - sin(D/2)/(D/2)
    ~ D^2/24 for an edge spanning the angle D <= sqrt(2) h, bounded by h^2/12 = 2.1e-4 at h = 0.05 (the
    whole film's area has the same error); and the element edges follow its boundary: every vertex of a
    supply cell lies inside the groove (1e-9), so the two areas can only agree if the cells fill it."""
    h = 0.05
    spec = FilmMeshSpec(width=1.5, element_size=h, supply=groove, half=half)
    mesh, cell_tags, _ = film_mesh(spec, comm)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    area = _integrate(mesh, fem.Constant(mesh, 1.0), dx(TAGS["supply"]))
    assert area == pytest.approx(groove.area / spec.multiplicity, rel=h**2 / 12)
    assert _integrate(mesh, fem.Constant(mesh, 1.0), dx) == pytest.approx(
        2 * math.pi * 1.5 / spec.multiplicity, rel=h**2 / 12
    )
    cells = cell_tags.find(TAGS["supply"])
    x = mesh.geometry.x[mesh.geometry.dofmap.array.reshape(-1, 3)[cells]].reshape(-1, 3)
    if isinstance(groove, AxialGroove):
        offset = np.angle(np.exp(1j * (np.arctan2(x[:, 1], x[:, 0]) - groove.angle)))  # in (-pi, pi]
        assert np.all(np.abs(offset) <= groove.arc / 2 + 1e-9)
        assert np.all(np.abs(x[:, 2]) <= groove.length / 2 + 1e-9)
    else:
        assert np.all(np.abs(x[:, 2]) <= groove.width / 2 + 1e-9)
    if half:
        assert x[:, 2].min(initial=0.0) >= -1e-12


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(width=0.0),
        dict(width=1.0, element_size=0.0),
        dict(width=1.0, supply=SupplyHole(angle=0.0, diameter=2.0)),
        dict(width=1.0, supply=SupplyHole(angle=0.0, z=0.1, diameter=0.2), half=True),
        dict(width=1.0, supply=AxialGroove(angle=0.0, arc=2 * math.pi, length=0.5)),
        dict(width=1.0, supply=AxialGroove(angle=0.0, arc=0.0, length=0.5)),
        dict(width=1.0, supply=AxialGroove(angle=0.0, arc=1.0, length=1.0)),
        dict(width=1.0, supply=AxialGroove(angle=math.nan, arc=1.0, length=0.5)),
        dict(width=1.0, supply=CircumferentialGroove(width=1.0)),
        dict(width=1.0, supply=CircumferentialGroove(width=-0.1), half=True),
        dict(width=1.0, element_size=0.1, edge_size=0.2),
        dict(width=1.0, element_size=0.1, edge_size=0.0),
        dict(width=1.0, element_size=0.1, edge_size=0.05, edge_layer=0.0),
    ],
)
def test_bad_mesh_spec_is_input_error(kwargs):
    with pytest.raises(InputError, match="out of range") as caught:
        FilmMeshSpec(**kwargs)
    assert "\n" not in str(caught.value)


@pytest.mark.mpi
@pytest.mark.parametrize("half", [False, True])
def test_a_mesh_graded_toward_the_edges_has_the_asked_sizes(comm, half):
    """``edge_size`` 0.025 at the edges, ``element_size`` 0.1 beyond ``edge_layer`` 0.3: the cells touching
    an edge have edges of about 0.025 (their mean within 25 % of it: gmsh's sizes are targets), the
    cells farther than 0.3 from both edges about 0.1 (mean within 25 %), the area is still the cylinder's
    (the chord error at the coarsest size, 1e-3 x (0.1/0.05)^2); a uniform mesh of the same element size
    has fewer cells; a mesh with a hole made after the graded one is the same as made before it."""
    width = 2.0
    holed = FilmMeshSpec(width=width, element_size=0.1, supply=SupplyHole(angle=1.0, diameter=0.3), half=half)
    before, _, _ = film_mesh(holed, comm)  # (a hole's rim sizes extend from its boundary)
    spec = FilmMeshSpec(width=width, element_size=0.1, edge_size=0.025, edge_layer=0.3, half=half)
    mesh, _, _ = film_mesh(spec, comm)
    uniform, _, _ = film_mesh(FilmMeshSpec(width=width, element_size=0.1, half=half), comm)
    one = fem.Constant(mesh, 1.0)
    area = _integrate(mesh, one, ufl.dx(domain=mesh))
    assert area == pytest.approx(2 * math.pi * width * (0.5 if half else 1.0), rel=4e-3)
    x = mesh.geometry.x
    cells = mesh.geometry.dofmap.array.reshape(-1, 3)
    points = x[cells]  # (cell, 3 nodes, xyz)
    edge_lengths = np.linalg.norm(points - np.roll(points, 1, axis=1), axis=2).mean(axis=1)
    distance = width / 2 - np.abs(points[:, :, 2]).max(axis=1)  # of the cell's nearest node to an edge
    far = width / 2 - np.abs(points[:, :, 2]).max(axis=1) > 0.35
    near = distance < 1e-9
    sizes = [
        comm.allreduce(float(edge_lengths[m].sum()), op=MPI.SUM) / comm.allreduce(int(m.sum()), op=MPI.SUM)
        for m in (near, far)
    ]
    assert sizes[0] == pytest.approx(0.025, rel=0.25), sizes
    assert sizes[1] == pytest.approx(0.1, rel=0.25), sizes
    count = comm.allreduce(mesh.topology.index_map(2).size_local, op=MPI.SUM)
    assert count > comm.allreduce(uniform.topology.index_map(2).size_local, op=MPI.SUM)
    # gmsh's options outlive a mesh: a mesh made after the graded one is the one made before it (the
    # hole's rim: its sizes extend from the boundary, which the graded mesh turns off for itself only)
    after, _, _ = film_mesh(holed, comm)

    def nodes(m):  # every rank's nodes, in one order (the distribution's local order may differ)
        return np.unique(np.round(np.concatenate(comm.allgather(m.geometry.x)), 12), axis=0)

    assert np.array_equal(nodes(after), nodes(before))
