"""2-D Euler-Bernoulli frame elements: axial bar + bending beam, DOFs (u, w, theta) per node.

theta = dw/dx. A point at height z above the neutral axis moves axially by u - z * theta, so the
contact surfaces (offset h/2) have axial motion (SPEC section 2).
"""
from __future__ import annotations

import numpy as np

DOFS_PER_NODE = 3  # u (axial) [m], w (transverse) [m], theta (rotation) [rad]
U, W, THETA = 0, 1, 2


def element_matrices(l: float, E: float, A: float, I: float, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass of one frame element, DOFs (u1, w1, th1, u2, w2, th2).

    Parameters: l [m] element length, E [Pa], A [m^2], I [m^4] second moment, rho [kg/m^3].
    Returns (K [N/m, N, N m], M [kg, kg m, kg m^2]) as 6 x 6 arrays.
    """
    # the entries written out (no fancy-index assignment: this runs once per element in every build);
    # each is the same product as the block form  c * [[...]]  (c the block's factor), so the same bits
    a, b = E * A / l, E * I / l**3
    ma, mb = rho * A * l / 6.0, rho * A * l / 420.0
    l6, l2 = 6 * l, l**2
    k = np.array([
        [a * 1.0, 0.0, 0.0, a * -1.0, 0.0, 0.0],
        [0.0, b * 12.0, b * l6, 0.0, b * -12.0, b * l6],
        [0.0, b * l6, b * (4 * l2), 0.0, b * (-6 * l), b * (2 * l2)],
        [a * -1.0, 0.0, 0.0, a * 1.0, 0.0, 0.0],
        [0.0, b * -12.0, b * (-6 * l), 0.0, b * 12.0, b * (-6 * l)],
        [0.0, b * l6, b * (2 * l2), 0.0, b * (-6 * l), b * (4 * l2)]])
    m = np.array([
        [ma * 2.0, 0.0, 0.0, ma * 1.0, 0.0, 0.0],
        [0.0, mb * 156.0, mb * (22 * l), 0.0, mb * 54.0, mb * (-13 * l)],
        [0.0, mb * (22 * l), mb * (4 * l2), 0.0, mb * (13 * l), mb * (-3 * l2)],
        [ma * 1.0, 0.0, 0.0, ma * 2.0, 0.0, 0.0],
        [0.0, mb * 54.0, mb * (13 * l), 0.0, mb * 156.0, mb * (-22 * l)],
        [0.0, mb * (-13 * l), mb * (-3 * l2), 0.0, mb * (-22 * l), mb * (4 * l2)]])
    return k, m


def frame_shape(xi: float, l: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frame element's interpolation at xi = (x - x1) / l in [0, 1] of an element of length l [m]:
    rows of weights on (u1, w1, th1, u2, w2, th2) giving u(x) (linear), w(x) (cubic Hermite) and
    theta(x) = dw/dx, the fields whose energy element_matrices integrates.

        u = (1 - xi) u1 + xi u2
        w = (1 - 3 xi^2 + 2 xi^3) w1 + l (xi - 2 xi^2 + xi^3) th1 + (3 xi^2 - 2 xi^3) w2 + l (xi^3 - xi^2) th2
    """
    u = np.array([1.0 - xi, 0.0, 0.0, xi, 0.0, 0.0])
    w = np.array([0.0, 1.0 - 3 * xi**2 + 2 * xi**3, l * (xi - 2 * xi**2 + xi**3),
                  0.0, 3 * xi**2 - 2 * xi**3, l * (xi**3 - xi**2)])
    th = np.array([0.0, (-6 * xi + 6 * xi**2) / l, 1.0 - 4 * xi + 3 * xi**2,
                   0.0, (6 * xi - 6 * xi**2) / l, 3 * xi**2 - 2 * xi])
    return u, w, th


def assemble_beam(x_nodes: np.ndarray, E: float, width: float, height: float, rho: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Global K, M of one beam meshed at `x_nodes` [m] (3 DOFs per node, node-major order)."""
    n = len(x_nodes)
    A = width * height
    I = width * height**3 / 12.0
    K = np.zeros((3 * n, 3 * n))
    M = np.zeros((3 * n, 3 * n))
    for e in range(n - 1):
        ke, me = element_matrices(x_nodes[e + 1] - x_nodes[e], E, A, I, rho)
        sl = slice(3 * e, 3 * e + 6)
        K[sl, sl] += ke
        M[sl, sl] += me
    return K, M


def mesh_nodes(x_start: float, x_end: float, required: list[float], h_max: float) -> np.ndarray:
    """Node positions [m] from x_start to x_end that include every `required` x and have no
    element longer than h_max (each gap between required points split evenly)."""
    pts = sorted({round(x, 12) for x in [x_start, x_end, *required]})
    nodes = [pts[0]]
    for a, b in zip(pts[:-1], pts[1:]):
        n_el = max(1, int(np.ceil((b - a) / h_max - 1e-9)))
        nodes.extend(a + (b - a) * np.arange(1, n_el + 1) / n_el)
    return np.array(nodes)
