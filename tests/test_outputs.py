"""Outputs that compose: one naming rule for derived files (``jamflow.io.names``),
directories read without their result files."""

import csv
from pathlib import Path

import numpy as np
import pytest

from jamflow.analysis.modes import Spectrum
from jamflow.cli.app import main
from jamflow.io.packing_file import load_packing
from jamflow.mechanics.contacts import Contacts
from test_python_api import _one_short_line
from jamflow.io.names import derived_path, is_derived, packing_files


@pytest.fixture(scope="module")
def above(tmp_path_factory):
    """A packing 1e-3 above its onset (moduli needs one), alone in its directory."""
    out = tmp_path_factory.mktemp("above") / "p.h5"
    assert main(["jam", "--n", "16", "--seed", "2", "--above", "1e-3", "--out", str(out), "--quiet"]) == 0
    return out


def test_derived_names_follow_one_rule(tmp_path):
    assert derived_path("a/p.h5", "modes") == Path("a/p.modes.h5")
    assert derived_path(Path("a/final.data"), "structure", ".png") == Path("a/final.structure.png")
    assert derived_path(["a/p.h5", "a/q.h5"], "modes", ".png") == Path("a/a.modes.png")
    assert derived_path(tmp_path, "structure") == tmp_path / f"{tmp_path.name}.structure.h5"
    (tmp_path / "x").mkdir()
    assert derived_path([tmp_path / "x" / "p.h5", tmp_path / "q.h5"], "modes") == tmp_path / f"{tmp_path.name}.modes.h5"
    with pytest.raises(ValueError, match="unknown derived file kind"):
        derived_path("p.h5", "pictures")
    assert [is_derived(n) for n in ("p.modes.h5", "p.moduli.h5", "p.structure.h5", "p.shear.h5", "p.modes.hdf5",
                                    "p.h5", "modes.h5", "p.data", "n64_seed000001.h5")] == [True] * 5 + [False] * 4
    for name in ("b.h5", "a.h5", "a.moduli.h5", "a.modes.h5", "a.modes.png", "notes.txt"):
        (tmp_path / name).write_bytes(b"")
    assert [p.name for p in packing_files(tmp_path)] == ["a.h5", "b.h5"]


def test_moduli_then_modes_and_analyze_of_the_directory(above, capsys):
    """Was: `jamflow moduli p.h5` wrote p.moduli.h5 beside it, after which `jamflow modes DIR`
    aborted on it ("not a jamflow packing file"); `modes` wrote p.modes.hdf5 and `analyze`
    structure.h5 in the working directory."""
    folder = above.parent
    assert main(["moduli", str(above), "--min-amplitude", "1e-8", "--max-amplitude", "1e-6", "--no-figure",
                 "--quiet"]) == 0
    assert main(["modes", str(folder), "--no-figure"]) == 0
    assert main(["analyze", str(folder), "--r-min", "1.4"]) == 0
    assert main(["modes", str(folder), "--no-figure"]) == 0  # again, with the modes and structure files there
    out = capsys.readouterr().out
    assert out.count("1 packing(s)") == 3
    made = sorted(p.name for p in folder.iterdir() if p.suffix == ".h5")
    assert made == sorted(["p.h5", "p.moduli.h5", "p.modes.h5", f"{folder.name}.structure.h5"])
    assert main(["analyze", str(above), "--r-min", "1.4"]) == 0 and (folder / "p.structure.h5").is_file()
    assert (folder / "p.structure-rdf.png").is_file()


def test_result_files_matched_by_a_shell_glob_are_skipped(above, capsys):
    """`jamflow modes runs/*.h5` a second time also lists runs/p.modes.h5: it is skipped with a
    warning, not refused as "not a jamflow packing file"; results alone are refused in one line."""
    folder = above.parent
    assert main(["modes", str(above), "--no-figure"]) == 0
    capsys.readouterr()
    assert main(["modes", *sorted(str(p) for p in folder.glob("*.h5")), "--no-figure"]) == 0
    out, err = capsys.readouterr()
    assert "1 packing(s)" in out and "warning: skipped" in err and "result file(s)" in err
    assert main(["modes", str(folder / "p.modes.h5")]) == 2
    err = capsys.readouterr().err
    assert "is a result file" in err and len(err.strip().splitlines()) == 1


def test_an_explicit_out_is_kept(above, tmp_path):
    assert main(["analyze", str(above), "--r-min", "1.4", "--out", str(tmp_path / "structure.h5")]) == 0
    assert (tmp_path / "structure.h5").is_file() and (tmp_path / "structure-rdf.png").is_file()


# --- pooled results of `jamflow modes` as data beside the figure ------------------------------


@pytest.fixture(scope="module")
def two_jammed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("store")
    for seed in (1, 2):
        assert main(["jam", "--n", "32", "--seed", str(seed), "--out", str(folder / f"p{seed}.h5"), "--quiet"]) == 0
    return folder


def _read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_modes_writes_pooled_dos_z_and_floaters_as_data(two_jammed, monkeypatch):
    """Was: pooled D(omega), <z> and floater fraction only as a picture, y axis "per packing"
    unnormalised, omega's M and unit not on the axis. The CSVs hold what the figure draws; checked
    against the contacts counted directly (2 N_c / N', the chapter's <z>) and the mode counts."""
    import jamflow.plots.modes as plots_modes

    drawn = {}
    save = plots_modes.save_figure
    monkeypatch.setattr(plots_modes, "save_figure", lambda fig, path: drawn.setdefault("fig", fig) and save(fig, path))
    assert main(["modes", str(two_jammed), "--bins", "12"]) == 0
    stem = two_jammed / f"{two_jammed.name}.modes"
    dos = _read_csv(f"{stem}-dos.csv")
    table = _read_csv(f"{stem}-packings.csv")
    low, high = (np.array([float(r[k]) for r in dos]) for k in ("omega_low", "omega_high"))
    d, per_packing = (np.array([float(r[k]) for r in dos]) for k in ("D", "D_per_packing"))
    packings = [load_packing(two_jammed / f"p{s}.h5") for s in (1, 2)]
    contacts = [Contacts().compute(p) for p in packings]
    modes = sum(len(Spectrum().compute(p).frequencies) for p in packings)
    assert len(dos) == 12 and np.sum(d * (high - low)) == pytest.approx(1.0, rel=1e-12)
    assert np.sum(per_packing * (high - low)) == pytest.approx(modes / 2, rel=1e-12)
    pooled = table[-1]
    assert [r["file"] for r in table] == [str(two_jammed / "p1.h5"), str(two_jammed / "p2.h5"), "pooled"]
    kept = sum(c.n_kept for c in contacts)
    assert float(pooled["mean_z"]) == pytest.approx(2 * sum(c.n_contacts for c in contacts) / kept, rel=1e-12)
    assert float(pooled["floater_fraction"]) == pytest.approx(sum(c.n_floaters for c in contacts) / 64, abs=0)
    assert int(pooled["n"]) == 64 and float(table[0]["mass"]) == 32.0
    ax_dos = drawn["fig"].axes[1]
    values, edges = ax_dos.patches[0].get_data()[:2]
    assert np.allclose(values, d) and np.allclose(edges[:-1], low)
    assert "M = N m" in ax_dos.get_xlabel() and r"\sqrt{\epsilon/(m\sigma^2)}" in ax_dos.get_xlabel()
    assert r"\int D\,d\omega = 1" in ax_dos.get_ylabel()
    assert f"{float(pooled['mean_z']):.4f}" in drawn["fig"].axes[2].texts[0].get_text()


def test_modes_mass_goes_on_the_axis(two_jammed, tmp_path, monkeypatch):
    import jamflow.plots.modes as plots_modes

    drawn = {}
    save = plots_modes.save_figure
    monkeypatch.setattr(plots_modes, "save_figure", lambda fig, path: drawn.setdefault("fig", fig) and save(fig, path))
    assert main(["modes", str(two_jammed / "p1.h5"), "--mass", "1", "--figure", str(tmp_path / "m.png")]) == 0
    assert "M = 1 m" in drawn["fig"].axes[1].get_xlabel()
    assert (tmp_path / "m-dos.csv").is_file() and (tmp_path / "m-packings.csv").is_file()


def test_store_summary_skips_results_written_into_the_store(tmp_path):
    """Was: `jamflow modes STORE` wrote n8_seed000000.modes.hdf5 (now .modes.h5) into the store and
    Store.rebuild_summary took every *.h5 for a packing ("not a store file name")."""
    import json

    from jamflow.ensemble import Store

    store = tmp_path / "store"
    store.mkdir()
    (store / "ensemble.json").write_text(json.dumps({"schema": "jamflow.ensemble", "schema_version": 1,
                                                     "axes": ["n"], "parameters": {}}))
    assert main(["jam", "--n", "8", "--seed", "0", "--out", str(store / "n8_seed000000.h5"), "--quiet"]) == 0
    assert main(["modes", str(store), "--no-figure"]) == 0 and (store / "n8_seed000000.modes.h5").is_file()
    rows = _read_csv(Store(store).rebuild_summary())
    assert [(r["n"], r["seed"], r["status"]) for r in rows] == [("8", "0", "ok")]


# --- HOOMD GSD export, read back with gsd.hoomd and freud ----------------------------------------


def _gsd_frame(path):
    import gsd.hoomd

    with gsd.hoomd.open(str(path), "r") as f:
        assert len(f) == 1
        return f[0]


@pytest.mark.parametrize("gamma", [0.0, 0.3, 1.3])
def test_gsd_export_of_a_sheared_packing_reads_back(tmp_path, capsys, gamma):
    """Box with HOOMD's tilt factor xy = gamma (accumulated, not folded), origin-centred positions;
    freud (a second reader of HOOMD's convention) gives the file's fractional coordinates."""
    import freud

    from conftest import random_config, tilted
    from jamflow.io.packing_file import save_packing

    p = tilted(random_config(24, 2, 0.8, seed=3, diameters=np.repeat([1.0, 1.4], 12)), gamma)
    src = save_packing(tmp_path / "p.h5", p)
    assert main(["export", str(src), "--format", "gsd"]) == 0
    assert "p.gsd (gsd)" in capsys.readouterr().out
    frame = _gsd_frame(tmp_path / "p.gsd")
    q = load_packing(src)
    lx, ly, lz, xy, xz, yz = frame.configuration.box
    assert frame.configuration.dimensions == 2 and lz == 0 and xz == yz == 0
    assert (lx, ly, xy) == pytest.approx((q.box.h[0, 0], q.box.h[1, 1], gamma), rel=1e-7, abs=1e-7)
    fractional = freud.box.Box.from_box(frame.configuration.box, dimensions=2).make_fractional(frame.particles.position)
    expected = q.box.to_fractional(q.positions) % 1.0
    assert np.all(fractional[:, :2] >= 0) and np.all(fractional[:, :2] < 1)
    diff = fractional[:, :2] - expected
    assert np.abs(diff - np.round(diff)).max() < 1e-6  # float32 positions
    assert np.allclose(frame.particles.diameter, q.diameters, rtol=1e-7)
    assert frame.particles.types == ["A", "B"] and np.array_equal(frame.particles.typeid, (q.diameters > 1).astype(int))
    assert np.array_equal(frame.particles.body, np.full(24, -1))


@pytest.mark.parametrize("spec,dim", [("ellipse:1.5", 2), ("spheroid:0.5", 3)])
def test_gsd_export_orientations_and_shapes(tmp_path, spec, dim):
    """Quaternions (w, x, y, z) turn body x onto each director; Ellipsoid semi-axes per type."""
    from jamflow.io.export import export_packing
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing
    from jamflow.model.shapes import parse_shape
    from jamflow.model.shapes.rotations import directors, quaternion_matrices, random_orientations

    rng = np.random.default_rng(1)
    p = Packing(rng.uniform(0, 12.0, (6, dim)), np.array([1.0, 1.4, 1.0, 1.4, 1.4, 1.0]), Box(12.0 * np.eye(dim)),
                shape=parse_shape(spec, dim), orientations=random_orientations(6, dim, rng))
    frame = _gsd_frame(export_packing(p, tmp_path / "e.gsd", "gsd"))
    q = frame.particles.orientation.astype(float)
    assert np.allclose(quaternion_matrices(q / np.linalg.norm(q, axis=1)[:, None])[:, :dim, 0],
                       directors(p.orientations, dim), atol=1e-6)
    a, b = p.shape.axes(p.diameters).T
    shapes = frame.particles.type_shapes
    assert [s["type"] for s in shapes] == ["Ellipsoid"] * 2
    assert [shapes[0]["a"], shapes[0]["b"], shapes[1]["a"], shapes[1]["c"]] == pytest.approx(
        [a[0] / 2, b[0] / 2, a[1] / 2, b[1] / 2])


def test_gsd_export_rigid_bodies_as_centres_and_sites(tmp_path):
    from jamflow.io.export import export_packing
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing
    from jamflow.model.shapes import RigidBody
    from jamflow.model.shapes.rotations import random_orientations

    rng = np.random.default_rng(2)
    p = Packing(rng.uniform(0, 10.0, (5, 2)), np.ones(5), Box(10.0 * np.eye(2)), shape=RigidBody([[0, 0], [0.5, 0]],
                [1.0, 0.7]), orientations=random_orientations(5, 2, rng))
    frame = _gsd_frame(export_packing(p, tmp_path / "b.gsd", "gsd"))
    body = frame.particles.body
    assert frame.particles.N == 15 and np.array_equal(body, np.concatenate([np.arange(5), np.repeat(np.arange(5), 2)]))
    assert frame.particles.types == ["A", "site"] and np.array_equal(frame.particles.typeid, [0] * 5 + [1] * 10)
    pos = frame.particles.position.astype(float)[:, :2]
    unwrapped = pos + frame.particles.image[:, :2] @ p.box.h.T  # HOOMD's box is h, centred on the origin
    world = p.shape.world_sites(p.positions, p.orientations, p.diameters) - p.positions[:, None, :]
    assert np.allclose(unwrapped[5:] - unwrapped[body[5:]], world.reshape(-1, 2), atol=1e-5)
    assert np.all(np.abs(pos) < 5.0 + 1e-6)
    assert np.allclose(frame.particles.diameter[5:], np.tile([1.0, 0.7], 5))


def test_gsd_export_without_the_package_names_the_extra(tmp_path, capsys, monkeypatch):
    import sys

    from jamflow.io.packing_file import save_packing
    from test_contacts import triangular_lattice

    src = save_packing(tmp_path / "p.h5", triangular_lattice(4, 4, 0.97))
    monkeypatch.setitem(sys.modules, "gsd", None)
    monkeypatch.setitem(sys.modules, "gsd.hoomd", None)
    assert main(["export", str(src), "--format", "gsd"]) == 2
    err = capsys.readouterr().err
    assert "jamflow[gsd]" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "p.gsd").exists()


# --- one-line reprs of the remaining result types ---------------------------------------------


def test_result_reprs_are_one_short_line():
    """Was (N = 256, /tmp measurement in the report): ShearPath 79383 characters, ShearStep 26262,
    RDFResult 35522, ReferenceResult 19755, BondOrderResult 9692, ModuliResult 2765, AboveResult
    583, CompressionSettings 504, ..."""
    from jamflow.analysis.correlations import BondCorrelation
    from jamflow.analysis.order import BondOrder
    from jamflow.analysis.structure import RDF, StructureFactor
    from jamflow.mechanics.elastic import HessianModuli
    from jamflow.mechanics.reference import energy_forces_pressure
    from jamflow.protocols.above import compress_above
    from jamflow.protocols.compression import jam
    from jamflow.protocols.moduli import Moduli
    from jamflow.protocols.shear import shear
    from jamflow.protocols.sweeps import SweepSettings

    start = jam(n=16, dim=2, sizes="bi:1.4:0.5", seed=2)
    above = compress_above(start.packing, 1e-3)
    _one_short_line(above, "AboveResult(N=16", "dim=2", f"phi={above.packing.phi:.10f}", "dphi=0.001",
                    f"P={above.pressure:.3e}")
    path = shear(above.packing, 1e-4, 2e-4)
    _one_short_line(path, "ShearPath(N=16", "steps=2", f"changes={path.n_changes}")
    step = path.steps[-1]
    _one_short_line(step, "ShearStep(gamma=0.0002", "N=16", f"phi_j={step.phi_j:.10f}",
                    f"contacts={len(step.network.i)}", f"removed={len(step.removed)}")
    _one_short_line(step.network, f"Network(contacts={len(step.network.i)}, floaters={step.network.n_floaters})")
    p = start.packing
    rdf = RDF().compute(p)
    _one_short_line(rdf, f"RDFResult(bins={len(rdf.g)}", "n_packings=1", f"peak_g={rdf.g.max():.4g}")
    _one_short_line(StructureFactor(k_max=8).compute(p), "StructureFactorResult(shells=", "n_packings=1")
    order = BondOrder(r_min=1.4).compute(p)
    _one_short_line(order, "BondOrderResult(l=6", f"global_order={order.global_order:.4f}", "N=16")
    corr = BondCorrelation(r_min=1.4).compute(p)
    _one_short_line(corr, "BondCorrelationResult(l=6", "n_packings=1")
    _one_short_line(corr.fit, "ExponentialFit(xi=")
    ref = energy_forces_pressure(p)
    _one_short_line(ref, "ReferenceResult(N=16", "dim=2", f"P={ref.pressure:.4e}")
    _one_short_line(HessianModuli().compute(above.packing), "HessianModuliResult(G=")
    moduli = Moduli(SweepSettings(amplitudes=(1e-8, 1e-7))).compute(above.packing)
    _one_short_line(moduli, "ModuliResult(N=16", f"G={moduli.G:.6e}", f"B_hessian={moduli.B_hessian:.6e}")
    _one_short_line(moduli.shear, "SweepResult(strain='shear'", f"modulus={moduli.shear.modulus:.6e}")


def test_settings_reprs_name_what_differs_and_rebuild():
    from jamflow.minimize.settings import MinimizerSettings
    from jamflow.protocols.pressure import PressureSettings
    from jamflow.protocols.settings import CompressionSettings
    from jamflow.protocols.sweeps import SweepSettings

    assert repr(CompressionSettings()) == "CompressionSettings()"
    custom = CompressionSettings(v_tol=1e-14, minimizer=MinimizerSettings(force_tol=1e-13))
    text = _one_short_line(custom, "v_tol=1e-14", "minimizer=MinimizerSettings(force_tol=1e-13)")
    assert eval(text, {"CompressionSettings": CompressionSettings, "MinimizerSettings": MinimizerSettings}) == custom
    assert repr(PressureSettings(pressures=(1e-4, 1e-5))) == "PressureSettings(pressures=(0.0001, 1e-05))"
    assert repr(SweepSettings()) == "SweepSettings()"


def test_anneal_nematic_and_onset_reprs():
    from jamflow.ensemble.onsets import onset_statistics
    from jamflow.model.nematic import Nematic
    from jamflow.protocols.anneal import anneal
    from jamflow.protocols.compression import jam

    start = jam(n=12, dim=2, sizes="bi:1.4:0.5", seed=1, shape="ellipse:1.0")
    res = anneal(start.packing, 1.05, 0.05)
    _one_short_line(res, "AnnealResult(N=12", "shape='ellipse:1.05'", "steps=1", f"phi_j={res.final.phi_j:.10f}")
    _one_short_line(Nematic().compute(np.zeros(10)), "NematicResult(p2=1.0000, director=[1.0, 0.0])")
    rows = [dict(n=str(n), seed=str(s), status="ok", phi_j=str(0.84 - 0.1 / n + 0.01 * np.sin(s * n)), mean_z="4.0",
                 dim="2", floaters="0", n_contacts=str(2 * n - 1)) for n in (16, 32, 64) for s in range(10)]
    _one_short_line(onset_statistics(rows, n_bootstrap=20), "OnsetResult(dim=2, n=[16, 32, 64]", "n_bootstrap=20")


# --- figures: checked on their data, not their pixels ----------------------------------------


@pytest.fixture
def drawn(monkeypatch):
    """The matplotlib figures the structure plots save (``plots.figure.save_figure`` wrapped)."""
    import jamflow.plots.structure as plots_structure

    figures = []
    save = plots_structure.save_figure
    monkeypatch.setattr(plots_structure, "save_figure", lambda fig, path, **kw: figures.append(fig) or save(fig, path, **kw))
    return figures


@pytest.fixture(scope="module")
def bidisperse():
    from jamflow.protocols.compression import jam

    return jam(n=64, dim=2, sizes="bi:1.4:0.5", seed=4).packing


def test_rdf_figure_shows_every_peak_and_the_total_on_top(bidisperse, drawn, tmp_path):
    """Was: ylim at 1.05 x the total's first peak (16 here) cut the partials' higher peaks, and the
    total was drawn under them."""
    from jamflow.analysis.structure import RDF
    from jamflow.plots.structure import plot_rdf

    rdf = RDF(partial=True).compute(bidisperse)
    plot_rdf(rdf, tmp_path / "rdf.png", r_min=1.4)
    ax = drawn[0].axes[0]
    curves = [line for line in ax.get_lines() if len(line.get_xdata()) == len(rdf.r)]
    assert len(curves) == 4  # three partials and the total
    highest = max(np.nanmax(line.get_ydata()) for line in curves)
    assert highest > rdf.g.max() and ax.get_ylim()[1] >= highest
    total = next(line for line in curves if np.array_equal(line.get_ydata(), rdf.g))
    assert all(total.get_zorder() > line.get_zorder() for line in curves if line is not total)


def test_q6_map_has_a_colour_key_matching_its_colours(bidisperse, drawn, tmp_path):
    """Was: disks coloured by the phase of psi_6 without a key."""
    from jamflow.analysis.order import BondOrder
    from jamflow.plots.structure import plot_bond_order_map

    order = BondOrder(r_min=1.4).compute(bidisperse)
    plot_bond_order_map(bidisperse, order, tmp_path / "q6.png")
    fig = drawn[0]
    assert len(fig.axes) == 2  # the map and its colour bar
    bar_ax = fig.axes[1]
    assert "arg psi_6" in bar_ax.get_ylabel()
    disks = fig.axes[0].collections[0]
    key = next(c for c in bar_ax.collections if c.norm.vmin is not None)  # the bar's colours: norm and map
    assert key.norm.vmin == -180 and key.norm.vmax == 180 and key.cmap.name == "hsv"
    psi = order.particle_order[:, 0]
    has = order.n_neighbours > 0
    assert np.allclose(disks.get_facecolor()[has, :3], key.to_rgba(np.degrees(np.angle(psi)))[has, :3])


def test_order_figure_has_one_bar_per_parameter(drawn, tmp_path):
    """Was: three dots against one file name; now one bar per order parameter at its mean."""
    from jamflow.plots.structure import plot_order

    values = {"Q6_global": np.array([0.1, 0.3]), "Q6_local": np.array([0.5, 0.7]), "G": np.array([0.02, 0.04])}
    plot_order(["a.h5", "b.h5"], values, tmp_path / "order.png")
    ax = drawn[0].axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == list(values)
    assert [patch.get_height() for patch in ax.patches] == pytest.approx([0.2, 0.6, 0.03])


def test_bodies_are_joined_in_the_picture():
    """Was: dimers drawn as loose disks, nothing showing which two form a body."""
    from matplotlib.figure import Figure

    from jamflow.plots.drawing import _View, draw_into
    from jamflow.protocols.compression import jam

    dimers = jam(n=16, dim=2, sizes="bi:1.4:0.5", shape="nmer:2:1.5", seed=1).packing
    view = _View(dimers, 0.5)
    bonds = view.body_lines()
    offsets = dimers.shape.world_sites(dimers.positions, dimers.orientations, dimers.diameters)
    length = np.linalg.norm(offsets[:, 1] - offsets[:, 0], axis=1)
    assert len(bonds) == 2 * dimers.n
    assert np.allclose(np.linalg.norm(bonds[:, 1] - bonds[:, 0], axis=1), np.tile(length, 2))
    ax = Figure().subplots()
    draw_into(ax, dimers, color_by="orientation")
    assert [c.get_label() for c in ax.collections if c.get_label() == "bodies"] == ["bodies"]


def test_slice_contact_lines_stay_in_their_cross_sections():
    """Was: in a 3D slice each contact line ran centre to centre across the gap between two
    cross-sections (the contact point lies off the plane): 23 of 23 at this packing."""
    from jamflow.plots.drawing import _View
    from jamflow.protocols.compression import jam

    spheres = jam(n=64, dim=3, sizes="mono", seed=1).packing
    view = _View(spheres, 0.5)
    lines, widths, _ = view.contact_lines()
    assert len(lines) > 10
    radius = np.zeros(spheres.n)
    radius[view.index] = 0.5 * view.sizes
    ends = lines[:, 1] - lines[:, 0]
    starts = lines[:, 0]
    owner = np.array([np.argmin(np.linalg.norm(view.xy - s, axis=1)) for s in starts])
    assert np.allclose(view.xy[owner], starts)
    assert np.all(np.linalg.norm(ends, axis=1) <= radius[owner] + 1e-12)  # inside its own cross-section


@pytest.mark.parametrize("spec,dim", [("disk", 2), ("ellipse:1.5", 2), ("spheroid:0.5", 3)])
def test_gsd_files_that_export_writes_read_back(tmp_path, spec, dim):
    """``packings_from_gsd`` inverts ``export --format gsd`` to float32 precision: box (with tilt),
    positions, diameters, shape and orientations."""
    from conftest import random_config, tilted
    from jamflow.io.export import export_packing
    from jamflow.io.gsd_file import packings_from_gsd
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing
    from jamflow.model.shapes import parse_shape
    from jamflow.model.shapes.rotations import random_orientations

    rng = np.random.default_rng(4)
    if spec == "disk":
        p = tilted(random_config(24, 2, 0.8, seed=3, diameters=np.repeat([1.0, 1.4], 12)), 0.3)
    else:
        p = Packing(rng.uniform(0, 12.0, (6, dim)), np.array([1.0, 1.4, 1.0, 1.4, 1.4, 1.0]), Box(12.0 * np.eye(dim)),
                    shape=parse_shape(spec, dim), orientations=random_orientations(6, dim, rng))
    (q,) = packings_from_gsd(export_packing(p, tmp_path / "p.gsd", "gsd"))
    assert q.dim == dim and q.shape.spec(dim) == p.shape.spec(dim) and q.n == p.n
    assert np.allclose(q.box.h, p.box.h, rtol=1e-6, atol=1e-6)
    assert np.abs(p.box.minimum_image(q.positions - p.positions)).max() < 1e-5
    assert np.allclose(q.diameters, p.diameters, rtol=1e-6)
    if dim == 2 and p.orientations is not None:
        turn = np.asarray(q.orientations) - np.asarray(p.orientations)
        assert np.abs(np.angle(np.exp(1j * turn))).max() < 1e-6
    elif p.orientations is not None:
        dots = np.abs(np.sum(np.asarray(q.orientations) * np.asarray(p.orientations), axis=1))
        assert np.allclose(dots, 1.0, atol=1e-6)  # q and -q are one rotation


def test_modes_analyze_and_draw_read_the_gsd_file_export_wrote(above, tmp_path, capsys):
    gsd = tmp_path / "p.gsd"
    assert main(["export", str(above), "--format", "gsd", "-o", str(gsd)]) == 0
    assert main(["modes", str(gsd), "--no-figure"]) == 0
    out = capsys.readouterr().out
    assert "1 packing(s)" in out and (tmp_path / "p.modes.h5").is_file()
    assert main(["draw", str(gsd), "-o", str(tmp_path / "p.png")]) == 0 and (tmp_path / "p.png").stat().st_size > 0
    from jamflow.cli.inputs import load_input

    assert load_input(gsd).metadata["coordinate_precision"] == "float32 (GSD)"


def test_a_gsd_file_of_rigid_bodies_is_refused_with_the_reason(tmp_path):
    from jamflow.io.export import export_packing
    from jamflow.io.gsd_file import packings_from_gsd
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing
    from jamflow.model.shapes import RigidBody
    from jamflow.model.shapes.rotations import random_orientations

    rng = np.random.default_rng(2)
    p = Packing(rng.uniform(0, 10.0, (5, 2)), np.ones(5), Box(10.0 * np.eye(2)), shape=RigidBody([[0, 0], [0.5, 0]],
                [1.0, 0.7]), orientations=random_orientations(5, 2, rng))
    with pytest.raises(ValueError, match="rigid bodies in a GSD file are not read back"):
        packings_from_gsd(export_packing(p, tmp_path / "b.gsd", "gsd"))
    (tmp_path / "x.gsd").write_bytes(b"not a gsd file")
    with pytest.raises(ValueError, match="is not a GSD file"):
        packings_from_gsd(tmp_path / "x.gsd")
