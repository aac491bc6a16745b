"""Compliance of the connecting-rod small-end eye with its bushing (DESIGN 7): the radial displacement
of the bore surface (the film's outer surface) per unit pressure, from 3D linear elasticity.

The model. The eye is an annular cylinder (steel, radii ``r_i = R + t`` to ``r_o``) with a bonded
bronze bushing (radii R to R + t) inside; the bore r = R is the film surface and the pin stays rigid.
Only the half width 0 <= z <= B/2 is modelled, with the symmetry plane z = 0 (``u_z = 0``), because
the film code solves the half film z >= 0 with a pressure symmetric in z. The eye is clamped
(``u = 0``) on the arc of its outer surface where it joins the rod shank,
``|theta - theta_s| <= alpha``, which with the symmetry plane excludes rigid motion. Linear
elasticity, ``div sigma(u) = 0`` with ``sigma = lambda tr(eps) I + 2 mu eps``, P2 tetrahedra on a
second-order gmsh mesh (P1 locks in the eye's bending), traction ``-p n`` on the bore (n is the
outward normal of the solid, so the pressure pushes the bore outward), all other surfaces free.

Angles are the bushing angle theta of the film code, measured from the bushing x axis toward its y
axis. ``u_r = u . (-n)`` on the bore: positive when the bore opens (the film gap grows).

Load basis. A structured grid of ``n_theta x n_z`` nodes on the bore, ``theta_j = j 2 pi / n_theta``
(periodic) and ``z_k = k (B/2) / (n_z - 1)`` (both ends included), carries the bilinear hat
functions ``hat_i(theta, z)`` (periodic in theta; node i = k n_theta + j, z-major). They sum to one,
so a uniform pressure is represented exactly. With the areas ``a_i = int hat_i dA``, the load vectors
``b_i(v) = int hat_i (-n . v) dA`` and the stiffness matrix K, the pressure ``p = sum_j p_j hat_j``
deforms the eye by ``u = K^-1 B p``. Work-consistent generalised forces and displacements::

    f_i = int p hat_i dA   ~=  a_i p_i                     [N]
    w_i = int u_r hat_i dA / a_i = (B^T u)_i / a_i         [m]
    w = G f,   G = A^-1 B^T K^-1 B A^-1,   A = diag(a)     [m/N]

G is symmetric positive definite (Maxwell-Betti at the discrete level). K is factorised once (MUMPS
Cholesky: K is symmetric positive definite) and all ``n_theta n_z`` load cases are back-substituted
in blocks. The film code passes nodal forces F at its own film nodes: ``f = T^T F`` and the
displacement at those nodes is ``w = T G T^T F`` with ``T = Compliance.interpolation(theta, z)``.

Reduction. Two bases (``Compliance.modes``). The eigen basis: the m dominant eigenpairs of G,
``G ~ Psi diag(lam) Psi^T``. The eye's bending (ovalisation) is captured by a dozen modes, but the
bushing's local compression is close to a diagonal operator (Winkler: ``u_r ~ k p``) and is not
low-rank: under the clamp, where the eye hardly moves, it is a third of the displacement, and for a
thin soft bushing nearly all of it (72 modes of a 0.5 mm layer on a rigid eye miss 77 % of the
displacement under a uniform pressure). The layer basis carries it as it is: the layer's local part,
whose image on the hats is exactly ``D = k A^-1 M A^-1`` (``Compliance.local_part``: M the hats' mass
matrix ``M_ij = int hat_i hat_j dA``, k the compression per pressure of the bushing bonded to a rigid
eye, solver.film.bushings.bonded_layer_coefficient), and the m dominant eigenpairs (by absolute value:
the remainder is indefinite) of the remainder ``G - D``, which is the eye's deformation and the
layer's departure from a local law (its edges, its spreading under loads narrower than a few
thicknesses). The film takes the local part node by node at its own nodes (w = k p) and the remainder
by its modes (solver.film.bushings.FEEye). For the reference small end the layer basis's error under
the reference loads (max norm) is 0.7 % with 48 modes and 0.3 % with 72 (eigen basis: 3.3 and 1.5 %);
for the thin layer the local part alone errs by 0.3 %. The number of modes is the smallest whose
error under the reference loads is within a tolerance (``Compliance.modes_for``;
bench/bench_compliance.py prints the errors).

Mesh. Element edge ``DEFAULT_ELEMENT_SIZE`` = 0.3 R in the eye, the bushing thickness on the bore
and in the bushing, a sixth of 0.3 R along the clamp's edges (where the stress is singular). For the
reference small end: 40k dofs, set-up about 12 s on one core, and displacements under the reference
loads within 0.5 % of those on a 217k-dof mesh. The bore elements (0.15 R) are coarser than the
default hat spacing (5 deg = 0.087 R): the hats are the coupling basis of the film, not resolved
load patterns. gmsh's 3D Delaunay is used because it is deterministic (HXT is not), so a compliance
built on several ranks uses the same mesh as one built on one.

Scaling. The elasticity problem is solved in lengths X = x / R and stresses divided by E_eye, so
the stiffness entries are O(h) instead of O(E h) ~ 1e9 N/m: for unit scaled traction the scaled
displacement U gives ``u = R U p / E_eye``, hence ``G = G_scaled / (R E_eye)`` with ``G_scaled``
built from the scaled areas and load vectors.

Cache. ``eye_compliance`` stores the result as ``<sha256 key>.npz`` (key of the geometry, the grid,
the element size, the support and ``FORMAT_VERSION``) in ``$XDG_CACHE_HOME/tribo-solver/compliance``
(default ``~/.cache/...``); rank 0 writes through a temporary file in the same directory and
``os.replace`` (atomic). A later call with the same inputs loads the file and builds nothing.

What the caller provides: an ``EyeGeometry`` (SI), the grid sizes and a communicator (the solve is
distributed over it; every rank receives the whole G). Use ``ElasticEye`` as a context manager:
PETSc destructors are collective.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import os
import tempfile
import time
import zipfile
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.sparse
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fem_petsc
from ufl.core.expr import Expr

from solver.errors import out_of_range
from solver.film.eye_mesh import DEFAULT_ELEMENT_SIZE, TAGS, EyeGeometry, eye_mesh

log = logging.getLogger(__name__)

FORMAT_VERSION = 1  # of the cache files; raise it when the discretisation or the file layout changes
DEFAULT_MODES = 72  # the eigen basis's modes before the tolerance chose them (< 2 % for the reference loads)
_BLOCK = 60  # right-hand sides per back-substitution (a dense block of dofs x 60 doubles)
_QUADRATURE_DEGREE = 6  # on the bore: the hats have kinks inside the facets


# ---------------------------------------------------------------------------------------------------
# The compliance: plain numpy data


@dataclasses.dataclass(frozen=True, eq=False)
class Compliance:
    """The bore's compliance on the hat grid (see the module docstring for the definitions).

    Attributes:
        geometry: the eye it belongs to.
        theta: (n_theta,) grid angles [rad], uniform from 0.
        z: (n_z,) grid axial positions [m], uniform on [0, B/2].
        areas: (N,) a_i = int hat_i dA [m^2], N = n_theta n_z, node i = k n_theta + j.
        matrix: (N, N) G [m/N], w = G f.
        clamped: False for a model supported at four points instead of the shank clamp (verification).
    """

    geometry: EyeGeometry
    theta: np.ndarray
    z: np.ndarray
    areas: np.ndarray
    matrix: np.ndarray
    clamped: bool = True

    @property
    def size(self) -> int:
        """Number of grid nodes N."""
        return self.theta.size * self.z.size

    def interpolation(self, theta: np.ndarray, z: np.ndarray) -> scipy.sparse.csr_matrix:
        """The hat values at bore points: T (n_points x N), ``T[p, i] = hat_i(theta_p, z_p)``.

        Nodal forces F [N] at these points make the generalised forces ``f = T^T F``; the
        displacement there is ``T w = T G f``.

        Args:
            theta: bushing angles of the points [rad], any range (periodic).
            z: axial positions of the points [m], in [0, B/2].
        """
        theta, z = np.broadcast_arrays(np.asarray(theta, dtype=float), np.asarray(z, dtype=float))
        theta, z = theta.ravel(), z.ravel()
        half_width = self.geometry.width / 2
        if z.size and not (z.min() >= -1e-9 * half_width and z.max() <= (1 + 1e-9) * half_width):
            raise ValueError(f"z must lie in [0, B/2] = [0, {half_width:g}] m ({z.min():g} .. {z.max():g})")
        n_theta, n_z = self.theta.size, self.z.size
        s = np.mod(theta, 2 * math.pi) / (2 * math.pi / n_theta)
        j0 = np.floor(s).astype(np.int64)
        s -= j0
        j0 %= n_theta
        j1 = (j0 + 1) % n_theta
        q = np.clip(z / (half_width / (n_z - 1)), 0.0, n_z - 1)
        k0 = np.minimum(np.floor(q).astype(np.int64), n_z - 2)
        q -= k0
        rows = np.repeat(np.arange(theta.size), 4)
        lower, upper = k0 * n_theta, (k0 + 1) * n_theta
        cols = np.stack([lower + j0, lower + j1, upper + j0, upper + j1], axis=1)
        vals = np.stack([(1 - s) * (1 - q), s * (1 - q), (1 - s) * q, s * q], axis=1)
        return scipy.sparse.csr_matrix((vals.ravel(), (rows, cols.ravel())), shape=(theta.size, self.size))

    def generalised_forces(
        self, pressure: Callable[[np.ndarray, np.ndarray], np.ndarray], refine: int = 8
    ) -> np.ndarray:
        """f_i = int p hat_i dA [N] for a pressure p(theta [rad], z [m]) [Pa], formed as the film code does.

        Nodal forces F = p dA at the midpoints of a ``refine`` times finer grid, then ``f = T^T F``
        (the midpoint rule on sub-cells is exact for the bilinear hats times a constant).
        """
        R, half_width = self.geometry.bore_radius, self.geometry.width / 2
        d_theta = 2 * math.pi / (self.theta.size * refine)
        dz = half_width / ((self.z.size - 1) * refine)
        theta_q, z_q = np.meshgrid(
            (np.arange(self.theta.size * refine) + 0.5) * d_theta,
            (np.arange((self.z.size - 1) * refine) + 0.5) * dz,
        )
        F = pressure(theta_q, z_q) * (R * d_theta * dz)
        return self.interpolation(theta_q, z_q).T @ F.ravel()

    def hat_mass(self) -> np.ndarray:
        """The hats' mass matrix ``M_ij = int hat_i hat_j dA`` [m^2] on the bore (a cylinder: exact, the
        tensor product of the periodic and the bounded 1D linear elements); its row sums are the areas
        of the hats on the exact cylinder (``areas`` are those on the mesh's bore, within 1.5 %)."""
        n_theta, n_z = self.theta.size, self.z.size
        h_theta = 2 * math.pi / n_theta * self.geometry.bore_radius
        identity = np.eye(n_theta)
        M_theta = 4 * identity + np.roll(identity, 1, axis=1) + np.roll(identity, -1, axis=1)
        M_z = np.diag(np.r_[2.0, np.full(n_z - 2, 4.0), 2.0]) + np.eye(n_z, k=1) + np.eye(n_z, k=-1)
        return np.kron(M_z * (self.z[1] - self.z[0]) / 6, M_theta * h_theta / 6)  # node i = k n_theta + j

    def local_part(self, coefficient: float) -> np.ndarray:
        """D = k A^-1 M A^-1 [m/N]: the image on the hats of a local law u_r = k p (``coefficient`` k
        [m/Pa]): the pressure sum_j p_j hat_j with f = A p displaces the bore by k p, whose generalised
        displacements are w_i = int hat_i k p dA / a_i (A: the row sums of ``hat_mass``)."""
        M = self.hat_mass()
        areas = M.sum(axis=1)
        return coefficient * M / np.outer(areas, areas)

    def modes(self, m: int = DEFAULT_MODES, local: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """The m dominant eigenpairs of G, or with a ``local`` coefficient k > 0 [m/Pa] of the remainder
        ``G - local_part(k)``: ``(Psi (N x m), lam (m,))``, |lam| descending, Psi orthonormal,
        ``G ~ local_part(k) + Psi diag(lam) Psi^T``."""
        if not 1 <= m <= self.size:
            raise out_of_range("number of compliance modes", m, f"[1, {self.size}]")
        cache = self.__dict__.setdefault("_eigenpairs", {})  # one decomposition per local part
        if local not in cache:
            if local == 0.0:
                lam, Psi = np.linalg.eigh(0.5 * (self.matrix + self.matrix.T))
                cache[local] = (Psi[:, ::-1], lam[::-1])
            else:
                lam, Psi = np.linalg.eigh(0.5 * (self.matrix + self.matrix.T) - self.local_part(local))
                order = np.argsort(-np.abs(lam), kind="stable")
                cache[local] = (Psi[:, order], lam[order])
        Psi, lam = cache[local]
        return Psi[:, :m], lam[:m]

    def truncation_errors(self, loads: np.ndarray, local: float = 0.0) -> np.ndarray:
        """Relative errors ``max|G f - G_m f| / max|G f|`` of the displacement with m = 0 .. N modes
        (``G_m = local_part(local) + Psi_m diag(lam_m) Psi_m^T``), (N + 1, k) for k loads (N, k)."""
        f = np.asarray(loads, dtype=float).reshape(self.size, -1)
        Psi, lam = self.modes(self.size, local)
        w = self.matrix @ f
        scale = np.abs(w).max(axis=0)
        w_m = self.local_part(local) @ f if local else np.zeros_like(w)
        errors = [np.abs(w - w_m).max(axis=0) / scale]
        for psi, value in zip(Psi.T, lam):
            w_m = w_m + np.outer(psi, value * (psi @ f))
            errors.append(np.abs(w - w_m).max(axis=0) / scale)
        return np.array(errors)

    def truncation_error(self, m: int, loads: np.ndarray, local: float = 0.0) -> np.ndarray | float:
        """Relative error of the displacement with m modes, ``max|G f - G_m f| / max|G f|``.

        Args:
            m: number of modes.
            loads: generalised forces f [N], (N,) or (N, k) for k loads.
            local: the local part's coefficient (``modes``); 0: the eigen basis.

        Returns:
            The error of each load (a float for a single load).
        """
        f = np.asarray(loads, dtype=float).reshape(self.size, -1)
        Psi, lam = self.modes(m, local)
        w = self.matrix @ f
        w_m = Psi @ (lam[:, None] * (Psi.T @ f))
        if local:
            w_m += self.local_part(local) @ f
        error = np.abs(w - w_m).max(axis=0) / np.abs(w).max(axis=0)
        return error if np.ndim(loads) > 1 else float(error[0])

    def modes_for(self, tolerance: float, loads: np.ndarray, local: float = 0.0) -> int:
        """The fewest modes whose truncation error under every load is at most ``tolerance``: 0 when
        the local part alone is within it (all N reproduce G to rounding)."""
        errors = self.truncation_errors(loads, local).max(axis=1)
        within = np.flatnonzero(errors <= tolerance)
        m = int(within[0]) if within.size else self.size
        return max(m, 0 if local else 1)

    def write(self, path: str | Path) -> None:
        """Write to an .npz file (not atomic: see ``eye_compliance`` for the cache)."""
        with open(path, "wb") as stream:
            np.savez(
                stream,
                format_version=FORMAT_VERSION,
                geometry=json.dumps(dataclasses.asdict(self.geometry)),
                theta=self.theta,
                z=self.z,
                areas=self.areas,
                matrix=self.matrix,
                clamped=self.clamped,
            )

    @classmethod
    def read(cls, path: str | Path) -> Compliance:
        """Read a file written by ``write``; ValueError if it is of another format version."""
        with np.load(path, allow_pickle=False) as data:
            version = int(data["format_version"])
            if version != FORMAT_VERSION:
                raise ValueError(f"{path}: compliance format {version}, expected {FORMAT_VERSION}")
            geometry = EyeGeometry(**json.loads(str(data["geometry"])))
            arrays = (data["theta"], data["z"], data["areas"], data["matrix"])
            return cls(geometry, *arrays, clamped=bool(data["clamped"]))


def reference_loads(compliance: Compliance) -> dict[str, np.ndarray]:
    """Generalised forces of the unit reference pressures used to judge the mode truncation [N]:

    - ``uniform``: p = 1 Pa everywhere;
    - ``opposite``: a cos^2 bump 30 deg wide (p = cos^2(pi (theta - theta_c) / 30 deg) for
      |theta - theta_c| < 15 deg) centred opposite the shank, times the film's axial profile
      ``1 - (2 z / B)^2``: the gas-load peak;
    - ``side``: the same bump 90 deg from the shank.
    """
    theta_s = math.radians(compliance.geometry.shank_angle_deg)
    half_width = compliance.geometry.width / 2

    def bump(theta_c: float) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        def pressure(theta, z):
            d = np.angle(np.exp(1j * (theta - theta_c)))  # wrapped to (-pi, pi]
            bump = np.where(np.abs(d) < math.radians(15), np.cos(d * 6.0) ** 2, 0.0)  # cos^2(pi d / 30 deg)
            return bump * (1 - (z / half_width) ** 2)

        return pressure

    return {
        "uniform": compliance.areas.copy(),
        "opposite": compliance.generalised_forces(bump(theta_s + math.pi)),
        "side": compliance.generalised_forces(bump(theta_s + math.pi / 2)),
    }


# ---------------------------------------------------------------------------------------------------
# The finite-element model


class ElasticEye:
    """The discrete elasticity problem of the eye: mesh, P2 space, factorised stiffness.

    Args:
        geometry: the eye.
        comm: the communicator the problem is distributed over.
        element_size: element edge in the eye [m]; default ``DEFAULT_ELEMENT_SIZE`` R. A sixth of it
            along the clamp's edges, where the stress is singular.
        bore_element_size: element edge on the bore and the bushing [m]; default the bushing
            thickness t (one P2 element across it), bounded to [element_size / 4, element_size].
        clamp: clamp the shank arc (the model); False supports the eye instead at the four bore
            points on the axes at z = 0 (u_y = 0 on the x axis, u_x = 0 on the y axis), which removes
            rigid motion and carries no force under loads symmetric about both axes (verification).

    Attributes:
        mesh, facet_tags: the mesh (lengths / R) and its facet groups (``TAGS``).
        V: the P2 displacement space; ``ds_bore``: the bore's measure.
    """

    def __init__(
        self,
        geometry: EyeGeometry,
        comm: MPI.Comm = MPI.COMM_SELF,
        *,
        element_size: float | None = None,
        bore_element_size: float | None = None,
        clamp: bool = True,
    ):
        self.geometry, self.comm, self.clamp = geometry, comm, clamp
        R = geometry.bore_radius
        self.element_size = element_size if element_size is not None else DEFAULT_ELEMENT_SIZE * R
        if bore_element_size is None:
            bore_element_size = max(
                min(self.element_size, geometry.bushing_thickness or self.element_size), self.element_size / 4
            )
        self.bore_element_size = bore_element_size
        self.mesh, cell_tags, self.facet_tags = eye_mesh(
            geometry,
            comm,
            element_size=self.element_size / R,
            bore_element_size=bore_element_size / R,
            clamp=clamp,
        )
        self.V = fem.VectorFunctionSpace(self.mesh, ("Lagrange", 2))
        self.ds_bore = ufl.Measure(
            "ds",
            domain=self.mesh,
            subdomain_data=self.facet_tags,
            metadata={"quadrature_degree": _QUADRATURE_DEGREE},
        )(TAGS["bore"])
        self.bcs = self._supports(self.facet_tags)
        self.K = fem_petsc.assemble_matrix(fem.form(self._stiffness(cell_tags)), bcs=self.bcs)
        self.K.assemble()
        self.K.setOption(PETSc.Mat.Option.SPD, True)
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setOperators(self.K)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("cholesky")
        self.ksp.getPC().setFactorSolverType("mumps")
        self.ksp.setUp()

    @property
    def num_dofs(self) -> int:
        """Global number of displacement unknowns."""
        return self.V.dofmap.index_map.size_global * self.V.dofmap.index_map_bs

    def _stiffness(self, cell_tags) -> ufl.Form:
        u, v = ufl.TrialFunction(self.V), ufl.TestFunction(self.V)
        dx = ufl.Measure("dx", domain=self.mesh, subdomain_data=cell_tags)
        g = self.geometry

        def eps(w):
            return ufl.sym(ufl.grad(w))

        form = 0
        for name, E, nu in (("eye", g.E_eye, g.nu_eye), ("bushing", g.E_bushing, g.nu_bushing)):
            E_scaled = E / g.E_eye
            mu = fem.Constant(self.mesh, E_scaled / (2 * (1 + nu)))
            lmbda = fem.Constant(self.mesh, E_scaled * nu / ((1 + nu) * (1 - 2 * nu)))
            sigma = lmbda * ufl.tr(eps(u)) * ufl.Identity(3) + 2 * mu * eps(u)
            form += ufl.inner(sigma, eps(v)) * dx(TAGS[name])
        return form

    def _supports(self, facet_tags) -> list:
        fdim = self.mesh.topology.dim - 1
        symmetry = fem.locate_dofs_topological(self.V.sub(2), fdim, facet_tags.find(TAGS["symmetry"]))
        bcs = [fem.dirichletbc(PETSc.ScalarType(0), symmetry, self.V.sub(2))]
        if self.clamp:
            clamp = fem.locate_dofs_topological(self.V, fdim, facet_tags.find(TAGS["clamp"]))
            return bcs + [fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), clamp, self.V)]
        # the bore points on the axes at z = 0 are mesh vertices (see _support_angles)
        for component, points in ((1, [(1, 0), (-1, 0)]), (0, [(0, 1), (0, -1)])):

            def at_points(x, points=points):
                return np.any([np.hypot(x[0] - a, x[1] - b) + np.abs(x[2]) < 1e-8 for a, b in points], axis=0)

            vertices = dmesh.locate_entities(self.mesh, 0, at_points)
            dofs = fem.locate_dofs_topological(self.V.sub(component), 0, vertices)
            bcs.append(fem.dirichletbc(PETSc.ScalarType(0), dofs, self.V.sub(component)))
        return bcs

    def _assemble_load(self, form: fem.FormMetaClass) -> PETSc.Vec:
        """An assembled load vector (owned entries summed), zero on the supported dofs."""
        b = fem_petsc.assemble_vector(form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(b, self.bcs)
        return b

    def displacement(self, pressure: Callable[[Expr, Expr], Expr]) -> fem.Function:
        """The displacement [m] under a bore pressure ``pressure(theta, z)`` [Pa], a UFL expression of
        the bushing angle theta [rad] and the axial position z [m]."""
        X = ufl.SpatialCoordinate(self.mesh)
        P = pressure(ufl.atan_2(X[1], X[0]), self.geometry.bore_radius * X[2]) / self.geometry.E_eye
        n = ufl.FacetNormal(self.mesh)
        b = self._assemble_load(fem.form(-P * ufl.inner(n, ufl.TestFunction(self.V)) * self.ds_bore))
        u = fem.Function(self.V, name="displacement")
        self.ksp.solve(b, u.vector)
        b.destroy()
        u.x.scatter_forward()
        u.x.array[:] *= self.geometry.bore_radius  # the solution is U = u / R
        return u

    def compliance(self, n_theta: int, n_z: int) -> Compliance:
        """The compliance on an ``n_theta x n_z`` hat grid (see the module docstring)."""
        if n_theta < 3:
            raise out_of_range("compliance grid n_theta", n_theta, ">= 3")
        if n_z < 2:
            raise out_of_range("compliance grid n_z", n_z, ">= 2")
        g = self.geometry
        R, half_width = g.bore_radius, g.width / 2
        theta = np.arange(n_theta) * (2 * math.pi / n_theta)
        z = np.linspace(0.0, half_width, n_z)
        B, areas = self._hat_loads(theta, z / R)
        G = self._back_substitute(B) / np.outer(areas, areas)  # scaled: A^-1 B^T K^-1 B A^-1
        return Compliance(g, theta, z, areas * R**2, G / (R * g.E_eye), self.clamp)

    def _hat_loads(self, theta: np.ndarray, Z: np.ndarray) -> tuple[scipy.sparse.csc_matrix, np.ndarray]:
        """The load vectors b_i (owned rows; sparse columns) and the areas a_i of the hats (scaled)."""
        X = ufl.SpatialCoordinate(self.mesh)
        cos, sin, Z_k = (fem.Constant(self.mesh, 0.0) for _ in range(3))
        spacing_theta = fem.Constant(self.mesh, theta[1] - theta[0])
        spacing_Z = fem.Constant(self.mesh, Z[1] - Z[0])
        d_theta = ufl.atan_2(cos * X[1] - sin * X[0], cos * X[0] + sin * X[1])  # theta - theta_j in (-pi, pi]
        hat = ufl.max_value(0.0, 1 - abs(d_theta) / spacing_theta) * ufl.max_value(
            0.0, 1 - abs(X[2] - Z_k) / spacing_Z
        )
        n = ufl.FacetNormal(self.mesh)
        load = fem.form(-hat * ufl.inner(n, ufl.TestFunction(self.V)) * self.ds_bore)
        area = fem.form(hat * self.ds_bore)
        columns, areas = [], []
        for Z_value in Z:
            for theta_value in theta:
                cos.value, sin.value, Z_k.value = math.cos(theta_value), math.sin(theta_value), Z_value
                b = self._assemble_load(load)
                columns.append(scipy.sparse.csc_matrix(b.array[:, None]))
                b.destroy()
                areas.append(self.comm.allreduce(fem.assemble_scalar(area), op=MPI.SUM))
        return scipy.sparse.hstack(columns, format="csc"), np.array(areas)

    def _back_substitute(self, B: scipy.sparse.csc_matrix) -> np.ndarray:
        """B^T K^-1 B, on every rank, solving blocks of ``_BLOCK`` right-hand sides at a time."""
        factor = self.ksp.getPC().getFactorMatrix()
        n_local, n_global = self.K.getLocalSize()[0], self.K.getSize()[0]
        result = np.zeros((B.shape[1], B.shape[1]))
        for start in range(0, B.shape[1], _BLOCK):
            block = B[:, start : start + _BLOCK]
            size = ((n_local, n_global), (PETSc.DECIDE, block.shape[1]))
            rhs = PETSc.Mat().createDense(size, array=np.asfortranarray(block.toarray()), comm=self.comm)
            solution = PETSc.Mat().createDense(size, comm=self.comm)
            solution.setUp()
            factor.matSolve(rhs, solution)
            result[:, start : start + block.shape[1]] = B.T @ solution.getDenseArray()
            rhs.destroy()
            solution.destroy()
        return self.comm.allreduce(result, op=MPI.SUM)

    def close(self) -> None:
        """Destroy the PETSc objects (collective)."""
        self.ksp.destroy()
        self.K.destroy()

    def __enter__(self) -> ElasticEye:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# ---------------------------------------------------------------------------------------------------
# Cached construction


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/tribo-solver/compliance``, or ``~/.cache/tribo-solver/compliance``."""
    root = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(root) / "tribo-solver" / "compliance"


def cache_key(geometry: EyeGeometry, n_theta: int, n_z: int, element_size: float, clamp: bool = True) -> str:
    """sha256 of everything the compliance depends on (geometry, grid, element size [m], support, format)."""
    inputs = {
        "format": FORMAT_VERSION,
        "geometry": dataclasses.asdict(geometry),
        "n_theta": n_theta,
        "n_z": n_z,
        "element_size": element_size,
        "clamp": clamp,
    }
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def eye_compliance(
    geometry: EyeGeometry,
    *,
    n_theta: int = 72,
    n_z: int = 5,
    element_size: float | None = None,
    comm: MPI.Comm = MPI.COMM_SELF,
    cache_dir: str | Path | None = None,
    use_cache: bool = True,
    clamp: bool = True,
) -> Compliance:
    """The compliance of the eye on an ``n_theta x n_z`` hat grid, from the cache when it is there.

    Args:
        geometry: the eye (SI).
        n_theta, n_z: grid nodes around the bore and over the half width (both ends included).
        element_size: element edge in the eye [m]; default ``DEFAULT_ELEMENT_SIZE`` R (``ElasticEye``).
        comm: the communicator the solve is distributed over; every rank returns the whole G.
        cache_dir: where the .npz files live; default ``default_cache_dir()``.
        use_cache: False neither reads nor writes the cache.
        clamp: see ``ElasticEye``.
    """
    element_size = element_size if element_size is not None else DEFAULT_ELEMENT_SIZE * geometry.bore_radius
    key = cache_key(geometry, n_theta, n_z, element_size, clamp)
    path = Path(cache_dir or default_cache_dir()) / f"{key}.npz"
    if use_cache:
        cached = comm.bcast(_read_cache(path) if comm.rank == 0 else None, root=0)
        if cached is not None:
            log.info("eye compliance loaded from %s", path)
            return cached
    start = time.perf_counter()
    with ElasticEye(geometry, comm, element_size=element_size, clamp=clamp) as eye:
        compliance = eye.compliance(n_theta, n_z)
        dofs = eye.num_dofs
    log.info(
        "eye compliance: %d dofs, %d load cases, %.1f s", dofs, compliance.size, time.perf_counter() - start
    )
    if use_cache and comm.rank == 0:
        _write_cache(compliance, path)
    return compliance


def _read_cache(path: Path) -> Compliance | None:
    """The cached compliance, or None when there is none (or it is unreadable: it is then rebuilt)."""
    if not path.exists():
        return None
    try:
        return Compliance.read(path)
    except (OSError, EOFError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as err:
        log.warning("ignoring unreadable compliance cache %s: %s", path, err)  # rebuilt and replaced
        return None


def _write_cache(compliance: Compliance, path: Path) -> None:
    """Write atomically (a temporary file in the same directory, then ``os.replace``: readers see the
    old file or the whole new one); a failure only warns, and removes the temporary file."""
    temporary = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(
            dir=path.parent, prefix=path.stem, suffix=".part", delete=False
        ) as file:
            temporary = Path(file.name)
        compliance.write(temporary)
        os.replace(temporary, path)
    except OSError as err:
        log.warning("could not write the compliance cache %s: %s", path, err)
        if temporary is not None:
            temporary.unlink(missing_ok=True)


__all__ = [
    "DEFAULT_ELEMENT_SIZE",
    "DEFAULT_MODES",
    "TAGS",
    "Compliance",
    "ElasticEye",
    "EyeGeometry",
    "cache_key",
    "default_cache_dir",
    "eye_compliance",
    "eye_mesh",
    "reference_loads",
]
