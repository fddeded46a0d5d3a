"""Orientations of particles (numpy): 2D angles, 3D unit quaternions.

Conventions used throughout jamflow:
- 2D: ``orientation`` theta (radians, shape (N,)) rotates the body frame by theta about z;
  the director (long axis of an ellipse, axis of a linear body) is the body x-axis,
  u = (cos theta, sin theta) (chapter section 2.3.1: theta is the angle between x and the
  long axis).
- 3D: a unit quaternion q = (w, x, y, z) per particle (shape (N, 4)) rotates body-frame
  vectors into the world frame, v_world = R(q) v_body; the director is R(q) x_body.
  Axisymmetric particles (spheroids, linear bodies) ignore rotations about their director.
"""

from __future__ import annotations

import math

import numpy as np

UNIT_TOL = 1e-8  # | |q| - 1 | allowed for a quaternion read from a user or a file


def quaternion_matrices(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of unit quaternions (N, 4) (w, x, y, z)."""
    w, x, y, z = np.asarray(q, float).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def angle_matrices(theta: np.ndarray) -> np.ndarray:
    """(N, 2, 2) rotation matrices of angles theta (N,)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def rotation_matrices(orientations: np.ndarray, dim: int) -> np.ndarray:
    """(N, d, d) body-to-world rotations of 2D angles or 3D quaternions."""
    return angle_matrices(orientations) if dim == 2 else quaternion_matrices(orientations)


def directors(orientations: np.ndarray, dim: int) -> np.ndarray:
    """(N, d) unit vectors along each particle's body x-axis."""
    return rotation_matrices(orientations, dim)[:, :, 0]


def rotation_change(phi: np.ndarray, v: np.ndarray) -> np.ndarray:
    """exp(phi x) v - v for world rotation vectors phi ((N,) angles about z in 2D, (N, 3) in 3D)
    and vectors v (N, d), by Rodrigues' formula with 1 - cos = 2 sin^2(phi/2): accurate relative
    to the change itself for small phi (no cancellation against v)."""
    v = np.asarray(v, float)
    if v.shape[1] == 2:
        angle = np.asarray(phi, float)
        perp = np.column_stack([-v[:, 1], v[:, 0]])
        return (-2.0 * np.sin(0.5 * angle) ** 2)[:, None] * v + np.sin(angle)[:, None] * perp
    phi = np.asarray(phi, float)
    angle = np.linalg.norm(phi, axis=1)
    safe = np.where(angle > 0, angle, 1.0)
    axis = phi / safe[:, None]
    kv = np.cross(axis, v)
    return np.sin(angle)[:, None] * kv + (2.0 * np.sin(0.5 * angle) ** 2)[:, None] * np.cross(axis, kv)


def turned(orientations: np.ndarray, phi: np.ndarray, dim: int) -> np.ndarray:
    """Orientations after turning each particle by the world rotation vector phi about its
    centre: 2D theta + phi; 3D q' = exp(phi / 2) q (quaternion product), renormalised."""
    if dim == 2:
        return np.asarray(orientations, float) + np.asarray(phi, float)
    q, phi = np.asarray(orientations, float), np.asarray(phi, float)
    angle = np.linalg.norm(phi, axis=1)
    half = np.where(angle > 0, np.sin(0.5 * angle) / np.where(angle > 0, angle, 1.0), 0.5)
    bw, bv = np.cos(0.5 * angle), half[:, None] * phi
    qw, qv = q[:, 0], q[:, 1:]
    w = bw * qw - np.einsum("nk,nk->n", bv, qv)
    v = bw[:, None] * qv + qw[:, None] * bv + np.cross(bv, qv)
    out = np.column_stack([w, v])
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def random_orientations(n: int, dim: int, rng: np.random.Generator) -> np.ndarray:
    """Uniformly random orientations: angles on [0, 2 pi) in 2D (directors uniform on the circle);
    Haar-uniform quaternions in 3D (directors uniform on the sphere; Shoemake's method)."""
    if dim == 2:
        return 2 * np.pi * rng.random(n)
    u1, u2, u3 = rng.random((3, n))
    a, b = np.sqrt(1 - u1), np.sqrt(u1)
    return np.column_stack([a * np.sin(2 * np.pi * u2), a * np.cos(2 * np.pi * u2),
                            b * np.sin(2 * np.pi * u3), b * np.cos(2 * np.pi * u3)])


START_ORIENTATIONS = ("random", "aligned", "nematic:S")  # the starts of ``start_orientations``


def check_start(kind) -> float | None:
    """The start's nematic order S of a start ``kind``: None for "random", 1 for "aligned",
    S for "nematic:S" with S in (0, 1]; a one-line ValueError for anything else."""
    if kind == "random":
        return None
    if kind == "aligned":
        return 1.0
    head, _, value = str(kind).partition(":") if isinstance(kind, str) else ("", "", "")
    try:
        s = float(value) if head == "nematic" else math.nan
    except ValueError:
        s = math.nan
    if not 0.0 < s <= 1.0:  # also refuses nan
        raise ValueError(f"--orientations {kind!r} is not one of random, aligned, nematic:S with the start's "
                         "nematic order S in (0, 1] (e.g. nematic:0.5)")
    return s


def cone_half_angle(s: float) -> float:
    """2D: the half-width D of the uniform law theta in [-D, D] whose P2 = <cos 2 theta> =
    sin(2D) / (2D) is ``s`` in (0, 1]; sinc falls monotonically on 2D in [0, pi], so the root
    is unique (bisection to round-off; D = pi / 2 is isotropic, P2 = 0)."""
    lo, hi = 0.0, 0.5 * math.pi
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if math.sin(2 * mid) / (2 * mid) > s else (lo, mid)
    return 0.5 * (lo + hi)


def nematic_orientations(s: float, n: int, dim: int, rng: np.random.Generator) -> np.ndarray:
    """Orientations whose nematic order about x is ``s`` in expectation (directors uniform in a
    cone about x). 2D: theta uniform in [-D, D], <cos 2 theta> = sin(2D) / (2D) = s
    (``cone_half_angle``). 3D: cos beta (beta the angle to x) uniform in [c, 1] and the azimuth
    uniform, <(3 cos^2 beta - 1) / 2> = c (1 + c) / 2 = s, c = (sqrt(1 + 8 s) - 1) / 2; each
    body turned from x by the shortest rotation (``quaternion_from_director``), as "aligned"."""
    if dim == 2:
        half = cone_half_angle(s)
        return rng.uniform(-half, half, n)
    c = 0.5 * (math.sqrt(1.0 + 8.0 * s) - 1.0)
    cos_b, azimuth = rng.uniform(c, 1.0, n), 2 * np.pi * rng.random(n)
    sin_b = np.sqrt(1.0 - cos_b ** 2)
    return quaternion_from_director(np.column_stack([cos_b, sin_b * np.cos(azimuth), sin_b * np.sin(azimuth)]))


def start_orientations(kind: str, n: int, dim: int, rng: np.random.Generator) -> np.ndarray:
    """Orientations of a start: "random" (``random_orientations``, chapter step 1), "aligned"
    (every director along x: theta = 0 in 2D, the unit quaternion in 3D; a nematic start,
    P2 = 1, for Figure 2.23(c)), or "nematic:S" (a partially nematic start about x, P2 = S in
    expectation, ``nematic_orientations``; "nematic:1" is "aligned"). "aligned" draws nothing
    from ``rng``."""
    s = check_start(kind)
    if s is None:
        return random_orientations(n, dim, rng)
    if s == 1.0:
        return np.zeros(n) if dim == 2 else np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    return nematic_orientations(s, n, dim, rng)


def quaternion_from_director(u: np.ndarray) -> np.ndarray:
    """(N, 4) unit quaternions that rotate the body x-axis onto the unit vectors u (N, 3)
    (the shortest rotation; for u = -x a half turn about z)."""
    u = np.asarray(u, float)
    w = 1.0 + u[:, 0]
    q = np.column_stack([w, np.zeros(len(u)), -u[:, 2], u[:, 1]])  # (1 + x.u, x cross u)
    flip = w < 1e-12
    q[flip] = [0.0, 0.0, 0.0, 1.0]
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def check_orientations(orientations, n: int, dim: int) -> np.ndarray:
    """Validated float array: (N,) finite angles in 2D, (N, 4) unit quaternions in 3D
    (renormalised to round-off); ValueError says what is wrong."""
    o = np.array(orientations, dtype=float)
    shape = (n,) if dim == 2 else (n, 4)
    if o.shape != shape:
        what = "one angle (radians) per particle" if dim == 2 else "one unit quaternion (w, x, y, z) per particle"
        raise ValueError(f"orientations must have shape {shape} ({what}), got {o.shape}")
    if not np.all(np.isfinite(o)):
        raise ValueError("orientations must be finite")
    if dim == 3:
        norm = np.linalg.norm(o, axis=1)
        worst = float(np.max(np.abs(norm - 1))) if n else 0.0
        if worst > UNIT_TOL:
            raise ValueError(f"orientations must be unit quaternions (| |q| - 1 | <= {UNIT_TOL:g}, worst "
                             f"{worst:.3g}); normalise with q / np.linalg.norm(q, axis=1, keepdims=True)")
        o = o / norm[:, None]
    return o



def quaternions_from_matrices(rot: np.ndarray) -> np.ndarray:
    """(N, 4) unit quaternions (w, x, y, z), w >= 0, of rotation matrices (N, 3, 3). Shepperd's
    method: each row below is 4 q_k q for the component k with the largest pivot (accurate for
    every rotation)."""
    r = np.asarray(rot, float)
    t = np.trace(r, axis1=1, axis2=2)
    s = [r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]]
    a = [r[:, 0, 1] + r[:, 1, 0], r[:, 0, 2] + r[:, 2, 0], r[:, 1, 2] + r[:, 2, 1]]
    rows = np.stack([np.column_stack([1 + t, s[0], s[1], s[2]]),
                     np.column_stack([s[0], 1 + 2 * r[:, 0, 0] - t, a[0], a[1]]),
                     np.column_stack([s[1], a[0], 1 + 2 * r[:, 1, 1] - t, a[2]]),
                     np.column_stack([s[2], a[1], a[2], 1 + 2 * r[:, 2, 2] - t])], axis=1)  # (N, 4, 4)
    pivot = np.argmax(np.einsum("nkk->nk", rows), axis=1)
    q = rows[np.arange(len(r)), pivot]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


def fit_orientations(body: np.ndarray, world: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Orientations of rigid bodies from their points: the rotation R_i minimising
    sum_s w_s |R_i body_is - world_is|^2 (Kabsch), ``body`` and ``world`` (N, S, d) offsets from
    the centre. 2D: angles (N,); 3D: quaternions (N, 4). For points on a line (a linear body)
    the rotation about it is arbitrary, as the body ignores it."""
    h = np.einsum("s,nsa,nsb->nab", weights, body, world)  # sum w b w^T
    if body.shape[2] == 2:
        return np.arctan2(h[:, 0, 1] - h[:, 1, 0], h[:, 0, 0] + h[:, 1, 1])
    u, _, vt = np.linalg.svd(h)
    sign = np.sign(np.linalg.det(np.einsum("nab,nbc->nac", u, vt)))
    sign[sign == 0] = 1.0
    fix = np.ones((len(h), 3))
    fix[:, 2] = sign
    rot = np.einsum("nba,nb,ncb->nac", vt, fix, u)  # V diag(1, 1, sign) U^T
    return quaternions_from_matrices(rot)


def generalized_torques(orientations, torques, dim: int, rotational_lengths, mask) -> np.ndarray:
    """(N, r) torques as forces on the coordinates d_k theta (chapter section 3): the body-frame
    components (R^T tau)_a / d_k on the axes that are degrees of freedom (``mask``), 0 elsewhere.
    torques: world frame, (N,) in 2D (about z), (N, 3) in 3D; rotational_lengths (N, r)."""
    tau = np.asarray(torques, float)
    if dim == 2:
        body = tau.reshape(-1, 1)
    else:
        body = np.einsum("nab,na->nb", quaternion_matrices(orientations), tau)
    return body * np.asarray(mask, float) / rotational_lengths
