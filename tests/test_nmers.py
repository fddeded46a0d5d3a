"""Rigid n-mers (docs/notes/nmers.md): the --shape specs nmer/dimer/trimer, their geometry against the
definitions of jamflow.model.shapes.nmers, closed-form union volumes, the site masses LAMMPS needs,
and the refusals of bad input."""

import math

import numpy as np
import pytest

from jamflow.cli.app import main
from jamflow.model.shapes import SPHERE, RigidBody, parse_shape
from jamflow.model.shapes.nmers import trimer_max_bend
from jamflow.model.shapes.union import union_moments


def extent(body: RigidBody, axis: np.ndarray) -> float:
    """Length of the body's union along a unit axis (tip to tip)."""
    along = body.sites @ axis
    return float(np.max(along + 0.5 * body.site_diameters) - np.min(along - 0.5 * body.site_diameters))


def end_axis(body: RigidBody, ends=(0, -1)) -> np.ndarray:
    u = body.sites[ends[1]] - body.sites[ends[0]]
    return u / np.linalg.norm(u)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("n,alpha", [(2, 1.2), (2, 2.0), (3, 1.5), (3, 3.0), (5, 4.2)])
def test_linear_nmer_geometry(n, alpha, dim):
    """N equal sites on a line, equally spaced, tip-to-tip length L = ALPHA D (D = 1)."""
    body = parse_shape(f"nmer:{n}:{alpha}", dim)
    assert body.n_sites == n and body.linear and np.all(body.site_diameters == 1.0)
    x = np.sort(body.sites[:, 0])
    assert np.allclose(np.diff(x), (alpha - 1) / (n - 1), rtol=1e-13)
    assert extent(body, np.eye(dim)[0]) == pytest.approx(alpha, rel=1e-13)
    assert body.dof(dim) == (3 if dim == 2 else 5)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("alpha,s", [(1.3, 0.5), (1.5, 0.7), (1.7, 0.7), (1.8, 1.0)])
def test_asymmetric_dimer_geometry(alpha, s, dim):
    """Sites D1 = 1 and D2 = S, tip-to-tip length ALPHA D1."""
    body = parse_shape(f"dimer:{alpha}:{s}", dim)
    assert sorted(body.site_diameters) == sorted([1.0, s])
    assert extent(body, end_axis(body)) == pytest.approx(alpha, rel=1e-13)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("alpha,c", [(2.0, 0.3), (1.5, 0.2), (2.5, 0.1), (2.0, 0.0)])
def test_bent_trimer_geometry(alpha, c, dim):
    """Outer sites tip to tip L = ALPHA along their line, the middle site at height h = C L."""
    body = parse_shape(f"trimer:{alpha}:{c}", dim)
    outer, middle = body.sites[[0, 2]], body.sites[1]
    axis = end_axis(body, (0, 2))
    assert extent(RigidBody(outer, [1.0, 1.0], fused=False), axis) == pytest.approx(alpha, rel=1e-12)
    foot = outer[0] + ((middle - outer[0]) @ axis) * axis
    assert np.linalg.norm(middle - foot) == pytest.approx(c * alpha, abs=1e-13)
    assert np.linalg.norm(foot - outer.mean(axis=0)) < 1e-13  # above the midpoint
    assert body.dof(dim) == (3 if dim == 2 else (5 if c == 0 else 6))


def lens_area(d, l):
    """Overlap area of two disks of diameter d at centre distance l."""
    r = d / 2
    return 2 * r * r * math.acos(l / (2 * r)) - 0.5 * l * math.sqrt(4 * r * r - l * l)


@pytest.mark.parametrize("alpha", [1.05, 1.5, 1.99, 2.0])
def test_dimer_volumes_closed_form(alpha):
    """Union of two unit disks / spheres at distance l = ALPHA - 1: 2 v - lens (spherical-cap
    lens pi (4r + l)(2r - l)^2 / 12 in 3D)."""
    l, r = alpha - 1.0, 0.5
    area = 2 * math.pi / 4 - (lens_area(1.0, l) if l < 1 else 0.0)
    volume = 2 * math.pi / 6 - math.pi * (4 * r + l) * (2 * r - l) ** 2 / 12
    assert parse_shape(f"nmer:2:{alpha}", 2).volumes([1.0], 2)[0] == pytest.approx(area, rel=1e-13)
    assert parse_shape(f"nmer:2:{alpha}", 3).volumes([1.0], 3)[0] == pytest.approx(volume, rel=1e-11)
    assert parse_shape(f"nmer:2:{alpha}", 2).volumes([1.4], 2)[0] == pytest.approx(1.4**2 * area, rel=1e-13)


def test_asymmetric_dimer_area_closed_form():
    """Two disks of radii R, r at distance l: the lens is R^2 acos(..) + r^2 acos(..) - Heron."""
    alpha, s = 1.5, 0.7
    big, small, l = 0.5, 0.35, alpha - 0.5 - 0.35
    lens = (big**2 * math.acos((l * l + big**2 - small**2) / (2 * l * big))
            + small**2 * math.acos((l * l + small**2 - big**2) / (2 * l * small))
            - 0.5 * math.sqrt((-l + big + small) * (l + big - small) * (l - big + small) * (l + big + small)))
    area = math.pi * (big**2 + small**2) - lens
    assert parse_shape(f"dimer:{alpha}:{s}", 2).volumes([1.0], 2)[0] == pytest.approx(area, rel=1e-13)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("spec", ["nmer:2:1.5", "nmer:4:3", "dimer:1.5:0.7", "dimer:1.2:0.4", "trimer:2:0.3",
                                  "trimer:1.4:0.5"])
def test_site_masses_put_the_site_centre_at_the_union_centre(spec, dim):
    """LAMMPS's rigid-body centre (mass-weighted sites) must be jamflow's (the union's centre of
    mass, the body-frame origin)."""
    body = parse_shape(spec, dim)
    m = body.site_masses
    assert np.all(m > 0) and m.sum() == pytest.approx(1.0, abs=1e-14)
    assert np.abs(m @ body.sites).max() < 1e-13
    volume, first, _ = union_moments(body.sites, body.site_diameters)
    assert np.abs(first / volume).max() < 1e-12  # the body frame's origin is the union's centre
    if spec.startswith("nmer"):
        assert np.allclose(m, 1.0 / body.n_sites)


def test_alpha_one_is_the_disk():
    assert parse_shape("nmer:3:1", 2) is SPHERE and parse_shape("dimer:1:0.5", 3) is SPHERE


def test_touching_sites_are_one_body():
    """ALPHA = N (and 1 + S): neighbouring sites touch at one point; the body is accepted and its
    volume is the sum of its sites."""
    assert parse_shape("nmer:2:2", 2).volumes([1.0], 2)[0] == pytest.approx(math.pi / 2, rel=1e-14)
    assert parse_shape("dimer:1.7:0.7", 3).volumes([1.0], 3)[0] == pytest.approx(math.pi / 6 * (1 + 0.343), rel=1e-11)
    c = trimer_max_bend(2.0)
    assert parse_shape(f"trimer:2:{c!r}", 2).n_sites == 3
    with pytest.raises(ValueError, match="do not overlap or touch"):
        RigidBody([[0, 0], [1.001, 0]], [1, 1])


@pytest.mark.parametrize("spec,match", [
    ("nmer:1:1.5", r"integer N >= 2"), ("nmer:2.5:1.5", r"integer N >= 2"),
    ("nmer:2:0.9", r"outside 1 < ALPHA <= 2"), ("nmer:3:3.2", r"outside 1 < ALPHA <= 3"),
    ("dimer:1.5:1.2", r"D1 is the larger site"), ("dimer:1.5:0", r"S = D2/D1 must lie in \(0, 1\]"),
    ("dimer:1.8:0.7", r"outside 1 < ALPHA <= 1 \+ S = 1.7"), ("dimer:0.9:0.7", r"outside 1 < ALPHA"),
    ("trimer:2:0.5", r"above C_max\(2\) = 0.433013"), ("trimer:1:0.2", r"outside 1 < ALPHA <= 3"),
    ("trimer:3.5:0", r"outside 1 < ALPHA <= 3"), ("trimer:2:-0.1", r"turned by 180 degrees; use trimer:2:0.1"),
    ("trimer:2", "two parameters"), ("nmer:2:x", "must be numbers"), ("dimer:1.5:0.7:1", "two parameters"),
    ("dimer:nan:0.5", "finite"), ("octamer:2", "unknown shape")])
def test_bad_specs_name_the_allowed_range(spec, match):
    with pytest.raises(ValueError, match=match):
        parse_shape(spec, 2)


def test_cli_refuses_a_bad_body_before_work(capsys, tmp_path):
    code = main(["jam", "--shape", "dimer:2.5:0.5", "--n", "16", "--out", str(tmp_path / "p.h5"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "1 < ALPHA <= 1 + S = 1.5" in err and len(err.strip().splitlines()) == 1
    assert not any(tmp_path.iterdir())


def _collinear_profile_integrals(centres, r):
    """Area, volume and second moments of a union of equal disks/spheres centred on the x-axis,
    by integrating its radius profile rho(x) = max_k sqrt(r^2 - (x - x_k)^2) (every section is
    one interval / disk), adaptive quadrature between the breakpoints."""
    from scipy.integrate import quad

    def rho(x):
        return np.sqrt(np.maximum(r * r - (x - centres) ** 2, 0.0)).max()

    cuts = np.sort(np.concatenate([centres - r, centres + r, 0.5 * (centres[1:] + centres[:-1])]))
    total = lambda f: sum(quad(f, a, b, epsabs=0, epsrel=1e-13, limit=200)[0] for a, b in zip(cuts[:-1], cuts[1:]))
    return (total(lambda x: 2 * rho(x)), total(lambda x: 2 * x * x * rho(x)), total(lambda x: 2 * rho(x) ** 3 / 3),
            total(lambda x: np.pi * rho(x) ** 2))


@pytest.mark.parametrize("n,alpha", [(3, 1.5), (3, 2.2), (4, 2.0), (5, 3.0)])
def test_union_moments_of_overlapping_collinear_sites(n, alpha):
    """Sites that overlap beyond their neighbours (a triple overlap for ALPHA < 2 at N = 3): area,
    second moments and volume against the integral of the union's radius profile. (A circle
    whose covered arcs wrapped past 2 pi used to be measured wrongly: nmer:3:1.5 had area
    1.3012 instead of 1.2801.)"""
    x = np.arange(n) * (alpha - 1) / (n - 1)
    x -= x.mean()
    area, sxx, syy, volume = _collinear_profile_integrals(x, 0.5)
    sites2 = np.column_stack([x, np.zeros(n)])
    a, first, second = union_moments(sites2, np.ones(n))
    assert a == pytest.approx(area, rel=1e-12)
    assert np.abs(first).max() < 1e-13
    assert second[0, 0] == pytest.approx(sxx, rel=1e-12) and second[1, 1] == pytest.approx(syy, rel=1e-12)
    v, _, _ = union_moments(np.column_stack([sites2, np.zeros(n)]), np.ones(n))
    assert v == pytest.approx(volume, rel=1e-10)
    assert parse_shape(f"nmer:{n}:{alpha}", 2).linear  # principal axes found along the line


def test_bent_trimer_area_against_a_grid():
    """A bent trimer (every pair overlaps): area and centre of mass on a 3001^2 grid."""
    body = parse_shape("trimer:1.6:0.35", 2)
    g = np.linspace(-1.2, 1.2, 3001)
    xx, yy = np.meshgrid(g, g)
    inside = np.zeros_like(xx, bool)
    for (x, y), d in zip(body.sites, body.site_diameters):
        inside |= (xx - x) ** 2 + (yy - y) ** 2 < (d / 2) ** 2
    cell = (g[1] - g[0]) ** 2
    assert body.volumes([1.0], 2)[0] == pytest.approx(inside.sum() * cell, rel=2e-4)
    assert abs((xx * inside).sum() * cell) < 1e-4 and abs((yy * inside).sum() * cell) < 1e-4


def _one_lobe_packing(left_touch: bool):
    """Dimer 0 (sites at -+0.25 on x) touched by 4 radial dimers on its right site only (contact
    directions -93, -31, 31, 93 degrees; overlap 0.01), or one of them moved onto its left site."""
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing

    angles = np.radians([-93.0, -31.0, 31.0, 93.0])
    u = np.column_stack([np.cos(angles), np.sin(angles)])
    centres = np.array([0.25, 0.0]) + 1.24 * u
    if left_touch:
        centres[0] = np.array([-0.25, 0.0]) + 1.24 * np.array([0.0, -1.0])
        angles[0] = -np.pi / 2
    pos = np.vstack([[0.0, 0.0], centres]) + 10.0
    return Packing(pos, np.ones(5), Box.cube(20.0, 2), shape=parse_shape("nmer:2:1.5", 2),
                   orientations=np.concatenate([[0.0], angles]))


def test_bodies_touched_on_one_site_have_a_free_rotation():
    """Four contacts (d_f + 1) all on one site of a dimer: not a floater by the convex rule, but
    it turns freely about that site (every contact force passes through its centre)."""
    from jamflow.mechanics.contacts import Contacts
    from jamflow.mechanics.reference import energy_forces_pressure

    p = _one_lobe_packing(False)
    c = Contacts(min_contacts=1).compute(p)
    assert c.n_contacts == c.n_site_contacts == c.n_body_contacts == 4 and c.z[0] == 4 and c.n_floaters == 0
    assert c.one_site.all() and c.free_rotations == 5  # the neighbours touch with one site too
    # the free rotation: turning body 0 about its right site's centre changes no overlap
    pivot = np.array([10.25, 10.0])
    turn = lambda a: p.with_positions(np.vstack([pivot + np.array([-0.25 * np.cos(a), -0.25 * np.sin(a)]),
                                                 p.positions[1:]]),
                                      orientations=np.concatenate([[a], p.orientations[1:]]))
    e0 = energy_forces_pressure(p).energy
    assert energy_forces_pressure(turn(0.05)).energy == pytest.approx(e0, rel=1e-13)
    assert Contacts().compute(p).n_floaters == 5  # d_f + 1 = 4: the neighbours (1 contact) go, then body 0
    q = Contacts(min_contacts=1).compute(_one_lobe_packing(True))
    assert q.n_contacts == 4 and not q.one_site[0] and q.one_site[1:].all() and q.free_rotations == 4


def test_side_by_side_dimers_touch_twice():
    """Two parallel dimers 0.99 apart: two overlapping site pairs, two constraints (two contacts
    with count="sites"), one touching pair of bodies."""
    from jamflow.mechanics.contacts import Contacts
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing

    p = Packing([[5.0, 5.0], [5.0, 5.99]], [1.0, 1.0], Box.cube(10.0, 2), shape=parse_shape("nmer:2:1.5", 2),
                orientations=[0.0, np.pi])
    c = Contacts(min_contacts=0, count="sites").compute(p)
    assert c.n_contacts == c.n_site_contacts == 2 and c.n_body_contacts == 1 and list(c.z) == [2, 2]
    assert not c.one_site.any() and c.free_rotations == 0
    b = Contacts(min_contacts=0).compute(p)  # the default counts touching pairs of bodies
    assert b.n_contacts == b.n_body_contacts == 1 and b.n_site_contacts == 2


def test_cli_jams_dimers_and_the_file_keeps_the_body(tmp_path, capsys):
    from jamflow.mechanics.reference import energy_forces_pressure
    from jamflow.io.packing_file import load_packing, read_attrs

    out = tmp_path / "d.h5"
    assert main(["jam", "--shape", "dimer:1.6:0.8", "--n", "24", "--seed", "2", "--out", str(out), "--quiet"]) == 0
    assert "max|tau/d|" in capsys.readouterr().out
    p = load_packing(out)
    body = parse_shape("dimer:1.6:0.8", 2)
    assert p.shape == body and p.shape.label == "dimer:1.6:0.8"
    attrs = read_attrs(out)
    assert attrs["shape_spec"] == "dimer:1.6:0.8"
    assert energy_forces_pressure(p).energy / p.n == pytest.approx(attrs["energy_per_particle"], rel=1e-6)
    assert 1e-16 < attrs["energy_per_particle"] < 2e-16


def test_cli_refuses_pairwise_damping_for_bodies(tmp_path, capsys):
    code = main(["jam", "--shape", "nmer:2:1.5", "--engine", "lammps", "--minimizer", "md", "--md-damping",
                 "pairwise", "--out", str(tmp_path / "p.h5"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "--md-damping pairwise is for disks and spheres" in err and len(err.strip().splitlines()) == 1
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("spec,match", [
    ("nmer:1:1.5", r"integer N >= 2"), ("nmer:2:0.9", r"outside 1 < ALPHA <= 2"),
    ("dimer:1.5:0", r"S = D2/D1 must lie in \(0, 1\]"), ("dimer:1.8:0.7", r"1 \+ S = 1.7"),
    ("trimer:2:0.5", r"above C_max\(2\)"), ("trimer:2:-0.1", r"turned by 180 degrees")])
def test_bad_specs_are_refused_in_2d_and_3d(spec, match, dim):
    with pytest.raises(ValueError, match=match):
        parse_shape(spec, dim)


def test_cli_refuses_lammps_minimisers_for_bodies(tmp_path, capsys):
    code = main(["jam", "--shape", "nmer:2:1.5", "--engine", "lammps", "--out", str(tmp_path / "p.h5"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "minimizer fire on nmer:2:1.5 particles: LAMMPS's minimisers ignore fix rigid" in err and "(it runs md there)" in err


def test_crossed_tangent_dimers_are_an_interlocked_minimum():
    """Why bodies start without overlaps: two alpha = 2 dimers crossed at their waists are at
    rest with V > 0, and every small move (translation, turn) raises the energy, so FIRE from a
    start with such a pair never unjams it (measured: jam at phi0 0.7 and 0.8 failed)."""
    from jamflow.model.box import Box
    from jamflow.mechanics.reference import energy_forces_pressure
    from jamflow.model.packing import Packing

    body = parse_shape("nmer:2:2", 2)
    p = Packing([[5.0, 5.0], [5.0, 5.0]], [1.0, 1.0], Box.cube(10.0, 2), shape=body, orientations=[0.0, np.pi / 2])
    ref = energy_forces_pressure(p)
    assert ref.energy == pytest.approx(4 * 0.5 * (1 - 1 / np.sqrt(2)) ** 2, rel=1e-14)  # 4 site pairs at 1/sqrt 2
    assert np.abs(ref.forces).max() < 1e-14 and np.abs(ref.torques).max() < 1e-14
    for move in ([1e-3, 0.0, 0.0], [0.0, 1e-3, 0.0], [7e-4, 7e-4, 0.0], [0.0, 0.0, 1e-3]):
        q = p.with_positions(p.positions + [[0, 0], move[:2]], orientations=p.orientations + [0.0, move[2]])
        assert energy_forces_pressure(q).energy > ref.energy


@pytest.mark.parametrize("dim,spec", [(2, "nmer:2:2"), (2, "trimer:2:0.3"), (3, "dimer:1.5:0.7")])
def test_bodies_start_without_overlaps(dim, spec):
    """Random sequential addition: no two bodies of the start overlap; the same seed gives the
    same start; too dense a start is refused, naming phi0."""
    from jamflow.model.packing import SeparationFailed
    from jamflow.model.pairs import overlapping_sites
    from jamflow.protocols.settings import CompressionSettings
    from jamflow.protocols.compression import initial_packing

    phi0 = CompressionSettings().start_phi(dim, shape=spec)
    assert phi0 == (0.45 if dim == 2 else 0.25)
    a = initial_packing(64, dim, "bi:1.4:0.5", "spring", 3, phi0, spec)
    b = initial_packing(64, dim, "bi:1.4:0.5", "spring", 3, phi0, spec)
    assert len(overlapping_sites(a)[0]) == 0 and np.array_equal(a.positions, b.positions)
    assert a.phi == pytest.approx(phi0, rel=1e-12)
    with pytest.raises(SeparationFailed, match="use a lower phi0"):
        initial_packing(64, dim, "bi:1.4:0.5", "spring", 3, 0.8 if dim == 2 else 0.6, spec)


def _side_by_side(tilt_angle=0.0):
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing

    return Packing([[5.0, 5.0], [5.0, 5.99]], [1.0, 1.0], Box.cube(10.0, 2), shape=parse_shape("nmer:2:1.5", 2),
                   orientations=[tilt_angle, np.pi + tilt_angle])


def test_drawing_draws_bodies_site_by_site(tmp_path):
    """jamflow.plots.drawing: the disks drawn are the sites (4 for two dimers), the contact lines join
    the centres of the 2 overlapping site pairs (0.99 long, both periodic ends drawn), every site
    coloured by its body's director angle mod pi (pi and 0 are one direction)."""
    from jamflow.plots.drawing import _View, _colours, draw_packing
    from jamflow.mechanics.contacts import Contacts

    p = _side_by_side()
    view = _View(p, 0.5)
    centres, sizes, owner = view.images()
    assert len(centres) == 4 and np.allclose(sizes, 1.0) and list(view.owner) == [0, 0, 1, 1]
    lines, widths, fmax = view.contact_lines()
    assert len(lines) == 4 and np.allclose(np.linalg.norm(lines[:, 1] - lines[:, 0], axis=1), 0.99)
    assert np.allclose(widths, widths.max())  # two equal site overlaps
    turned = _side_by_side(0.3)
    values, _, _ = _colours(turned, Contacts().compute(turned), "orientation", None)
    assert np.allclose(values, 0.3)
    assert draw_packing(p, tmp_path / "d.png", color_by="orientation").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_drawing_slices_3d_bodies_through_their_sites():
    """3D: the slice cuts sites (spheres of a body), not body centres: a dimer lying along z
    with its upper site's centre on the slice shows that site at full size and the other not."""
    from jamflow.model.box import Box
    from jamflow.plots.drawing import _View
    from jamflow.model.packing import Packing
    from jamflow.model.shapes.rotations import random_orientations

    body = parse_shape("nmer:2:2", 3)  # sites at -+0.5 along the body x axis
    q = random_orientations(1, 3, np.random.default_rng(0))
    p = Packing([[3.0, 3.0, 3.0]], [1.0], Box.cube(6.0, 3), shape=body, orientations=q)
    sites = body.world_sites(p.positions, p.orientations, p.diameters)[0]
    top = int(np.argmax(sites[:, 2]))
    view = _View(p, sites[top, 2] / 6.0)
    cut_heights = np.abs(sites[:, 2] - sites[top, 2])
    assert list(view.index) == [int(k) for k in np.flatnonzero(cut_heights < 0.5)]
    assert view.sizes[list(view.index).index(top)] == pytest.approx(1.0)


def test_draw_refuses_orientation_colours_for_disks(tmp_path):
    from jamflow.model.box import Box
    from jamflow.plots.drawing import draw_packing
    from jamflow.model.packing import Packing

    disks = Packing([[1.0, 1.0], [2.0, 2.0]], [1.0, 1.0], Box.cube(4.0, 2))
    with pytest.raises(ValueError, match="color_by 'orientation' needs particles that turn"):
        draw_packing(disks, tmp_path / "x.png", color_by="orientation")
    assert not (tmp_path / "x.png").exists()


def test_free_rotation_vector_of_a_one_site_dimer():
    """Body 0 of the one-lobe packing is touched on its right site (lever (0.25, 0)): its free
    rotation is d_k theta on the rotation row and -z x lever = (0, -0.25) theta on its centre;
    the dynamical matrix (floaters kept) maps it to the contact forces' stress term only."""
    from jamflow.analysis.free_rotations import free_rotation_vectors, pivot_sites
    from jamflow.mechanics.hessian import Coordinates, hessian

    p = _one_lobe_packing(False)
    assert pivot_sites(p) == {0: 1, 1: 0, 2: 0, 3: 0, 4: 0}  # the neighbours touch with their inner site
    coords = Coordinates.of(p)
    v = free_rotation_vectors(p, coords)
    assert v.shape == (15, 5)
    dk = p.rotational_lengths[0, -1]
    expected = np.zeros(15)
    expected[[0, 1, 10]] = [0.0, -0.25, dk]
    assert np.allclose(v[:, 0], expected / np.linalg.norm(expected), atol=1e-15)
    m = hessian(p).toarray()
    stress = 0.01  # |V'| of the 0.01 site overlaps (linear spring): the stress term's scale
    spin = np.zeros(15)
    spin[10] = 1.0  # turning body 0 about its centre instead: the contacts' stiffness resists
    assert np.abs(m @ v).max() < 2 * stress < 0.2 * np.abs(m @ spin).max()


def test_zero_modes_are_translations_plus_free_rotations():
    """The stored N = 64 dimer packing: 6 zero modes = 2 translations + 4 free rotations of its
    one-site dimers, nothing left over; ellipses (no sites) keep their 4 quartic zero modes
    unexplained, so the check can fail."""
    from pathlib import Path

    from jamflow.analysis.free_rotations import zero_modes
    from jamflow.analysis.modes import Spectrum
    from jamflow.io.packing_file import load_packing

    data = Path(__file__).parent / "data"
    dimers = Spectrum(method="dense").compute(load_packing(data / "dimer2d_a1.5_n64_s0.h5"))
    z = zero_modes(dimers)
    assert (z.n_zero, z.n_trivial, z.n_free, z.unexplained) == (6, 2, 4, 0) and z.residual < 1e-9 and z.exactly_trivial
    ellipses = zero_modes(Spectrum(method="dense").compute(load_packing(data / "ellipse1.5_n16_s0.h5")))
    assert (ellipses.n_free, ellipses.unexplained) == (0, 4) and not ellipses.exactly_trivial
    with pytest.raises(ValueError, match="needs every eigenvector"):
        zero_modes(Spectrum(method="dense", vectors=False).compute(load_packing(data / "dimer2d_a1.5_n64_s0.h5")))
