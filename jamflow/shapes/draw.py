"""Pictures of 2D packings: disks and rigid bodies drawn site by site, clipped to the periodic
cell (like the chapter's Figure 2.26). Matplotlib only; the caller owns the figure (Agg backend
for files). ``jamflow draw`` (issue 18) can reuse ``draw_packing``."""

from __future__ import annotations

from itertools import product

import numpy as np

from ..packing import Packing


def site_circles(packing: Packing) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centres (M, 2), diameters (M,), body index (M,)) of every disk to draw: the sites of
    rigid bodies, or the particles themselves."""
    if packing.shape.kind == "sphere":
        return packing.box.wrap(packing.positions), packing.diameters, np.arange(packing.n)
    if packing.shape.kind != "rigid":
        raise ValueError(f"draw_packing draws disks and rigid bodies, not {packing.shape.name(packing.dim)}")
    shape = packing.shape
    sites = shape.world_sites(packing.box.wrap(packing.positions), packing.orientations, packing.diameters)
    diam = packing.diameters[:, None] * shape.site_diameters[None, :]
    return sites.reshape(-1, 2), diam.ravel(), np.repeat(np.arange(packing.n), shape.n_sites)


def draw_packing(ax, packing: Packing, color_by: str = "orientation", cmap: str = "twilight",
                 edge: str = "k", linewidth: float = 0.3):
    """Draw a 2D packing into ``ax``: every disk and its periodic images, clipped to the cell.
    ``color_by``: "orientation" (director angle mod pi, a cyclic colour map: nematic domains show
    as patches of one colour; disks are grey), "size" (the particle's scale) or "none"."""
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Circle, Polygon

    if packing.dim != 2:
        raise ValueError("draw_packing draws 2D packings; for 3D use the packing file with a 3D viewer")
    if color_by not in ("orientation", "size", "none"):
        raise ValueError(f"color_by must be 'orientation', 'size' or 'none', got {color_by!r}")
    centres, diam, body = site_circles(packing)
    h = packing.box.h
    shifts = np.array([h @ np.array(k, float) for k in product((-1, 0, 1), repeat=2)])
    patches = [Circle(c + s, d / 2) for s in shifts for c, d in zip(centres, diam)]
    values = None
    if color_by == "orientation" and packing.orientations is not None:
        u = packing.directors
        values = np.mod(np.arctan2(u[:, 1], u[:, 0]), np.pi)[body]
    elif color_by == "size":
        values = packing.diameters[body]
    coll = PatchCollection(patches, edgecolor=edge, linewidth=linewidth)
    if values is None:
        coll.set_facecolor("0.75")
    else:
        coll.set_array(np.tile(values, len(shifts)))
        coll.set_cmap(cmap)
        if color_by == "orientation":
            coll.set_clim(0.0, np.pi)
    corners = np.array([[0.0, 0.0], h[:, 0], h[:, 0] + h[:, 1], h[:, 1]])
    cell = Polygon(corners, closed=True, fill=False, edgecolor="k", linewidth=0.8)
    ax.add_patch(cell)
    ax.add_collection(coll)
    coll.set_clip_path(cell)
    ax.set_xlim(corners[:, 0].min(), corners[:, 0].max())
    ax.set_ylim(corners[:, 1].min(), corners[:, 1].max())
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    return coll
