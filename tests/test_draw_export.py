"""jamflow draw (pictures, in the format their suffix names) and jamflow export (LAMMPS dump,
extended XYZ for OVITO)."""

import numpy as np
import pytest
from conftest import no_traceback

from jamflow.io.readers import packings_from_lammps
from jamflow.cli.app import main
from jamflow.plots.drawing import MAX_LINE_WIDTH, _View, draw_packing
from jamflow.io.export import export_packing
from jamflow.io.packing_file import save_packing
from jamflow.model.pairs import overlapping_pairs
from jamflow.protocols.compression import jam

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def disks():
    return jam(n=32, dim=2, seed=3).packing


@pytest.fixture(scope="module")
def spheres():
    return jam(n=32, dim=3, sizes="mono", seed=1).packing


def test_draw_command_writes_a_png(disks, tmp_path, capsys):
    src = save_packing(tmp_path / "p.h5", disks)
    assert main(["draw", str(src)]) == 0
    assert (tmp_path / "p.png").read_bytes()[:8] == PNG
    assert main(["draw", str(src), "-o", str(tmp_path / "q6.png"), "--color-by", "q6", "--q6-r-min", "1.35"]) == 0
    assert (tmp_path / "q6.png").read_bytes()[:8] == PNG


def test_contact_lines_are_proportional_to_force(disks):
    lines, widths, fmax = _View(disks, 0.5).contact_lines()
    i, j, dr, r, sigma = overlapping_pairs(disks)
    force = np.abs(disks.potential.dv_dr(r, sigma))
    assert len(lines) == 2 * len(i)  # both periodic ends of every contact
    assert np.allclose(widths, MAX_LINE_WIDTH * np.tile(force, 2) / force.max(), rtol=1e-12)
    assert fmax == force.max()
    assert np.allclose(np.linalg.norm(lines[:, 1] - lines[:, 0], axis=1), np.tile(r, 2))  # centre to centre


def test_sphere_slice_cuts_the_right_spheres(spheres, tmp_path):
    view = _View(spheres, 0.3)
    lz = spheres.box.h[2, 2]
    z = spheres.box.wrap(spheres.positions)[:, 2]
    dz = np.minimum(np.abs(z - 0.3 * lz), lz - np.abs(z - 0.3 * lz))
    cut = np.flatnonzero(dz < 0.5 * spheres.diameters)
    assert np.array_equal(view.index, cut)
    assert np.allclose(view.sizes, 2 * np.sqrt(0.25 * spheres.diameters[cut] ** 2 - dz[cut] ** 2))
    assert draw_packing(spheres, tmp_path / "s.png", slice_at=0.3).read_bytes()[:8] == PNG


def test_draw_refuses_bad_options(disks, tmp_path):
    with pytest.raises(ValueError, match="slice_at"):
        draw_packing(disks, tmp_path / "x.png", slice_at=1.0)
    with pytest.raises(ValueError, match="color_by"):
        draw_packing(disks, tmp_path / "x.png", color_by="size")


@pytest.mark.parametrize("which", ["disks", "spheres"])
def test_lammps_dump_reads_back_through_mdanalysis(which, disks, spheres, tmp_path):
    """Second reader: MDAnalysis (float32 coordinates) gets positions, radii and the box back."""
    p = {"disks": disks, "spheres": spheres}[which]
    path = export_packing(p, tmp_path / "p.dump", "lammps-dump")
    (back,) = packings_from_lammps(path, dim=p.dim)
    assert np.allclose(back.diameters, p.diameters, rtol=1e-6)
    assert np.allclose(back.box.h, p.box.h, rtol=1e-6)
    assert np.allclose(back.positions, p.box.wrap(p.positions), atol=1e-5)


def test_extended_xyz_columns_and_lattice(disks, tmp_path):
    lines = export_packing(disks, tmp_path / "p.xyz", "xyz").read_text().splitlines()
    assert int(lines[0]) == disks.n and len(lines) == disks.n + 2
    lattice = [float(v) for v in lines[1].split('Lattice="')[1].split('"')[0].split()]
    assert np.array_equal(np.reshape(lattice, (3, 3))[:2, :2], disks.box.h.T) and 'pbc="T T F"' in lines[1]
    assert "Properties=species:S:1:pos:R:3:radius:R:1" in lines[1]
    rows = np.array([[float(v) for v in line.split()[1:]] for line in lines[2:]])
    assert np.array_equal(rows[:, :2], disks.box.images(disks.positions)[0]) and np.all(rows[:, 2] == 0)
    assert np.array_equal(rows[:, 3], disks.diameters / 2)


def test_export_command(disks, tmp_path, capsys):
    src = save_packing(tmp_path / "p.h5", disks)
    assert main(["export", str(src), "--format", "xyz"]) == 0 and (tmp_path / "p.xyz").is_file()
    assert main(["export", str(src), "--format", "lammps-dump", "-o", str(tmp_path / "x.dump")]) == 0
    assert (tmp_path / "x.dump").read_text().startswith("ITEM: TIMESTEP")


def _random_oriented(shape, dim, seed=0):
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing
    from jamflow.model.shapes.rotations import random_orientations

    rng = np.random.default_rng(seed)
    return Packing(rng.uniform(0, 12.0, (6, dim)), rng.choice([1.0, 1.4], 6), Box(12.0 * np.eye(dim)),
                   shape=shape, orientations=random_orientations(6, dim, rng))


def _dump_table(path):
    lines = path.read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith("ITEM: ATOMS")) + 1
    names = lines[start - 1].split()[2:]
    return {name: np.array([float(row.split()[c]) for row in lines[start:]]) for c, name in enumerate(names)}


@pytest.mark.parametrize("dim", [2, 3])
def test_export_ellipsoids_axes_and_quaternions(dim, tmp_path):
    """Dump: full axes and (w, i, j, k) turning body x onto the director; XYZ: semi-axes, (x, y, z, w)."""
    from jamflow.model.shapes import parse_shape
    from jamflow.model.shapes.rotations import directors, quaternion_matrices

    p = _random_oriented(parse_shape("ellipse:1.5" if dim == 2 else "spheroid:0.5", dim), dim)
    t = _dump_table(export_packing(p, tmp_path / "e.dump", "lammps-dump"))
    a, b = p.shape.axes(p.diameters).T
    assert np.array_equal(t["shapex"], a) and np.array_equal(t["shapey"], b) and np.array_equal(t["shapez"], b)
    q = np.column_stack([t["quatw"], t["quati"], t["quatj"], t["quatk"]])
    assert np.allclose(quaternion_matrices(q)[:, :dim, 0], directors(p.orientations, dim), atol=1e-15)
    xyz = export_packing(p, tmp_path / "e.xyz", "xyz").read_text().splitlines()
    assert "aspherical_shape:R:3:orientation:R:4" in xyz[1] and f'shape="{p.shape.spec(dim)}"' in xyz[1]
    rows = np.array([[float(v) for v in line.split()[1:]] for line in xyz[2:]])
    assert np.array_equal(rows[:, 4:7], 0.5 * np.column_stack([a, b, b]))
    assert np.array_equal(rows[:, 7:11], q[:, [1, 2, 3, 0]])


@pytest.mark.parametrize("dim", [2, 3])
def test_export_rigid_bodies_one_row_per_site(dim, tmp_path):
    """Sites inside the box, at the body's world positions (whole about the wrapped centre) once their
    image flags are applied; site radii, body ids."""
    from jamflow.model.shapes import RigidBody

    sites = [[0, 0], [0.5, 0]] if dim == 2 else [[0, 0, 0], [0.5, 0, 0], [0.5, 0.4, 0]]
    p = _random_oriented(RigidBody(sites, [1.0, 0.7] if dim == 2 else [1.0, 1.0, 0.8]), dim)
    t = _dump_table(export_packing(p, tmp_path / "b.dump", "lammps-dump"))
    world = p.shape.world_sites(p.positions, p.orientations, p.diameters)
    shift = (p.box.wrap(p.positions) - p.positions)[:, None, :]
    pos = np.column_stack([t[c] for c in "xyz"[:dim]])
    image = np.column_stack([t[c] for c in ("ix", "iy", "iz")[:dim]])
    s = p.box.to_fractional(pos)
    assert np.all(s >= 0) and np.all(s < 1) and np.any(image != 0)
    assert np.allclose(pos + image @ p.box.h.T, (world + shift).reshape(-1, dim), atol=1e-12)
    assert np.array_equal(t["mol"], np.repeat(np.arange(1, p.n + 1), p.shape.n_sites))
    assert np.array_equal(t["radius"], (0.5 * p.diameters[:, None] * p.shape.site_diameters).ravel())
    assert "molecule:I:1" in export_packing(p, tmp_path / "b.xyz", "xyz").read_text().splitlines()[1]


def test_draw_ellipses_to_scale_along_their_directors(tmp_path):
    """Each ellipse image is drawn with its full axes a, b and the director's angle; 3D spheroids are refused."""
    from jamflow.plots.drawing import _elliptic
    from jamflow.model.shapes import parse_shape

    p = _random_oriented(parse_shape("ellipse:1.6", 2), 2)
    view = _View(p, 0.5)
    centres, _, owner = view.images()
    widths, heights, angles = _elliptic(view, owner)
    a, b = p.shape.axes(p.diameters).T
    k = view.index[owner]
    assert np.array_equal(widths, a[k]) and np.array_equal(heights, b[k])
    u = p.directors[k]
    assert np.allclose(np.cos(np.radians(angles)), u[:, 0]) and np.allclose(np.sin(np.radians(angles)), u[:, 1])
    assert draw_packing(p, tmp_path / "e.png", color_by="orientation").read_bytes()[:8] == PNG
    spheroids = _random_oriented(parse_shape("spheroid:1.5", 3), 3)
    with pytest.raises(ValueError, match="OVITO"):
        draw_packing(spheroids, tmp_path / "s.png")


@pytest.mark.parametrize("which", ["disks", "spheres"])
def test_export_command_lammps_data_reads_back(which, disks, spheres, tmp_path, capsys):
    """--format lammps-data writes the LAMMPS data file; the data reader gets positions,
    diameters and the box back to float32 round-off (MDAnalysis)."""
    from jamflow.io.readers import packing_from_lammps

    p = {"disks": disks, "spheres": spheres}[which]
    src = save_packing(tmp_path / "p.h5", p)
    assert main(["export", str(src), "--format", "lammps-data"]) == 0
    out = tmp_path / "p.data"
    assert "(lammps-data)" in capsys.readouterr().out and "Atoms # sphere" in out.read_text()
    back = packing_from_lammps(out, "data")
    assert back.dim == p.dim and back.n == p.n
    assert np.allclose(back.diameters, p.diameters, rtol=1e-6)
    assert np.allclose(back.box.h, p.box.h, rtol=1e-6)
    assert np.allclose(back.positions, p.box.wrap(p.positions), atol=1e-5)


@pytest.mark.parametrize("fmt", ["lammps-data", "lammps-dump"])
def test_draw_command_reads_lammps_files(fmt, disks, tmp_path, capsys):
    """draw reads LAMMPS data files and dumps as analyze does (jamflow.cli.inputs)."""
    from jamflow.io.export import SUFFIXES

    src = export_packing(disks, tmp_path / f"p{SUFFIXES[fmt]}", fmt)
    assert main(["draw", str(src), "-o", str(tmp_path / "p.png")]) == 0
    assert (tmp_path / "p.png").read_bytes()[:8] == PNG
    assert f"{src}: {disks.n} " in capsys.readouterr().out


@pytest.mark.parametrize("suffix, magic", [(".svg", b"<?xml"), (".pdf", b"%PDF"), (".png", b"\x89PNG")])
def test_draw_writes_the_format_its_suffix_asks_for(tmp_path, packing_file, suffix, magic):
    # was: PNG bytes in pic.svg and pic.pdf
    out = tmp_path / f"pic{suffix}"
    assert main(["draw", str(packing_file), "-o", str(out)]) == 0
    assert out.read_bytes().startswith(magic)


def test_draw_refuses_a_suffix_it_cannot_write(tmp_path, capsys, packing_file, monkeypatch):
    monkeypatch.setattr("jamflow.cli.commands.draw.load_input", lambda *a: pytest.fail("work started"))
    code = main(["draw", str(packing_file), "-o", str(tmp_path / "pic.jpg")])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and "not .jpg" in err and list(tmp_path.iterdir()) == []
