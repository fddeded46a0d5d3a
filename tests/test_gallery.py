"""The gallery (docs/gallery.md, made by docs/gallery/make_gallery.py) and the plotting functions
it added: every chapter figure the script makes is shown on the page with its code, and the
figures draw the data they are given."""

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

import jamflow
from jamflow.plots import anneal as anneal_plots
from jamflow.plots import compression as compression_plots

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.fixture(scope="module")
def gallery():
    spec = importlib.util.spec_from_file_location("make_gallery", DOCS / "gallery" / "make_gallery.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_gallery_figure_is_shown_with_its_code(gallery):
    page = (DOCS / "gallery.md").read_text()
    shown = re.findall(r":pyobject: (figure_[0-9_]+)", page)
    assert sorted(shown) == sorted(f.__name__ for f in gallery.FIGURES.values())
    headed = re.findall(r"^## Figure (2\.[0-9]+)", page, re.M)
    assert headed == list(gallery.FIGURES)
    for image in re.findall(r"gallery/images/fig-(2-[0-9]+)[a-z]?\.png", page):
        assert image.replace("-", ".") in gallery.FIGURES
    assert set(gallery.SLOW) <= set(gallery.FIGURES)


def test_gallery_makes_figure_2_3(gallery, tmp_path):
    assert gallery.main(["--only", "2.3", "--out", str(tmp_path), "--jobs", "1"]) == 0
    assert (tmp_path / "fig-2-3.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _captured(monkeypatch, module):
    """The matplotlib figure ``module`` would save, instead of a file."""
    saved = {}
    monkeypatch.setattr(module, "save_figure", lambda fig, path, **kw: saved.setdefault("fig", fig) and Path(path))
    return saved


def test_compression_figure_draws_the_history(monkeypatch, tmp_path):
    res = jamflow.jam(n=16, seed=3)
    saved = _captured(monkeypatch, compression_plots)
    compression_plots.compression_figure(tmp_path / "c.png", res)
    phi_axes, energy_axes = saved["fig"].axes
    x, y = phi_axes.lines[0].get_data()
    np.testing.assert_array_equal(x, np.arange(1, res.minimizations + 1))
    np.testing.assert_array_equal(y, res.history["phi"])
    assert phi_axes.lines[1].get_ydata()[0] == res.phi_j
    energy = energy_axes.lines[0].get_ydata()
    assert energy[-1] == res.history["energy_per_particle"][-1]
    assert res.settings.v_tol < energy[-1] < 2 * res.settings.v_tol


def test_anneal_figure_draws_each_protocol(monkeypatch, tmp_path):
    saved = _captured(monkeypatch, anneal_plots)
    series = {"compression": ([1.0, 1.2], [3.9, 5.0], [0.1, 0.1], [0.84, 0.87], [0.01, 0.01]),
              "anneal 0.05": ([1.0, 1.05, 1.1], [3.9, 4.4, 4.8], [0.1, 0.1, 0.1], [0.84, 0.85, 0.86], [0, 0, 0])}
    anneal_plots.anneal_figure(tmp_path / "a.png", series)
    z_axes, phi_axes = saved["fig"].axes
    for label, (alpha, z, _, phi, _) in series.items():
        for ax, y in ((z_axes, z), (phi_axes, phi)):
            line = next(c.lines[0] for c in ax.containers if c.get_label() == label)
            np.testing.assert_array_equal(line.get_xdata(), alpha)
            np.testing.assert_array_equal(line.get_ydata(), y)
    assert [line.get_ydata()[0] for line in z_axes.lines if line.get_linestyle() == ":"] == [4, 6]
