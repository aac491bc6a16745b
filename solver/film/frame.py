"""The max-gap inlet's solution frame: the film is solved in a frame turned so that the line of maximum
film thickness lies on the mesh seam (theta = 0), where the mesh has nodes and the inlet's ambient
pressure is prescribed, and its results are turned back to the bushing frame.

``frame_angle`` gives the turn, ``FrameTurn`` carries a nodal field (the warm start) to a turned frame,
and ``turn_jacobian`` brings the Jacobian of the solution frame back to the bushing frame, with the
motion of the inlet line with the eccentricity's direction. Numpy and scipy only.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import Delaunay

from solver.film.types import Kinematics


def rotation(angle: float) -> np.ndarray:
    """The 2 x 2 rotation by ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def frame_angle(kin: Kinematics, clearance: float) -> float:
    """Angle beta [rad] by which the max-gap inlet's solution frame is turned from the bushing frame:
    the maximum gap (opposite the eccentricity, or opposite the squeeze velocity when concentric) is
    put on the seam at theta = 0."""
    e, rate = np.asarray(kin.ecc), np.asarray(kin.ecc_rate)
    if np.linalg.norm(e) > 1e-9 * clearance:
        return math.atan2(e[1], e[0]) + math.pi
    if np.linalg.norm(rate) > 0:
        return math.atan2(rate[1], rate[0]) + math.pi
    return 0.0


def in_frame(kin: Kinematics, beta: float) -> Kinematics:
    """The kinematics seen in the frame turned by ``beta``."""
    rot = rotation(-beta)
    return Kinematics(tuple(rot @ kin.ecc), tuple(rot @ kin.ecc_rate), kin.omega_journal, kin.omega_bushing)


def turn_jacobian(
    J: np.ndarray,
    beta: float,
    kin: Kinematics,
    force_solved: np.ndarray,
    clearance: float,
    eccentricity_rate_scale: float,
    turning: bool,
) -> np.ndarray:
    """The Jacobian (4 x 5, SI outputs per dimensionless input) of the solution frame in the bushing
    frame. With ``turning`` (the max-gap inlet off-centre) the inlet line turns with the eccentricity:
    in the solution frame the eccentricity is (-a, 0) and turning it (d eps'_y = -a dphi) turns the
    inlet line with it. Turning eps and its rate together is a symmetry (F -> S F dphi, M unchanged),
    so at fixed rate: dF/dphi = S F' - J'_rate S deps',  dM/dphi = -J'_M,rate S deps'."""
    if turning:
        a = math.hypot(*kin.ecc) / clearance
        S = np.array([[0.0, -1.0], [1.0, 0.0]])
        rate = rotation(-beta) @ np.asarray(kin.ecc_rate) / eccentricity_rate_scale
        d_dphi = -J[:, 2:4] @ (S @ rate)
        d_dphi[:2] += S @ force_solved
        J[:, 1] = d_dphi / (-a)
    rot, rot_back = rotation(beta), rotation(-beta)
    J[:2, :2] = rot @ J[:2, :2] @ rot_back
    J[:2, 2:4] = rot @ J[:2, 2:4] @ rot_back
    J[:2, 4] = rot @ J[:2, 4]
    J[2:, :2] = J[2:, :2] @ rot_back
    J[2:, 2:4] = J[2:, 2:4] @ rot_back
    return J


class FrameTurn:
    """Carries a nodal field on the film mesh to a solution frame turned by delta about the axis:
    ``new(theta, z) = old(theta + delta, z)``, by linear interpolation on a triangulation of the
    nodes in (theta, z) (periodic in theta). Serial; used for the VI's warm start."""

    def __init__(self, x: np.ndarray):
        """x: the coordinates of the owned dofs (unit cylinder)."""
        self.size = len(x)
        self.theta = np.arctan2(x[:, 1], x[:, 0]) % (2 * math.pi)
        self.z = x[:, 2]
        two_pi = 2 * math.pi
        points = np.concatenate(
            [np.column_stack([self.theta + shift, self.z]) for shift in (0.0, two_pi, -two_pi)]
        )
        self.node = np.tile(np.arange(self.size), 3)
        self.triangulation = Delaunay(points)

    def __call__(self, values: np.ndarray, delta: float) -> np.ndarray:
        query = np.column_stack([(self.theta + delta) % (2 * math.pi), self.z])
        simplex = self.triangulation.find_simplex(query)
        inside = simplex >= 0  # (a node on the hull may fall outside by round-off: it keeps its value)
        transform = self.triangulation.transform[simplex[inside]]
        b = np.einsum("ijk,ik->ij", transform[:, :2], query[inside] - transform[:, 2])
        weights = np.column_stack([b, 1.0 - b.sum(axis=1)])
        corners = self.node[self.triangulation.simplices[simplex[inside]]]
        out = values.copy()
        out[inside] = np.einsum("ij,ij->i", weights, values[corners])
        return out
