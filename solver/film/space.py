"""The film's discretisation, shared by every film kind: the mesh, the pressure space, the film's UFL
geometry and constants, the prescribed dofs and the midpoint-rule operator.

``FilmSpace`` holds what every cavitation law and bushing reads; it makes no choice between them (the
factory, solver.film.factory, does): a deformable space has a deformation Function W in its film
thickness, a rigid one has none. The reference pressure p_ref is a ``fem.Constant`` of the forms
(``p_ref``), so that a new viscosity changes a value, not the compiled forms (``set_scales``).
"""

from __future__ import annotations

import functools

from petsc4py import PETSc

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from solver.film import reynolds
from solver.film.functionals import compile_form
from solver.film.mesh import TAGS, FilmMeshSpec, film_mesh
from solver.film.scaling import FilmScales
from solver.film.spec import FilmSpec
from solver.film.types import default_mesh_size


class FilmSpace:
    """Mesh, space, geometry and prescribed dofs of one film (module docstring).

    Args:
        spec: the film's specification.
        comm: the communicator of the mesh.
        deformable: the bushing deforms (the film thickness has a deformation W).
    """

    def __init__(self, spec: FilmSpec, comm, *, deformable: bool):
        bearing = self.bearing = spec.bearing
        self.spec = spec
        self.piezo = spec.piezoviscosity
        self.roughness, self.contact = spec.roughness, spec.contact
        self.scales = FilmScales(
            radius=bearing.radius,
            clearance=bearing.clearance,
            viscosity=bearing.viscosity,
            omega_ref=spec.omega_ref,
        )
        self.sigma = spec.sigma
        R = bearing.radius
        relief = spec.edge_relief
        #: the bore's edge relief H_r(z / R, mod) (solver.film.relief), or None: a cylindrical bore
        self.relief = (
            None
            if relief is None or relief.depth == 0.0
            else functools.partial(
                relief.thickness, radius=R, clearance=bearing.clearance, width=bearing.width
            )
        )
        # aligned surfaces, edges at the same pressure, a supply on the mid-plane: the film is
        # symmetric about the mid-plane, so only its half z >= 0 is solved (half the unknowns) and
        # every integral over the film is doubled (solver.film.mesh)
        mesh_size = spec.mesh_size if spec.mesh_size is not None else default_mesh_size(bearing.width, R)
        edge_size = spec.mesh_edge_size
        self.mesh_spec = FilmMeshSpec(
            width=bearing.width / R,
            element_size=mesh_size,
            supply=bearing.supply,
            half=spec.half,
            edge_size=None if edge_size is None else min(edge_size, mesh_size),
        )
        self.mesh, self.cell_tags, self.facet_tags = film_mesh(self.mesh_spec, comm)
        self.comm = self.mesh.comm
        self.V = fem.FunctionSpace(self.mesh, ("Lagrange", spec.degree))
        self.P = fem.Function(self.V, name="pressure")
        # the true pressure / p_ref: the reduced pressure mapped node by node (solver.film.viscosity)
        self.pressure = fem.Function(self.V, name="true_pressure") if self.piezo is not None else self.P
        self.W = fem.Function(self.V, name="deformation") if deformable else None  # w / c
        # the deformation's rate by BDF2 from the committed states (solver.film.history)
        self.W_previous = fem.Function(self.V) if deformable else None
        self.inverse_step = fem.Constant(self.mesh, PETSc.ScalarType(0.0))
        #: p_ref [Pa] in the forms (the asperity pressure / p_ref, the piezoviscous ratio)
        self.p_ref = fem.Constant(self.mesh, PETSc.ScalarType(self.scales.pressure))
        self.params = reynolds.FilmParameters(self.mesh)
        self.params.set(S=self.sigma / bearing.clearance if self.sigma > 0 else 1.0)
        # the flow floor of the elastic film: a quarter of the roughness (h/sigma < 0.25 is asperity
        # contact; the flow factors are held below 0.5), or 1e-3 c on smooth surfaces
        self.flow_floor = 0.25 * self.sigma / bearing.clearance if self.sigma > 0 else 1e-3
        self.geometry = reynolds.FilmGeometry(
            self.mesh,
            self.params,
            deformation=self.W,
            previous_deformation=self.W_previous,
            inverse_step=self.inverse_step,
            flow_floor=self.flow_floor,
            relief=self.relief,
        )
        n_owned_cells = self.mesh.topology.index_map(2).size_local
        self.owned_cells = np.arange(n_owned_cells, dtype=np.int32)
        cell_nodes = self.mesh.geometry.dofmap.array.reshape(-1, 3)[:n_owned_cells]
        x = self.mesh.geometry.x[cell_nodes]
        angle = np.arctan2(x[..., 1], x[..., 0])
        self.vertex_cos, self.vertex_sin = np.cos(angle), np.sin(angle)
        # the same at the geometry's nodes, and each cell's three nodes (contiguous columns): contact cells
        node_angle = np.arctan2(self.mesh.geometry.x[:, 1], self.mesh.geometry.x[:, 0])
        self.node_cos, self.node_sin = np.cos(node_angle), np.sin(node_angle)
        self.cell_nodes = [np.ascontiguousarray(cell_nodes[:, k]) for k in range(3)]
        #: the relief at each cell's vertices (0 without): H_r is convex and grows with |z|, so its least
        #: value on a cell (of the half film, or not straddling the mid-plane) is at a vertex
        self.vertex_relief = self.relief_at(x[..., 2])
        spread = np.ptp(np.unwrap(angle, axis=1), axis=1)
        self.cell_extent = float(np.max(spread, initial=0.0))  # rad, the largest angular extent of a cell
        self.dofs = self.V.dofmap.index_map.size_global * self.V.dofmap.index_map_bs
        self.owned_coords = self.V.tabulate_dof_coordinates()[: self.V.dofmap.index_map.size_local].copy()
        self.n = len(self.owned_coords)
        self.dof_relief = self.relief_at(self.owned_coords[:, 2])  # at the owned dofs
        self.bcs = self._boundary_conditions()
        #: serial P1: the operator from precomputed tensors (solver.film.tensors), set by the film's forms
        self.serial_p1 = self.comm.size == 1 and spec.degree == 1
        # nodal areas of the film (integral of each basis function): the cavitated area
        self.nodal_areas = fem_petsc.assemble_vector(
            compile_form(ufl.TestFunction(self.V) * ufl.dx(domain=self.mesh))
        )
        self.nodal_areas.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)

    def relief_at(self, z: np.ndarray) -> np.ndarray:
        """The relief H_r at the axial coordinates z / R (zeros without relief)."""
        return np.zeros_like(z) if self.relief is None else self.relief(z)

    # -- pressures --------------------------------------------------------------------------------
    def reduced(self, p: float) -> float:
        """The film's unknown for a pressure p [Pa]: p, or the reduced pressure with piezoviscosity."""
        return p if self.piezo is None else float(self.piezo.reduced(p))

    def true_pressure(self, Q: np.ndarray) -> np.ndarray:
        """p / p_ref from the reduced pressure Q / p_ref, node by node (solver.film.viscosity)."""
        return self.piezo.pressure(Q * self.scales.pressure) / self.scales.pressure

    def pressure_map(self):
        """With piezoviscosity, ``Q -> (p, dp/dQ)`` (the true pressure that loads a bushing); else None."""
        if self.piezo is None:
            return None

        def pressure_map(Q: np.ndarray):
            p = self.true_pressure(Q)
            return p, self.piezo.ratio(p * self.scales.pressure)

        return pressure_map

    @property
    def q_limit(self) -> float | None:
        """The reduced pressure's bound / p_ref (piezoviscosity), None without."""
        return None if self.piezo is None else self.piezo.q_limit / self.scales.pressure

    @property
    def cavitation_bound(self) -> float:
        """P_cav: the film's unknown at the cavitation pressure / p_ref."""
        return self.reduced(self.bearing.cavitation_pressure) / self.scales.pressure

    # -- prescribed dofs ----------------------------------------------------------------------------
    def prescribed(self) -> dict[str, tuple[np.ndarray, float]]:
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
                self.reduced(self.bearing.supply_pressure) / self.scales.pressure,
            )
        return out

    def _boundary_conditions(self) -> list:
        bcs = []
        for dofs, value in self.prescribed().values():
            function = fem.Function(self.V)
            function.x.array[:] = value
            bcs.append(fem.dirichletbc(function, dofs))
        return bcs

    def lower_bounds(self) -> np.ndarray:
        """The pressure's lower bound per dof (local, ghosts included): P_cav, or the Dirichlet value
        where it is lower (the bound must not bind a prescribed dof)."""
        lower = np.full(len(self.P.x.array), self.cavitation_bound)
        for bc in self.bcs:
            dofs = bc.dof_indices()[0]
            lower[dofs] = np.minimum(lower[dofs], bc.g.x.array[dofs])
        return lower

    # -- a new viscosity ------------------------------------------------------------------------------
    def set_scales(self, bearing) -> None:
        """A new bearing (its viscosity) for the same film: the scales, p_ref in the forms and the
        prescribed values (/ p_ref) of the boundary conditions follow; the forms stay compiled."""
        self.bearing = bearing
        self.scales = FilmScales(
            radius=bearing.radius,
            clearance=bearing.clearance,
            viscosity=bearing.viscosity,
            omega_ref=self.scales.omega_ref,
        )
        self.p_ref.value = self.scales.pressure
        for bc, (dofs, value) in zip(self.bcs, self.prescribed().values()):
            bc.g.x.array[:] = value

    def close(self) -> None:
        self.nodal_areas.destroy()
