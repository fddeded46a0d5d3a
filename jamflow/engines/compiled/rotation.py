"""Orientation arithmetic for compiled kernels (conventions of ``jamflow.model.shapes.rotations``).

2D orientations are angles o[i, 0]; 3D orientations are unit quaternions o[i] = (w, x, y, z)
rotating body-frame vectors into the world frame. Rotational steps and torques are handled
in the body frame: a step phi (body-frame rotation vector) right-multiplies the quaternion,
q <- q exp(phi / 2); a world torque tau becomes R(q)^T tau.
"""

from __future__ import annotations

import math

from jamflow.engines.compiled import jit


@jit
def quaternion_matrix(w, x, y, z):
    """R of the unit quaternion (w, x, y, z), row by row: (r00, r01, r02, r10, ..., r22). The
    compiled twin of ``rotations.quaternion_matrices`` (numpy, the reference; tests/test_engines.py
    holds them together)."""
    return (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
            2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
            2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))


@jit
def rotation_matrix(o, i, out):
    """out (d, d) = R of particle i."""
    if o.shape[1] == 1:
        c, s = math.cos(o[i, 0]), math.sin(o[i, 0])
        out[0, 0], out[0, 1], out[1, 0], out[1, 1] = c, -s, s, c
        return
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = quaternion_matrix(o[i, 0], o[i, 1], o[i, 2], o[i, 3])
    out[0, 0], out[0, 1], out[0, 2] = r00, r01, r02
    out[1, 0], out[1, 1], out[1, 2] = r10, r11, r12
    out[2, 0], out[2, 1], out[2, 2] = r20, r21, r22


@jit
def rotate(o, i, phi):
    """Turn particle i by the body-frame rotation vector phi (length 1 in 2D, 3 in 3D);
    returns the rotation angle |phi|."""
    if o.shape[1] == 1:
        o[i, 0] += phi[0]
        return abs(phi[0])
    angle = math.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    if angle == 0.0:
        return 0.0
    s = math.sin(0.5 * angle) / angle
    bw, bx, by, bz = math.cos(0.5 * angle), s * phi[0], s * phi[1], s * phi[2]
    w, x, y, z = o[i, 0], o[i, 1], o[i, 2], o[i, 3]
    nw = w * bw - x * bx - y * by - z * bz
    nx = w * bx + x * bw + y * bz - z * by
    ny = w * by - x * bz + y * bw + z * bx
    nz = w * bz + x * by - y * bx + z * bw
    norm = math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
    o[i, 0], o[i, 1], o[i, 2], o[i, 3] = nw / norm, nx / norm, ny / norm, nz / norm
    return angle


@jit
def generalized_torques(o, tau, dk, mask, g):
    """g[i, a] = mask[a] (R_i^T tau_i)_a / dk[i, a]: torques as forces on the coordinates
    d_k theta (chapter section 3). 2D: tau and g are (N, 1). The compiled twin of
    ``rotations.generalized_torques`` (numpy, the reference; tests/test_engines.py compares them)."""
    n, r = g.shape
    if r == 1:
        for i in range(n):
            g[i, 0] = mask[0] * tau[i, 0] / dk[i, 0]
        return
    for i in range(n):
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = quaternion_matrix(o[i, 0], o[i, 1], o[i, 2], o[i, 3])
        t0, t1, t2 = tau[i, 0], tau[i, 1], tau[i, 2]
        g[i, 0] = mask[0] * (r00 * t0 + r10 * t1 + r20 * t2) / dk[i, 0]
        g[i, 1] = mask[1] * (r01 * t0 + r11 * t1 + r21 * t2) / dk[i, 1]
        g[i, 2] = mask[2] * (r02 * t0 + r12 * t1 + r22 * t2) / dk[i, 2]
