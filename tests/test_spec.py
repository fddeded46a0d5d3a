"""The jam specification (jamflow.protocols.spec.JamSpec): the library API that `jamflow jam` and
`jamflow ensemble` share. Its fields are the command's options, with the command's defaults; it
refuses what it does not know before any work; run through the library or the command line, one
spec gives the same packing."""

import argparse
import json
import re

import numpy as np
import pytest

from jamflow.cli.app import build_parser
from jamflow.cli.commands.jam import spec_from_args
from jamflow.cli.options import add_spec_arguments
from jamflow.io.packing_file import load_packing
from jamflow.protocols.spec import JamSpec, prepare, run_jam

CLI_ONLY = {"out", "force", "quiet", "emit_deck", "threads", "command", "run"}


def test_the_spec_has_every_jam_option_with_its_default():
    args = build_parser("jam").parse_args(["jam"])
    options = {k: v for k, v in vars(args).items() if k not in CLI_ONLY}
    assert options == JamSpec().as_dict()


def test_the_ensemble_declares_the_same_options_but_n_seed_and_above():
    p = argparse.ArgumentParser()
    add_spec_arguments(p, skip=("n", "seed", "above"))
    assert set(vars(p.parse_args([]))) == set(JamSpec.option_names()) - {"n", "seed", "above"}


def test_unknown_options_are_refused_with_the_known_ones():
    with pytest.raises(ValueError, match="unknown jam option.*vtoll.*use names of `jamflow jam --help`.*vtol"):
        JamSpec.from_options(vtoll=1e-16)


@pytest.mark.parametrize("options,message", [
    (dict(vtol=-1.0), "--vtol must be a finite positive number"),
    (dict(engine="gpu"), "--engine 'gpu' is not one of"),
    (dict(pressure=1e-3, walls="y"), "does not combine with --walls"),
    (dict(gamma=0.5, pressure=1e-3), "use one of them"),
    (dict(contact="gaussian"), "applies to ellipses/spheroids"),
    (dict(orientations="aligned"), "--orientations aligned applies to particles with an axis.*not to disks"),
    (dict(orientations="sideways", shape="ellipse:2"), "--orientations 'sideways' is not one of random, aligned"),
    (dict(orientations="nematic:0.5"), "--orientations nematic:0.5 applies to particles with an axis.*not to disks"),
    *[(dict(orientations=bad, shape="ellipse:2"), rf"--orientations '{bad}' is not one of random, aligned, nematic:S "
       r"with the start's nematic order S in \(0, 1\]")
      for bad in ("nematic:0", "nematic:-0.2", "nematic:1.5", "nematic:nan", "nematic:abc", "nematic:", "nematic")],
])
def test_prepare_refuses_bad_specs_before_work(options, message, monkeypatch):
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(ValueError, match=message):
        prepare(JamSpec(n=16, **options))


def test_a_spec_survives_json():
    spec = JamSpec(n=32, shape="ellipse:1.6", sizes="mono", walls="y", gamma=None, seed=5)
    assert JamSpec(**json.loads(json.dumps(spec.as_dict()))) == spec


def test_library_and_command_line_make_the_same_packing(tmp_path):
    spec = JamSpec(n=32, seed=4)
    result, checks = run_jam(spec)
    assert checks.passed
    args = build_parser("jam").parse_args(["jam", "--n", "32", "--seed", "4", "--out", str(tmp_path / "p.h5"), "--quiet"])
    assert spec_from_args(args) == spec
    assert args.run(args) == 0
    written = load_packing(tmp_path / "p.h5")
    assert np.array_equal(written.positions, result.packing.positions)  # files hold the packing, bit for bit


def test_the_protocols_are_chapter_and_fast_and_another_name_is_refused_before_work(capsys):
    """The chapter's protocol is "chapter" ("seed" named both it and the random seed, and is no
    longer a protocol name): an unknown name is refused with the names to use, before any work."""
    from jamflow.cli.app import main
    from jamflow.protocols.settings import PROTOCOLS, protocol_settings

    assert sorted(PROTOCOLS) == ["chapter", "fast"]
    for name in ("slow", "seed"):
        with pytest.raises(ValueError, match=f"unknown protocol '{name}'; use one of chapter, fast"):
            protocol_settings(name)
        with pytest.raises(ValueError, match=f"--protocol '{name}' is not one of chapter, fast"):
            prepare(JamSpec(protocol=name))
    with pytest.raises(SystemExit):
        main(["jam", "--help"])
    jam_help = " ".join(capsys.readouterr().out.split())
    assert "--protocol {chapter,fast}" in jam_help and "old name" not in jam_help
    with pytest.raises(SystemExit):
        build_parser("jam").parse_args(["jam", "--protocol", "seed"])
    assert re.search(r"choose from '?chapter'?, '?fast'?", capsys.readouterr().err)


@pytest.mark.parametrize("dim,shape", [(2, "ellipse:3"), (3, "spheroid:2"), (2, "nmer:2:2"), (3, "nmer:3:2")])
def test_an_aligned_start_has_every_director_along_x(dim, shape):
    """--orientations aligned (Figure 2.23(c)): a nematic start, P2 = 1 along x. Ellipses and
    spheroids keep the random start's positions and sizes (orientations are drawn last)."""
    from jamflow.model.nematic import Nematic

    n = 24 if dim == 2 else 64
    random_spec = JamSpec(n=n, dim=dim, shape=shape, sizes="mono", seed=3)
    _, aligned = prepare(JamSpec(**{**random_spec.as_dict(), "orientations": "aligned"}))
    _, random = prepare(random_spec)
    np.testing.assert_allclose(aligned.directors, np.tile(np.eye(dim)[0], (n, 1)), atol=1e-15)
    assert Nematic().compute(aligned).p2 == pytest.approx(1.0, abs=1e-12)
    assert Nematic().compute(random).p2 < 0.6
    assert aligned.metadata["orientations"] == "aligned" and random.metadata["orientations"] == "random"
    if "nmer" not in shape:
        assert np.array_equal(aligned.positions, random.positions)


@pytest.mark.parametrize("dim,shape", [(2, "ellipse:3"), (3, "spheroid:2"), (2, "nmer:2:2"), (3, "nmer:3:2")])
def test_nematic_one_is_the_aligned_start_bit_for_bit(dim, shape):
    """--orientations nematic:1 is "aligned": the same positions, sizes and orientations to the
    bit (nothing more drawn from the generator, also for rigid bodies, whose orientations come
    first), and "aligned" still draws nothing (its positions are the random start's)."""
    n = 24 if dim == 2 else 64
    spec = JamSpec(n=n, dim=dim, shape=shape, sizes="mono", seed=3, orientations="aligned")
    _, aligned = prepare(spec)
    _, one = prepare(JamSpec(**{**spec.as_dict(), "orientations": "nematic:1"}))
    for name in ("positions", "diameters", "orientations"):
        assert np.array_equal(getattr(one, name), getattr(aligned, name)), name
    assert np.array_equal(aligned.orientations, np.zeros(n) if dim == 2 else np.tile([1.0, 0, 0, 0], (n, 1)))


def _p2_about_x(directors):
    """Per-particle nematic order about x: cos 2 theta (2D), (3 cos^2 beta - 1) / 2 (3D)."""
    u = np.asarray(directors)
    return 2 * u[:, 0] ** 2 - 1 if u.shape[1] == 2 else 1.5 * u[:, 0] ** 2 - 0.5


def _p2_law(s, dim):
    """Mean and variance of the per-particle P2 of the nematic:S law, in closed form: 2D theta
    uniform in [-D, D] (mean sin 2D / 2D, <cos^2 2 theta> = (1 + sin 4D / 4D) / 2); 3D
    x = cos beta uniform in [c, 1] (mean c (1 + c) / 2, <P2(x)^2> from the antiderivative of
    (9 x^4 - 6 x^2 + 1) / 4)."""
    from jamflow.model.shapes.rotations import cone_half_angle

    if dim == 2:
        d = cone_half_angle(s)
        return np.sin(2 * d) / (2 * d), 0.5 * (1 + np.sin(4 * d) / (4 * d)) - (np.sin(2 * d) / (2 * d)) ** 2
    c = 0.5 * (np.sqrt(1 + 8 * s) - 1)
    prim = lambda x: (9 * x ** 5 / 5 - 2 * x ** 3 + x) / 4  # noqa: E731
    return c * (1 + c) / 2, (prim(1.0) - prim(c)) / (1 - c) - (c * (1 + c) / 2) ** 2


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("s", [0.1, 0.25, 0.5, 0.64, 0.75, 0.99])
def test_a_nematic_start_has_order_s_about_x(dim, s):
    """--orientations nematic:S: the start's P2 about x over N = 20000 directors is S within 4
    standard errors of the mean; the law's own mean (closed form) is S to round-off, and its
    variance is the sample's to 10 %. Through the library's start (random_packing)."""
    from jamflow.model.packing import random_packing
    from jamflow.model.shapes import Ellipsoid
    from jamflow.model.sizes import parse_sizes

    n = 20000
    mean, var = _p2_law(s, dim)
    assert mean == pytest.approx(s, abs=1e-12)
    start = random_packing(n, dim, parse_sizes("mono"), 0.3, 7, shape=Ellipsoid(3.0), orientations=f"nematic:{s}")
    p2 = _p2_about_x(start.directors)
    assert abs(p2.mean() - s) < 4 * np.sqrt(var / n), (p2.mean(), s)
    assert p2.var() == pytest.approx(var, rel=0.1)
    assert start.metadata["orientations"] == f"nematic:{s}"


def test_ellipses_jammed_from_an_aligned_start_stay_roughly_aligned(tmp_path):
    """Figure 2.23(c, d) at N = 32, alpha = 3, seed 0: the aligned start keeps nematic order
    (P2 = 0.74 here), the random start does not (0.34, domains at this small N); the file
    records the start (also a nematic:S one)."""
    from jamflow.cli.app import main
    from jamflow.model.nematic import Nematic

    p2 = {}
    for start in ("random", "aligned", "nematic:0.5"):
        path = tmp_path / f"{start}.h5"
        assert main(["jam", "--n", "32", "--sizes", "mono", "--shape", "ellipse:3", "--orientations", start,
                     "--quiet", "--out", str(path)]) == 0
        packing = load_packing(path)
        assert packing.metadata["orientations"] == start
        p2[start] = Nematic().compute(packing).p2
    assert p2["aligned"] > 0.6 and p2["random"] < 0.45, p2


@pytest.mark.parametrize("shape, contact", [("ellipse:1.5", "exact"), ("dimer:1.5:1", "exact"),
                                            ("ellipse:1.5", "cleaver")])
def test_prepare_parses_the_shape_spec_once(monkeypatch, shape, contact):
    from jamflow.model.shapes import parse

    word = shape.partition(":")[0]
    calls = []
    parser = parse.SPECS[word]
    monkeypatch.setitem(parse.SPECS, word, lambda *args: calls.append(args) or parser(*args))
    spec = JamSpec(n=16, shape=shape, contact=contact)
    settings, start = prepare(spec)
    assert len(calls) == 1 and start.shape is spec.particle and spec.particle.kind == start.shape.kind
