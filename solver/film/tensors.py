"""The Reynolds operator and source from tensors precomputed once per mesh (P1, midpoint rule, serial).

With P1 elements on flat triangles and the midpoint rule (the film operator's quadrature, degree
2k - 1), the weak form ``integral(D grad P . grad v + f v)`` with ``D = k_theta t t + k_z e_z e_z``
(solver.film.reynolds) gives, on a cell K with centroid c, area |K| and basis gradients G::

    A_K = |K| (k_theta(c) (G t(c))(G t(c))^T + k_z(c) (G e_z)(G e_z)^T),   l_K = |K| f(c) / 3

So the matrix values are two fixed sparse matrices (values x cells) times the per-cell coefficients,
and the source one more: ``values = T_theta k_theta + T_z k_z``, ``l = T_f f``. The coefficients
are the same UFL expressions as the form's (``reynolds_coefficients``), evaluated at the cell
midpoints by a compiled ``fem.Expression``: the UFL form stays the definition, and a test checks the
tensors against dolfinx's assembly of it to 1e-12. One coefficient evaluation and three sparse
products replace two assemblies (0.8 ms + 0.4 ms at 1620 unknowns). Dirichlet rows and columns
are treated as dolfinx does (zeroed, 1 on the diagonal, the source lifted).

Serial only (the batch runs one case per rank); on a distributed mesh the film assembles with dolfinx.
"""

from __future__ import annotations

from petsc4py import PETSc

import basix
import numpy as np
import scipy.sparse
import ufl
from dolfinx import fem

#: the midpoint of the reference triangle: the one point of the degree-1 rule (weight 1/2)
MIDPOINT = np.array([[1.0 / 3.0, 1.0 / 3.0]])


def _cell_geometry(V: fem.FunctionSpace, who: str):
    """Per owned cell of a serial P1 mesh of flat triangles: (dofs (cell, 3), vertices X (cell, vertex,
    xyz), Jacobian J (cell, xyz, 2), basis gradients G (cell, xyz, basis) by the pseudo-inverse of the
    manifold's Jacobian, |det J|)."""
    mesh = V.mesh
    if mesh.comm.size != 1 or V.ufl_element().degree() != 1:
        raise ValueError(f"{who}: P1 on a serial mesh only")
    if mesh.geometry.dofmap.links(0).size != 3:
        raise ValueError(f"{who}: flat (affine) triangles only")
    n_cells = mesh.topology.index_map(2).size_local
    dofs = V.dofmap.list.array.reshape(-1, 3)[:n_cells]
    X = mesh.geometry.x[mesh.geometry.dofmap.array.reshape(-1, 3)[:n_cells]]
    J = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]], axis=2)
    JtJ = np.einsum("cki,ckj->cij", J, J)
    reference_gradients = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])  # (basis, 2)
    G = np.einsum("cki,cij,bj->ckb", J, np.linalg.inv(JtJ), reference_gradients)
    return dofs, X, J, G, np.sqrt(np.linalg.det(JtJ))


class MidpointOperator:
    """Fills the PETSc matrix and source vector of the film for the current coefficients.

    Args:
        V: the P1 pressure space (serial mesh).
        A: the film's PETSc matrix (its sparsity pattern is used and kept).
        coefficients: UFL expressions (k_theta, k_z, f) of the residual (reynolds_coefficients).
        bcs: the Dirichlet conditions of the film.
        integrals: UFL integrands independent of P, integrated by the same midpoint rule in the same
            evaluation (``self.integrals`` after each ``assemble``): the Couette friction torques.
        fast: ``fast(operator)`` -> a callable that evaluates ``expression`` in numpy
            (RigidMidpointCoefficients), or None: the compiled expression.
    """

    def __init__(self, V: fem.FunctionSpace, A: PETSc.Mat, coefficients, bcs: list, integrals=(), fast=None):
        dofs, X, J, G, det = _cell_geometry(V, "MidpointOperator")
        n_cells = len(dofs)
        cells = np.arange(n_cells, dtype=np.int32)
        weight = 0.5 * det  # |K|: reference weight 1/2 x |det J|
        centroid = X.mean(axis=1)
        self.centroid = centroid
        r = np.hypot(centroid[:, 0], centroid[:, 1])
        tangent = np.stack([-centroid[:, 1] / r, centroid[:, 0] / r, np.zeros(n_cells)], axis=1)
        g_theta = np.einsum("ckb,ck->cb", G, tangent)
        g_z = G[:, 2, :]
        local_theta = weight[:, None, None] * g_theta[:, :, None] * g_theta[:, None, :]
        local_z = weight[:, None, None] * g_z[:, :, None] * g_z[:, None, :]
        # the matrix's CSR layout: the position of every (row, column) of every cell
        self.indptr, self.indices, _ = A.getValuesCSR()
        nnz = len(self.indices)
        rows = np.repeat(dofs, 3, axis=1).ravel()  # (cell, i, j) flattened with j fastest
        cols = np.tile(dofs, (1, 3)).ravel()
        position = np.empty(len(rows), dtype=np.int64)
        for k, (row, col) in enumerate(zip(rows, cols)):
            start, end = self.indptr[row], self.indptr[row + 1]
            position[k] = start + np.searchsorted(self.indices[start:end], col)
        if not np.array_equal(self.indices[position], cols):
            raise RuntimeError("MidpointOperator: a cell's entry is not in the matrix's sparsity pattern")
        cell_of = np.repeat(cells, 9)
        self.T_theta = scipy.sparse.csr_matrix(
            (local_theta.ravel(), (position, cell_of)), shape=(nnz, n_cells)
        )
        self.T_z = scipy.sparse.csr_matrix((local_z.ravel(), (position, cell_of)), shape=(nnz, n_cells))
        n_dofs = V.dofmap.index_map.size_local
        self.T_f = scipy.sparse.csr_matrix(
            (np.repeat(weight / 3.0, 3), (dofs.ravel(), np.repeat(cells, 3))), shape=(n_dofs, n_cells)
        )
        self.integrands = list(
            integrals
        )  # (the mass-conserving film evaluates them with its own coefficients)
        #: what ``evaluate`` needs at the midpoints (UFL): k_theta, k_z, f, then the integrands
        self.coefficients = list(coefficients) + self.integrands
        self.expression = fem.Expression(ufl.as_vector(self.coefficients), MIDPOINT)
        self.weight = weight  # |K|: the midpoint rule's weight of each cell
        self.nodal_areas = self.T_f @ np.ones(n_cells)  # lumped: a third of each cell's area to its vertices
        # per cell: its dofs, the local matrices per unit coefficient and the basis functions'
        # circumferential slopes (the elastic film's Jacobian, solver.film.ehd, differentiates A P + l
        # with respect to the coefficients)
        self.dofs, self.local_theta, self.local_z, self.g_theta = dofs, local_theta, local_z, g_theta
        self.positions = position.reshape(-1, 3, 3)  # (cell, i, j) -> index in the CSR layout
        self.centroid_angle = np.arctan2(centroid[:, 1], centroid[:, 0])
        self.integrals = np.zeros(len(integrals))
        self.cells = cells
        # Dirichlet dofs: their rows and columns are zeroed and their diagonal set to 1 (dolfinx's way)
        bc_dofs = (
            np.unique(np.concatenate([bc.dof_indices()[0] for bc in bcs])) if bcs else np.zeros(0, np.int32)
        )
        row_of = np.repeat(np.arange(n_dofs), np.diff(self.indptr))
        is_bc = np.zeros(n_dofs, dtype=bool)
        is_bc[bc_dofs] = True
        self.constrained = is_bc[row_of] | is_bc[self.indices]
        self.bc_diagonal = np.flatnonzero(is_bc[row_of] & (row_of == self.indices))
        self.bc_dofs = bc_dofs
        self.bc_values = np.zeros(n_dofs)
        for bc in bcs:
            index = bc.dof_indices()[0]
            self.bc_values[index] = bc.g.x.array[index]
        self.lift = bool(np.any(self.bc_values[bc_dofs] != 0.0))
        #: evaluates what ``expression`` does in numpy when set (RigidMidpointCoefficients)
        self.fast = None if fast is None else fast(self)

    def set_bc_values(self, bcs: list) -> None:
        """The Dirichlet values anew (their dofs unchanged): a new p_ref changes a supply's P."""
        for bc in bcs:
            index = bc.dof_indices()[0]
            self.bc_values[index] = bc.g.x.array[index]
        self.lift = bool(np.any(self.bc_values[self.bc_dofs] != 0.0))

    def assemble(self, A: PETSc.Mat, rhs: PETSc.Vec) -> None:
        """A and the source (lifted, with -g on the Dirichlet rows) for the current constants."""
        self.evaluate()
        A.setValuesCSR(self.indptr, self.indices, self.values)
        A.assemble()
        rhs.setArray(self.source)

    def evaluate(self, k: np.ndarray | None = None) -> None:
        """``values`` (A's, in its CSR layout) and ``source`` for the current constants, without PETSc
        (the elastic film, solver.film.ehd, works on them directly). ``k``: the ``coefficients`` at the
        midpoints when the caller has evaluated them (the elastic film, in one kernel with its own)."""
        # (cell, 3 + integrals): k_theta, k_z, f, ... at the midpoints
        if k is None:
            k = self.expression.eval(self.cells) if self.fast is None else self.fast()
        self.integrals = self.weight @ k[:, 3:]
        values = self.T_theta @ k[:, 0] + self.T_z @ k[:, 1]
        source = self.T_f @ k[:, 2]
        if self.lift:  # l += A[:, bc] g, with A before the constraints
            full = scipy.sparse.csr_matrix((values, self.indices, self.indptr), shape=(len(source),) * 2)
            source += full[:, self.bc_dofs] @ self.bc_values[self.bc_dofs]
        values[self.constrained] = 0.0
        values[self.bc_diagonal] = 1.0
        source[self.bc_dofs] = -self.bc_values[self.bc_dofs]
        self.values, self.source = values, source


class PressureTorque:
    """The pressure part of the viscous torques on a rigid film from tensors precomputed once per mesh.

    The integrand (solver.film.reynolds.shear_traction_integrands) is ``-Phi_fp(H/S) 6 H dP/dtheta``,
    linear in P, integrated by the degree-2 rule of FFCx (3 points per cell; the forms' "moment"
    measure, which keeps the film's moment balance). With P1 on flat triangles ``dP/dtheta`` at a point
    is ``(G t(x_q)) . P_K``, so the integral is ``c . (B P)`` with the fixed sparse matrix
    ``B[(K, q), dof] = w_q |K| (G_K t(x_q))_dof`` and ``c = -6 Phi_fp(H_q/S) H_q`` at the points, where
    ``H_q = 1 - eps_x cos(theta_q) - eps_y sin(theta_q)`` with cos and sin taken as x/r and y/r at the
    point, as the form does. The roughness law is evaluated with numpy (``mod=np``: the same
    expression as the form's); a test checks the result against dolfinx's evaluation of the UFL
    integrand to 1e-12. An elastic bushing adds its deformation W (P1, interpolated at the points by
    the fixed matrix ``interpolation``) to H, and the flow sees H floored as the forms do
    (solver.film.reynolds.FilmGeometry): ``-Phi_fp(H/S) 6 H_flow dP/dtheta``.

    Args:
        V: the P1 pressure space (serial mesh).
        roughness: the Patir-Cheng factors (solver.film.flow_factors.PatirCheng), or None (smooth:
            Phi_fp = 1).
        S: sigma / c.
        flow_floor: the elastic film's floor of H in the flow (FilmGeometry's ``flow_floor``); None for
            a rigid bushing.
        relief: the bore's edge relief, a function of z / R (FilmSpace.relief), or None.
    """

    DEGREE = 2

    def __init__(
        self, V: fem.FunctionSpace, roughness, S: float, flow_floor: float | None = None, relief=None
    ):
        points, weights = basix.make_quadrature(basix.CellType.triangle, self.DEGREE)
        dofs, X, J, G, area = _cell_geometry(V, "PressureTorque")
        n_cells = len(dofs)
        # the points in space: x_q = X_0 + J xi_q
        x = X[:, None, 0, :] + np.einsum("cki,qi->cqk", J, points)  # (cell, q, xyz)
        r = np.hypot(x[..., 0], x[..., 1])
        self.cos, self.sin = (x[..., 0] / r).ravel(), (x[..., 1] / r).ravel()
        self.relief = None if relief is None else relief(x[..., 2].ravel())  # H_r at the points
        tangent = np.stack([-x[..., 1] / r, x[..., 0] / r], axis=-1)  # (cell, q, 2): the z part is 0
        slopes = np.einsum("cqk,ckb->cqb", tangent, G[:, :2, :])  # (cell, q, basis)
        values = (weights[None, :, None] * area[:, None, None] * slopes).ravel()
        n_points = n_cells * len(weights)
        rows = np.repeat(np.arange(n_points), 3)
        cols = np.repeat(dofs, len(weights), axis=0).ravel()
        n_dofs = V.dofmap.index_map.size_local
        self.B = scipy.sparse.csr_matrix((values, (rows, cols)), shape=(n_points, n_dofs))
        basis = np.column_stack(
            [1.0 - points[:, 0] - points[:, 1], points[:, 0], points[:, 1]]
        )  # (q, vertex)
        self.interpolation = scipy.sparse.csr_matrix(
            (np.tile(basis.ravel(), n_cells), (rows, cols)), shape=(n_points, n_dofs)
        )  # P1 values at the points
        self.roughness, self.S, self.flow_floor = roughness, S, flow_floor

    def coefficient(self, eps_x: float, eps_y: float, W: np.ndarray | None = None) -> np.ndarray:
        """c = -6 Phi_fp(H/S) H_flow at the points (H_flow = H on a rigid bushing)."""
        H = 1.0 - eps_x * self.cos - eps_y * self.sin
        if self.relief is not None:
            H = H + self.relief
        H_flow = H
        if W is not None:
            H = H + self.interpolation @ W
            h0 = self.flow_floor
            H_flow = np.where(H < h0, h0 * np.exp(np.minimum(H, h0) / h0 - 1.0), H)
        if self.roughness is None:
            return -6.0 * H_flow
        return -6.0 * self.roughness.pressure_shear_factor(H / self.S, mod=np) * H_flow

    def __call__(self, P: np.ndarray, eps_x: float, eps_y: float, W: np.ndarray | None = None) -> float:
        """The integral of ``-Phi_fp 6 H_flow dP/dtheta`` over the mesh for the nodal values P (and the
        deformation W of an elastic bushing)."""
        return float(self.coefficient(eps_x, eps_y, W) @ (self.B @ P))


class RigidMidpointCoefficients:
    """The operator's coefficients (k_theta, k_z, f) and the Couette torque integrands of a rigid film at
    the cell midpoints, in numpy: what ``MidpointOperator`` evaluates with a compiled ``fem.Expression``
    of the UFL forms (solver.film.reynolds.reynolds_coefficients and shear_traction_integrands), in a
    third of the time (the roughness laws are the same expressions with ``mod=np``; a test checks the
    two to 1e-12).

    At a midpoint with cos and sin taken as x/r and y/r (as the forms do)::

        H = 1 - eps_x cos - eps_y sin,  dH/dtheta = eps_x sin - eps_y cos,  dH/dT = -deps_x cos - deps_y sin
        k_theta = H^3 phi_x,  k_z = H^3 phi_y,
        f = U_m phi_c dH/dtheta + phi_c dH/dT + U_d (dphi_s/dHs) dH/dtheta
        couette_journal = 2 U_d / H (Phi_f - Phi_fs),  couette_bushing = -2 U_d / H (Phi_f + Phi_fs)

    (smooth film: phi_x = phi_y = phi_c = Phi_f = 1, phi_s = Phi_fs = 0).

    Args:
        operator: the MidpointOperator (its cells' centroids).
        params: the film's FilmParameters (read at every call).
        roughness: PatirCheng, or None.
        integrals: the names of the operator's integrals, each "viscous_couette_journal" or
            "viscous_couette_bushing".
        relief: the bore's edge relief H_r at the midpoints (solver.film.relief), or None.
    """

    INTEGRALS = ("viscous_couette_journal", "viscous_couette_bushing")

    def __init__(self, operator: MidpointOperator, params, roughness, integrals, relief=None):
        if any(name not in self.INTEGRALS for name in integrals):
            raise ValueError(
                f"RigidMidpointCoefficients: integrals {list(integrals)} (allowed: {self.INTEGRALS})"
            )
        self.integrals = list(integrals)
        centroid = operator.centroid
        r = np.hypot(centroid[:, 0], centroid[:, 1])
        self.cos, self.sin = centroid[:, 0] / r, centroid[:, 1] / r
        self.relief = relief  # H_r at the midpoints, or None
        self.params, self.roughness = params, roughness
        self.out = np.empty((len(r), 3 + len(self.integrals)))

    def __call__(self) -> np.ndarray:
        """(cells, 3 + integrals): k_theta, k_z, f and the integrands at the midpoints."""
        p = self.params.get()
        cos, sin, rough, out = self.cos, self.sin, self.roughness, self.out
        H = 1.0 - p["eps_x"] * cos - p["eps_y"] * sin
        if self.relief is not None:
            H = H + self.relief
        dH_dtheta = p["eps_x"] * sin - p["eps_y"] * cos
        dH_dT = -p["deps_x"] * cos - p["deps_y"] * sin
        H3 = H**3
        couette = None
        if self.integrals:
            couette = 2.0 * p["U_half_diff"] / H
        if rough is None:
            out[:, 0] = H3
            out[:, 1] = H3
            out[:, 2] = p["U_mean"] * dH_dtheta + dH_dT
            Phi_f, Phi_fs = 1.0, 0.0
        else:
            Hs = H / p["S"]
            out[:, 0] = H3 * rough.pressure_flow_x(Hs)
            out[:, 1] = H3 * rough.pressure_flow_y(Hs)
            phi_c = rough.contact_factor(Hs)
            out[:, 2] = (
                phi_c * (p["U_mean"] * dH_dtheta + dH_dT)
                + p["U_half_diff"] * rough.shear_flow_slope(Hs) * dH_dtheta
            )
            if couette is not None:
                Phi_f, Phi_fs, _ = rough.shear_stress_factors(Hs)
        for k, name in enumerate(self.integrals):
            out[:, 3 + k] = (
                couette * (Phi_f - Phi_fs) if name == self.INTEGRALS[0] else -couette * (Phi_f + Phi_fs)
            )
        return out
