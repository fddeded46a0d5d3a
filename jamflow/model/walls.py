"""Walls and gravity: the chapter's other boundary conditions (chapter section 2.3).

- **Smooth walls** sit at both faces of every walled (non-periodic) axis of the box,
  x_a = 0 and x_a = L_a (``jamflow.model.box``). A mobile disk/sphere i at distance h from a face
  feels the particles' own law at contact distance a_i / 2: V(s), s = h / (a_i / 2)
  (``jamflow.model.potentials``; the same law as a pair at r = h, sigma = a_i / 2, so a wall is a
  particle's mirror image). The wall contact enters the virial like a pair: h (-dV/dh) along
  the axis, so at force balance the virial pressure P_aa equals the pressure on the walls.
- **Rough walls** are rows of fixed particles of the small diameter with their centres on
  the faces (``rough_wall_particles``), spaced by at least their diameter at the densest
  packing (so they never overlap each other and no mobile particle passes between them);
  fixed particles do not interact with each other and feel no wall or gravity. The smooth
  faces stay behind them (a mobile particle cannot reach them through the row). Rows on an
  upper face sit 1e-12 L_a inside it (``UPPER_INSET``), where LAMMPS's non-periodic box
  still owns them.
- **Gravity** g pulls every mobile particle (unit mass) along -e_(d-1): V = g x_(d-1),
  onto the floor x_(d-1) = 0, which must be a wall.

Packing fraction: particle volume inside the walls over the volume between them; a fixed
particle on k faces counts 2^-k of its volume (``inside_fraction``).
Wall loads (``face_loads``): the force the particles exert on each face, through the smooth
wall and through the fixed particles on that face (a particle on an edge or corner counts on
each of its faces); the pressure on a face is its outward normal component over its area.
Units: lengths in small diameters, energies eps, forces eps / diameter.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from jamflow.model.box import AXES, Box
from jamflow.model.packing import face_membership

WALL_TYPES = ("smooth", "rough")
UPPER_INSET = 1e-12  # upper-face rows sit at L_a (1 - UPPER_INSET): LAMMPS (boundary f) owns no atom at x = L_a


def parse_walls(spec, dim: int) -> tuple[int, ...]:
    """``"y"``, ``"x,y"``, ``"x,y,z"`` (or "", "none") -> sorted walled axes."""
    if spec is None:
        return ()
    if isinstance(spec, (tuple, list)):
        names = [AXES[a] if isinstance(a, (int, np.integer)) else str(a) for a in spec]
    else:
        text = str(spec).strip().lower()
        names = [] if text in ("", "none") else [t.strip() for t in text.split(",")]
    allowed = AXES[:dim]
    bad = [n for n in names if n not in allowed]
    if bad or len(set(names)) != len(names):
        raise ValueError(f"--walls {spec!r}: give distinct axes among {', '.join(allowed)} separated by commas, "
                         f"e.g. y or x,y")
    return tuple(sorted(allowed.index(n) for n in names))


def walled_box(box: Box, axes) -> Box:
    """The same cell with walls on ``axes`` (refused for an axis that takes part in a shear)."""
    return Box(box.h, tuple(a not in axes for a in range(box.dim)))


def rough_wall_particles(box: Box, diameter: float, shrink: float = 1.0) -> np.ndarray:
    """Centres (M, d) of the fixed particles lining every walled face of ``box``: a square grid
    on each face, spaced by at least ``diameter`` once the box is scaled by ``shrink`` (< 1:
    the densest compression expected), including the face's edges along other walled axes;
    points shared by several faces appear once."""
    d, lengths = box.dim, box.lengths
    points = []
    for a in box.walls:
        axes = []
        for b in range(d):
            if b == a:
                continue
            count = max(1, int(math.floor(lengths[b] * shrink / diameter)))
            grid = np.arange(count + (0 if box.periodic[b] else 1)) * (lengths[b] / count)
            if not box.periodic[b]:
                grid[-1] = lengths[b] * (1 - UPPER_INSET)
            axes.append(grid)
        mesh = np.meshgrid(*axes, indexing="ij")
        others = np.column_stack([m.ravel() for m in mesh])
        for face in (0.0, lengths[a] * (1 - UPPER_INSET)):
            pts = np.insert(others, a, face, axis=1)
            points.append(pts)
    pts = np.concatenate(points)
    key = np.round(pts / (1e-6 * diameter)).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    return pts[np.sort(first)]






def smooth_wall_contacts(packing):
    """Each smooth-wall contact group: (axis a, side 0 lower / 1 upper, mobile particles k within
    a_k/2 of that face, their gaps h_k to it, the push -dV/dh >= 0 away from the face), the wall
    acting at contact distance a_k/2 with the particles' own law."""
    pot, half, mobile = packing.potential, 0.5 * packing.diameters, packing.mobile
    for a in packing.box.walls:
        x = packing.positions[:, a]
        for side, h in enumerate((x, packing.box.lengths[a] - x)):
            k = np.flatnonzero(mobile & (h < half))
            yield a, side, k, h[k], -pot.dv_dr(h[k], half[k])


def smooth_wall_terms(packing):
    """Smooth walls on the mobile particles: (energy, forces (N, d), virial (d, d), face forces
    (d, 2, d): the force the particles exert on each face)."""
    n, d = packing.n, packing.dim
    forces, virial, loads = np.zeros((n, d)), np.zeros((d, d)), np.zeros((d, 2, d))
    energy = 0.0
    half = 0.5 * packing.diameters
    for a, side, k, h, push in smooth_wall_contacts(packing):
        sign = 1.0 if side == 0 else -1.0
        energy += float(packing.potential.energy(h, half[k]).sum())
        forces[k, a] += sign * push
        virial[a, a] += float((h * push).sum())
        loads[a, side, a] = -sign * float(push.sum())
    return energy, forces, virial, loads


def gravity_terms(packing):
    """V = g sum_mobile x_(d-1) and the weight -g e_(d-1) on every mobile particle."""
    forces = np.zeros((packing.n, packing.dim))
    if not packing.gravity:
        return 0.0, forces
    mobile = packing.mobile
    forces[mobile, -1] = -packing.gravity
    return float(packing.gravity * packing.positions[mobile, -1].sum()), forces


def face_loads(packing, smooth_loads: np.ndarray, pair_forces: np.ndarray) -> np.ndarray:
    """(d, 2, d) force of the particles on each face: the smooth wall's share plus the pair
    forces on the fixed particles centred on that face."""
    member = face_membership(packing)
    return smooth_loads + np.einsum("nas,nb->asb", member.astype(float), pair_forces)


def face_pressures(box: Box, loads: np.ndarray) -> np.ndarray:
    """(k, 2) pressure on the lower and upper face of each walled axis: outward normal force
    over the face area (eps / diameter^(d-1) per area, i.e. eps / diameter^d)."""
    out = []
    for a in box.walls:
        area = box.volume / box.lengths[a]
        out.append([-loads[a, 0, a] / area, loads[a, 1, a] / area])
    return np.array(out).reshape(len(box.walls), 2)


def with_walls(packing, axes, wall_type: str = "smooth"):
    """A start with walls on ``axes`` (walled axes bound the box at its faces): the mobile
    particles' coordinates along walled axes are mapped affinely into [a_i/2, L_a - a_i/2], so
    none starts on or behind a wall (LAMMPS refuses that). Rough walls add rows of fixed
    particles of the smallest diameter on every walled face (appended after the mobile ones),
    spaced by at least their diameter up to the densest packing of equal disks/spheres."""
    from jamflow.model.packing import DENSEST_PHI

    if wall_type not in WALL_TYPES:
        raise ValueError(f"unknown wall type {wall_type!r}; use one of {', '.join(WALL_TYPES)}")
    if not axes:
        return packing
    box = walled_box(packing.box, axes)
    x, half = np.array(packing.positions), 0.5 * packing.diameters
    for a in box.walls:
        x[:, a] = half + (x[:, a] / box.lengths[a]) * (box.lengths[a] - 2 * half)
    packing = replace(packing, box=box, positions=x)
    if wall_type == "smooth":
        return packing
    if not packing.shape.round or packing.fixed is not None:
        raise ValueError("rough walls are made of fixed disks/spheres next to mobile disks/spheres")
    small = float(packing.diameters.min())
    shrink = (packing.phi / DENSEST_PHI[packing.dim]) ** (1.0 / packing.dim)
    sites = rough_wall_particles(box, small, min(1.0, shrink))
    n = packing.n
    return replace(packing, positions=np.vstack([packing.positions, sites]),
                   diameters=np.concatenate([packing.diameters, np.full(len(sites), small)]),
                   fixed=np.concatenate([np.zeros(n, bool), np.ones(len(sites), bool)]))


def wall_type(packing) -> str:
    """"rough" (fixed wall particles), "smooth" (walls only) or "" (periodic box)."""
    if packing.fixed is not None:
        return "rough"
    return "smooth" if packing.box.walls else ""


def wall_loads(packing) -> np.ndarray:
    """(d, 2, d) force of the particles on each face of the walled axes (cell search: any N)."""
    from jamflow.model.pairs import overlapping_pairs

    _, _, _, smooth = smooth_wall_terms(packing)
    if packing.fixed is None:
        return smooth
    i, j, dr, r, sigma = overlapping_pairs(packing)
    one = packing.fixed[i] ^ packing.fixed[j]
    i, j, dr, r, sigma = i[one], j[one], dr[one], r[one], sigma[one]
    fpair = (-packing.potential.dv_dr(r, sigma) / r)[:, None] * dr  # on i from j
    forces = np.zeros((packing.n, packing.dim))
    np.add.at(forces, i, fpair)
    np.add.at(forces, j, -fpair)
    return face_loads(packing, smooth, forces)
