"""A packing as a picture (matplotlib Agg, PNG written atomically).

Particles are drawn to scale in the periodic (possibly tilted) cell, with their periodic
images clipped to the cell; contacts (overlapping pairs) as lines between centres whose
width is proportional to the contact force |dV/dr|; floaters (``jamflow.mechanics.contacts``)
hatched grey; the others coloured by contact number z or by local bond order |Q6|
(``jamflow.analysis.order``). Spheres are drawn as a *slice*: the cross-sections of the
spheres cut by the plane at fractional height ``slice_at`` of the cell, with the contacts
between cut spheres projected onto it (each half-line stopping at its own cross-section's edge,
since the contact point lies off the plane).

Rigid bodies (n-mers, ``jamflow.model.shapes.nmers``) are drawn site by site: every site is a disk
(a sphere in 3D, cut by the slice) and a black line joins the sites of one body; its contacts are
the overlapping site pairs of different bodies, and ``color_by="orientation"`` colours each body by its director angle mod pi on a
cyclic map (nematic domains show as patches of one colour, like the chapter's Figure 2.26).

Ellipses are drawn with their full axes a, b along and across the director; 3D spheroids have
no slice picture (their cross-sections are ellipses of varying size): export them to OVITO
(``jamflow export``).

A new particle shape adds one ``Drawer`` to ``DRAWERS``: the function that gives the outline of
every drawn particle image as ellipse widths, heights and angles (see ``_round``, ``_elliptic``)
and the dimensions it draws.
"""

from __future__ import annotations

from itertools import product
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import EllipseCollection, LineCollection
from matplotlib.colors import BoundaryNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from jamflow.mechanics.contacts import Contacts
from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_pairs, overlapping_sites, site_packing
from jamflow.plots.figure import save_figure
from jamflow.support.settings_errors import SettingError

COLOR_BY = ("z", "q6", "orientation")
MAX_LINE_WIDTH = 3.0  # points, for the largest contact force


def _round(view, owner):
    """Disks, sphere cross-sections and body sites: widths = heights = their drawn sizes."""
    sizes = view.sizes[owner]
    return sizes, sizes, np.zeros(len(sizes))


def _elliptic(view, owner):
    """2D ellipses: full axes a (along the director), b, and the director angle in degrees."""
    particle = view.owner[view.index[owner]]
    a, b = view.packing.shape.axes(view.packing.diameters[particle]).T
    u = view.packing.directors[particle]
    return a, b, np.degrees(np.arctan2(u[:, 1], u[:, 0]))


class Drawer(NamedTuple):
    """How a shape is drawn: ``outline(view, owner) -> (widths, heights, angles)`` of the drawn
    images (owner indexing view.index), and the dimensions it draws (3D: a slice)."""

    outline: Callable
    dims: tuple = (2, 3)


# shape kind (Packing.shape.kind) -> its Drawer; rigid bodies are their site disks
DRAWERS = {"sphere": Drawer(_round), "rigid": Drawer(_round), "ellipsoid": Drawer(_elliptic, dims=(2,))}


def _outlines(centres, outline, ax, **style):
    """The particle images as ellipses (widths, heights, angles in degrees) in data units."""
    widths, heights, angles = outline
    return EllipseCollection(widths, heights, angles, units="xy", offsets=centres, offset_transform=ax.transData,
                             **style)


def draw_packing(packing: Packing, path, *, color_by: str = "z", slice_at: float = 0.5, q6_r_min: float | None = None,
                 title: str = "") -> Path:
    """Write the picture of ``packing`` to the PNG ``path`` (see module docstring).

    ``q6_r_min``: neighbour cutoff of the local Q6 in <sigma^2>^(1/2) (default: the first
    minimum of g(r)); ``slice_at`` in [0, 1): the slice height of a 3D packing."""
    check_options(packing, color_by, slice_at)
    fig = Figure(figsize=(7.2, 6.4), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    body, label, norm, caption = draw_into(ax, packing, color_by=color_by, slice_at=slice_at, q6_r_min=q6_r_min)
    bar = fig.colorbar(body, ax=ax, label=label, shrink=0.8)
    if isinstance(norm, BoundaryNorm):
        bar.set_ticks(np.arange(norm.boundaries[0] + 0.5, norm.boundaries[-1]))
    ax.set(xlabel="x (small diameters)", ylabel="y (small diameters)")
    ax.set_title(title or caption, fontsize=8)
    return save_figure(fig, path, dpi=130)


def check_options(packing: Packing, color_by: str, slice_at: float) -> None:
    """Refuse options the picture cannot honour, before any work."""
    if color_by not in COLOR_BY:
        raise ValueError(f"color_by must be one of {', '.join(COLOR_BY)}, got {color_by!r}")
    if color_by == "orientation" and packing.orientations is None:
        raise ValueError("color_by 'orientation' needs particles that turn (rigid bodies, ellipses); "
                         f"these are {packing.shape.name(packing.dim)}: use z or q6")
    if not 0.0 <= slice_at < 1.0:
        raise SettingError("slice_at", f"must lie in [0, 1) (a fraction of the cell height), got {slice_at}")
    drawer = DRAWERS.get(packing.shape.kind)
    if drawer is None:
        raise ValueError(f"jamflow draw cannot draw {packing.shape.kind} particles yet; it draws {', '.join(DRAWERS)}")
    if packing.dim not in drawer.dims:
        raise ValueError(f"jamflow draw has no slice picture of {packing.dim}D {packing.shape.name(packing.dim)}s; "
                         "view them in OVITO: jamflow export IN.h5 --format xyz")


def draw_into(ax, packing: Packing, *, color_by: str = "z", slice_at: float = 0.5, q6_r_min: float | None = None,
              contacts: bool = True):
    """Draw ``packing`` into the matplotlib axes ``ax`` (cell, particles and periodic images
    clipped to it, floaters hatched, contact lines unless ``contacts`` is False); returns
    (coloured collection, colour label, norm, caption) for a colour bar and title."""
    check_options(packing, color_by, slice_at)
    view = _View(packing, slice_at)
    found = Contacts(count="sites").compute(packing)  # rigid bodies: site contacts, as jamflow.mechanics.checks
    values, label, norm = _colours(packing, found, color_by, q6_r_min)
    cell = Polygon(view.corners, closed=True, fill=False, lw=0.8, color="k")
    ax.add_patch(cell)
    centres, _, owner = view.images()
    outline = DRAWERS[packing.shape.kind].outline(view, owner)
    particle = view.owner[view.index][owner]  # the particle of every drawn image
    kept, floaters = ~found.floater[particle], found.floater[particle]
    cmap = "twilight" if color_by == "orientation" else "viridis"
    body = _outlines(centres[kept], [o[kept] for o in outline], ax, array=values[particle][kept], cmap=cmap,
                     norm=norm, edgecolors="k", linewidths=0.3)
    ghost = _outlines(centres[floaters], [o[floaters] for o in outline], ax, facecolors="0.85", edgecolors="0.4",
                      linewidths=0.3, hatch="////")
    artists = [body, ghost]
    fmax = 0.0
    bonds = view.body_lines()
    if len(bonds):  # which sites form a body
        artists.append(LineCollection(bonds, linewidths=1.2, colors="k", label="bodies"))
    if contacts:
        lines, widths, fmax = view.contact_lines()
        artists.append(LineCollection(lines, linewidths=widths, colors="crimson", capstyle="round", label="contacts"))
    for artist in artists:
        ax.add_collection(artist)
        artist.set_clip_path(cell)
    lo, hi = view.corners.min(0), view.corners.max(0)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), aspect="equal")
    return body, label, norm, _caption(packing, found, fmax, view)


def _caption(packing, contacts, fmax, view) -> str:
    where = "" if packing.dim == 2 else f"3D slice at z = {view.slice_at:.2f} L_z (cross-sections), "
    return (f"{where}N = {packing.n} {packing.shape.spec(packing.dim)}, phi = {packing.phi:.6f}, {packing.potential.spec}\n"
            f"N_c = {contacts.n_contacts} (isostatic {contacts.isostatic_count}), {contacts.n_floaters} floaters "
            f"(hatched); line width ~ contact force (widest {fmax:.2e})")


def _colours(packing, contacts, color_by, q6_r_min):
    """Per-particle colour values, colour-bar label and norm."""
    if color_by == "orientation":  # director angle in the picture's plane, mod pi (head-tail symmetric)
        u = packing.directors
        return np.mod(np.arctan2(u[:, 1], u[:, 0]), np.pi), "director angle mod pi (rad)", Normalize(0.0, np.pi)
    if color_by == "z":  # non-floaters have z >= d + 1
        low, top = packing.dim + 1, max(int(contacts.z.max()), 2 * packing.dim + 2)
        return contacts.z.astype(float), "contact number z", BoundaryNorm(np.arange(low - 0.5, top + 1.0), 256)
    from jamflow.analysis.order import BondOrder

    mags = BondOrder(r_min=q6_r_min).compute(packing).magnitudes
    name = "|psi_6|" if packing.dim == 2 else "q_6"
    return np.nan_to_num(mags), f"local bond order {name}", Normalize(0.0, 1.0)


class _View:
    """The 2D picture of a packing: the cell (or the slice through it), the disks drawn (the
    particles, or the sites of rigid bodies; ``owner``: the particle of each disk), their
    sizes in it, and which disks appear (``index``: all in 2D, the cut ones in 3D)."""

    def __init__(self, packing: Packing, slice_at: float):
        self.packing, self.slice_at = packing, slice_at
        disks, self.owner = site_packing(packing) if packing.shape.made_of_sites else (packing, np.arange(packing.n))
        h = packing.box.h
        pos = packing.box.wrap(disks.positions)
        if packing.dim == 2:  # sizes: what a particle image reaches (an ellipse's major axis)
            self.index, self.sizes, xy = np.arange(disks.n), 2.0 * disks.shape.reach(disks.diameters), pos
        else:
            dz = (pos[:, 2] - slice_at * h[2, 2] + 0.5 * h[2, 2]) % h[2, 2] - 0.5 * h[2, 2]
            radius = 0.5 * disks.diameters
            self.index = np.flatnonzero(np.abs(dz) < radius)
            self.sizes = 2.0 * np.sqrt(radius[self.index] ** 2 - dz[self.index] ** 2)
            xy = pos[:, :2] - h[:2, 2] * (pos[:, 2:3] / h[2, 2])  # move along the third cell vector into the plane
        self.diameters = disks.diameters
        self.h2 = h[:2, :2]
        frac = np.linalg.solve(self.h2, xy.T).T % 1.0
        self.xy = frac @ self.h2.T  # every disk wrapped into the 2D cell
        self.corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float) @ self.h2.T

    def pairs(self):
        """(i, j, dr, r, sigma) of every overlapping pair of drawn disks (sites of different
        bodies for rigid bodies), dr = r_i - r_j."""
        if self.packing.shape.made_of_sites:
            _, _, s, t, dr, r, sigma = overlapping_sites(self.packing)
            return s, t, dr, r, sigma
        return overlapping_pairs(self.packing)

    def images(self):
        """Centres, sizes and owners (index into ``self.index``) of every periodic image
        that reaches into the cell."""
        xy, sizes = self.xy[self.index], self.sizes
        reach = sizes.max(initial=0.0) / np.min(np.abs(np.diag(self.h2)))
        centres, owners = [], []
        for shift in product((-1, 0, 1), repeat=2):
            moved = xy + np.array(shift, float) @ self.h2.T
            frac = np.linalg.solve(self.h2, moved.T).T
            near = np.all((frac > -reach) & (frac < 1 + reach), axis=1)
            centres.append(moved[near])
            owners.append(np.flatnonzero(near))
        owner = np.concatenate(owners)
        return np.concatenate(centres), sizes[owner], owner

    def _cut(self) -> np.ndarray:
        """Whether each disk is drawn (cut by the slice in 3D)."""
        cut = np.zeros(len(self.owner), bool)
        cut[self.index] = True
        return cut

    def _radii(self) -> np.ndarray:
        """Drawn radius of each disk (its cross-section in 3D; 0 where not drawn)."""
        radius = np.zeros(len(self.owner))
        radius[self.index] = 0.5 * self.sizes
        return radius

    def contact_lines(self):
        """Segments (both periodic ends), line widths and the largest force drawn. In 2D a
        contact joins the two centres; in a 3D slice the contact point is out of the plane, so each
        half-line, from a centre towards the contact point, stops at the edge of its own
        cross-section and no line crosses empty space."""
        i, j, dr, r, sigma = self.pairs()
        if self.packing.dim == 3:
            keep = self._cut()[i] & self._cut()[j]
            i, j, dr, r, sigma = i[keep], j[keep], dr[keep], r[keep], sigma[keep]
        force = np.abs(self.packing.potential.dv_dr(r, sigma))
        fmax = float(force.max()) if len(force) else 0.0
        widths = MAX_LINE_WIDTH * force / fmax if fmax > 0 else np.zeros(0)
        start_i, start_j, step_i, step_j = self.xy[i], self.xy[j], dr[:, :2], dr[:, :2]
        if self.packing.dim == 3:
            length = np.linalg.norm(step_i, axis=1)
            unit = step_i / np.where(length > 0, length, 1.0)[:, None]
            share = self.diameters[i] / (self.diameters[i] + self.diameters[j])  # contact point along r_i - r_j
            radius = self._radii()
            step_i = unit * np.minimum(share * length, radius[i])[:, None]
            step_j = unit * np.minimum((1 - share) * length, radius[j])[:, None]
        lines = np.concatenate([np.stack([start_i, start_i - step_i], 1), np.stack([start_j, start_j + step_j], 1)])
        return lines, np.concatenate([widths, widths]), fmax

    def body_lines(self) -> np.ndarray:
        """Rigid bodies: segments joining the consecutive sites of each body (both periodic
        ends; in 3D only sites cut by the slice), so that the picture shows which disks form a
        body. Empty for other shapes."""
        p = self.packing
        if not p.shape.made_of_sites or p.shape.n_sites < 2:
            return np.zeros((0, 2, 2))
        offsets = p.shape.world_sites(p.positions, p.orientations, p.diameters) - p.positions[:, None, :]
        n_sites = p.shape.n_sites
        first = (np.arange(p.n)[:, None] * n_sites + np.arange(n_sites - 1)[None, :]).ravel()
        step = np.diff(offsets, axis=1).reshape(-1, p.dim)[:, :2]  # site k -> k + 1 of each body
        keep = self._cut()[first] & self._cut()[first + 1]
        a, b, step = self.xy[first[keep]], self.xy[first[keep] + 1], step[keep]
        return np.concatenate([np.stack([a, a + step], 1), np.stack([b, b - step], 1)])
