"""Draw two ellipses at their contact distance (chapter Figure 2.12), matplotlib only.

Uses ``matplotlib.figure.Figure`` directly (Agg canvas), so it never opens a window and
works on headless machines regardless of the pyplot backend.
"""

from __future__ import annotations

import numpy as np

from jamflow.model.shapes.contact_distance import contact_distance


def draw_contact_pair(ax, a_i, b_i, a_j, b_j, r_hat, u_i, u_j, method="exact", center_i=(0.0, 0.0), **style):
    """Draw ellipse i at ``center_i`` and ellipse j at center_i + sigma_ij(method) r_hat.

    a, b are full axis lengths (along / across the unit director u); 2D only. ``style`` goes
    to both ``matplotlib.patches.Ellipse`` patches. Returns (sigma, center_j).
    """
    from matplotlib.patches import Ellipse

    r_hat, u_i, u_j = (np.asarray(v, dtype=float) for v in (r_hat, u_i, u_j))
    if r_hat.shape != (2,) or u_i.shape != (2,) or u_j.shape != (2,):
        raise ValueError("draw_contact_pair draws one 2D pair: r_hat, u_i, u_j must have shape (2,)")
    sigma = float(contact_distance(a_i, b_i, a_j, b_j, r_hat, u_i, u_j, method=method))
    c_i = np.asarray(center_i, dtype=float)
    c_j = c_i + sigma * r_hat
    style = {"fill": False, "lw": 1.5, **style}
    for c, a, b, u in ((c_i, a_i, b_i, u_i), (c_j, a_j, b_j, u_j)):
        ax.add_patch(Ellipse(tuple(c), float(a), float(b), angle=float(np.degrees(np.arctan2(u[1], u[0]))), **style))
    return sigma, c_j


FIGURE_2_12_PANELS = (
    # label, size ratio a_j / a_i, u_i, u_j (r_hat = x, alpha = 2)
    ("(a) same size, end to end", 1.0, (1.0, 0.0), (1.0, 0.0)),
    ("(b) same size, side to end", 1.0, (0.0, 1.0), (1.0, 0.0)),
    ("(c) $a_j/a_i$ = 1.4, end to end", 1.4, (1.0, 0.0), (1.0, 0.0)),
    ("(d) $a_j/a_i$ = 1.4, side to end", 1.4, (0.0, 1.0), (1.0, 0.0)),
)


def figure_2_12(path=None, alpha: float = 2.0):
    """Chapter Figure 2.12: alpha = 2 ellipses at the Gaussian (Cleaver, eq. 2.6) contact
    distance (solid) and at the exact one (dashed outline of j). Returns (figure, errors),
    errors = relative error sigma_gauss / sigma_exact - 1 per panel; saves to ``path`` if given.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 6.2))
    axes = fig.subplots(2, 2).ravel()
    r_hat = np.array([1.0, 0.0])
    errors = []
    for ax, (label, ratio, u_i, u_j) in zip(axes, FIGURE_2_12_PANELS):
        a_i, b_i, a_j, b_j = 1.0, 1.0 / alpha, ratio, ratio / alpha
        method = "gaussian" if ratio == 1.0 else "cleaver"
        sg, _ = draw_contact_pair(ax, a_i, b_i, a_j, b_j, r_hat, u_i, u_j, method=method, color="k")
        se = float(contact_distance(a_i, b_i, a_j, b_j, r_hat, u_i, u_j))
        ax.add_patch(_outline(a_j, b_j, u_j, (se, 0.0)))
        errors.append(sg / se - 1)
        ax.set_title(f"{label}\n$\\sigma_g/\\sigma - 1$ = {100 * errors[-1]:.1f}%", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlim(-0.9, sg + 0.9 * ratio)
        ax.set_ylim(-0.8, 0.8)
        ax.axis("off")
    fig.suptitle(f"Ellipses (alpha = {alpha:g}) at the Gaussian contact distance; dashed: exact position of j")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig, errors


def _outline(a, b, u, center):
    from matplotlib.patches import Ellipse

    angle = float(np.degrees(np.arctan2(u[1], u[0])))
    return Ellipse(center, float(a), float(b), angle=angle, fill=False, ls="--", lw=1.0, color="tab:red")
