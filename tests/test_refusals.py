"""User errors refused before any work (docs/hardening.md has the catalogue): one line on
stderr, exit 2, no traceback, nothing written. Jam's options (values that cannot work, an option
without its partner, a contact method a shape has none of or that cannot give a checked packing,
--above), the Python API's arguments, the strains of shear and families, anneal's options, sizes
that do not fit in memory (--n, --k-max, seed ranges). A negative number is read as a value, not an
option; a refusal prints no progress bar, a run still does."""

import subprocess

import numpy as np
import pytest
from conftest import JAMFLOW, no_traceback, run_jam

import jamflow
from jamflow.cli.app import main
from jamflow.io.packing_file import load_packing


@pytest.mark.parametrize("args,message", [
    (["--vtol", "1e-30"], "vtol 1e-30 is not resolvable.*use vtol"),  # was: exit 0, a packing that is not jammed
    (["--potential", "spring:10"], "alpha = 10.*2 <= ALPHA <= 3"),  # was: traceback, "start from a lower phi0"
    (["--ftol", "1"], "force tolerance 1.0e\\+00.*--ftol\\) <="),  # was: traceback, "start from a lower phi0"
    (["--seed", "99999999999999999999999"], "seed must be an integer in \\[0, 2\\^63 - 1\\]"),  # was: result lost at save
    (["--n", "1000000000"], "needs about .* GB of memory"),  # was: grew to 24 GB, killed by the kernel
    (["--potential", "spring:1.5"], "alpha = 1.5"),  # was: exit 0, net forces 0.4 of the contact forces
    (["--potential", "spring:4"], "alpha = 4"),  # was: exit 0, net forces 7% of the contact forces
])
def test_jam_refuses_before_work(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, *args, "--out", str(tmp_path / "x.h5"))
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1
    import re

    assert re.search(message, err), err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs,error,message", [
    (dict(dim=2.0), ValueError, "dim must be the integer 2 or 3"),
    (dict(sizes=None), TypeError, "sizes must be a spec string"),
    (dict(potential=3), TypeError, "potential must be a spec string"),
    (dict(settings="fast"), TypeError, "settings must be a CompressionSettings"),
    (dict(seed=2**70), ValueError, "seed must be an integer in"),
    (dict(start=np.zeros((3, 2))), TypeError, "start must be a Packing"),
])
def test_python_jam_rejects_bad_arguments_clearly(kwargs, error, message, monkeypatch):
    """Was: TypeError/AttributeError from deep inside (dim=2.0, sizes=None, potential=3, settings='fast')."""
    monkeypatch.setattr("jamflow.protocols.compression.compress", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(error, match=message):
        jamflow.jam(n=16, **kwargs)


PARTNERLESS = [  # (options, the option, its partner): was exit 0, the option silently ignored
    (["--stress", "aniso"], "--stress aniso", "--pressure"),
    (["--wall-type", "rough"], "--wall-type rough", "--walls"),
    (["--damping", "2"], "--damping 2.0", "--minimizer md"),
    (["--md-damping", "pairwise"], "--md-damping pairwise", "--minimizer md"),
    (["--dphi0", "1e-3", "--pressure", "1e-3"], "--dphi0 0.001", "a compression run"),
    (["--dphi0", "1e-3", "--gravity", "1e-3", "--walls", "y"], "--dphi0 0.001", "a compression run"),
    (["--vtol", "1e-3", "--gravity", "1e-3", "--walls", "y"], "--vtol 0.001", "a compression run"),
    (["--vtol", "1e-10", "--pressure", "1e-3"], "--vtol 1e-10", "a compression run"),
]


@pytest.mark.parametrize("args,option,partner", PARTNERLESS)
def test_an_option_without_its_partner_is_refused_before_work(tmp_path, capsys, monkeypatch, args, option, partner):
    for work in ("jamflow.protocols.spec.jam", "jamflow.protocols.pressure.jam_at_pressure"):
        monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, "--n", "16", *args, "--out", str(tmp_path / "x.h5"))
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    assert f"{option} applies to {partner} only" in err and "leave" in err
    assert list(tmp_path.iterdir()) == []


def test_library_refuses_a_non_default_value_without_its_partner():
    from jamflow.protocols.spec import PARTNERS, JamSpec, check_boundaries

    values = dict(stress="tri", wall_type="rough", damping=3.0, md_damping="pairwise", dphi0=2e-4, vtol=1e-10)
    assert set(values) == set(PARTNERS)
    for name, value in values.items():
        check_boundaries(JamSpec(**{name: getattr(JamSpec(), name)}))  # the default alone: accepted
        with pytest.raises(ValueError, match=f"--{name.replace('_', '-')} .* applies to"):
            check_boundaries(JamSpec(**{name: value}, pressure=1e-3 if name in ("dphi0", "vtol") else None))
    check_boundaries(JamSpec(stress="tri", pressure=1e-3))  # with the partner: accepted
    check_boundaries(JamSpec(wall_type="rough", walls="y"))
    check_boundaries(JamSpec(damping=3.0, md_damping="pairwise", minimizer="md"))
    check_boundaries(JamSpec(dphi0=2e-4))


@pytest.mark.parametrize("shape,dim,contact", [("disk", 2, "gaussian"), ("sphere", 3, "cleaver"),
                                               ("ellipse:1", 2, "linear"), ("nmer:2:1.5", 2, "gaussian")])
def test_jam_refuses_a_contact_method_for_shapes_without_one(tmp_path, capsys, monkeypatch, shape, dim, contact):
    # was: accepted and silently ignored (disks, spheres and rigid bodies of round sites have no approximation)
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, "--shape", shape, "--dim", str(dim), "--contact", contact,
                        "--out", str(tmp_path / "x.h5"))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"--contact {contact} applies to ellipses/spheroids" in err and "leave --contact out" in err
    assert list(tmp_path.iterdir()) == []


def test_jam_keeps_a_contact_method_for_ellipses():
    from jamflow.cli.app import build_parser
    from jamflow.cli.commands.jam import spec_from_args
    from jamflow.protocols.spec import prepare

    args = build_parser("jam").parse_args(["jam", "--shape", "ellipse:1.5", "--sizes", "mono", "--contact", "gaussian",
                                           "--n", "16"])
    assert prepare(spec_from_args(args))[1].shape.contact == "gaussian"


@pytest.mark.parametrize("contact", ["linear", "quadratic"])
@pytest.mark.parametrize("shape,dim", [("ellipse:1.5", 2), ("spheroid:1.5", 3)])
def test_a_contact_method_without_second_derivatives_is_refused_before_work(tmp_path, capsys, monkeypatch, contact,
                                                                            shape, dim):
    # was: the whole jam ran, then every packing failed: "the dynamical matrix needs the contact-distance
    # method's derivatives; the 'linear' method's lambda ... has none here"
    from jamflow.protocols.spec import JamSpec, prepare

    monkeypatch.setattr("jamflow.protocols.compression.open_engine", lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--sizes", "mono", "--shape", shape, "--dim", str(dim),
                        "--contact", contact, "--out", str(tmp_path / "x.h5"))
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    assert f"--contact {contact} cannot make a checked packing" in err and "exact | cleaver | gaussian" in err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="cannot make a checked packing"):
        prepare(JamSpec(n=16, sizes="mono", shape=shape, dim=dim, contact=contact))


def test_jam_above_one_does_not_quote_an_onset_not_yet_known(tmp_path, capsys, monkeypatch):
    # was: "phi_J + dphi = 0.000000 + 2 >= 1"
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: pytest.fail("work started"))
    assert main(["jam", "--n", "10", "--above", "2", "--quiet", "--out", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert "--above 2 >= 1" in err and "0.000000" not in err


def test_negative_values_with_an_exponent_are_values():
    # was: `jamflow shear --dgamma -1e-3` "expected one argument" (argparse read -1e-3 as an option)
    from jamflow.cli.app import build_parser

    args = build_parser("shear").parse_args(["shear", "p.h5", "--dgamma", "-1e-3", "--to", "-2e-3", "--out", "d"])
    assert (args.dgamma, args.to) == (-1e-3, -2e-3)
    assert build_parser("jam").parse_args(["jam", "--gamma", "-1e-2"]).gamma == -1e-2


@pytest.mark.parametrize("args,option", [
    (["families", "--spacing", "nan"], "--spacing"), (["families", "--gamma-min", "nan"], "--gamma-min"),
    (["families", "--gamma-max", "inf"], "--gamma-max"), (["shear", "P", "--dgamma", "nan", "--to", "1e-3"], "--dgamma"),
    (["shear", "P", "--dgamma", "1e-3", "--to", "inf"], "--to"),
])
def test_a_strain_that_is_not_finite_is_refused_naming_its_option(tmp_path, capsys, monkeypatch, packing_file, args,
                                                                   option):
    # was: "shear strain gamma must be a finite number, got nan" (the check of the grid's strains)
    for work in ("jamflow.cli.commands.families.sample", "jamflow.cli.commands.shear.shear"):
        monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    args = [str(packing_file) if a == "P" else a for a in args]
    assert main([*args, "--out", str(tmp_path / "d"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert option in err and "finite" in err and "shear strain gamma" not in err and len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_anneal_refuses_before_work(tmp_path, capsys, monkeypatch, packing_file):
    monkeypatch.setattr("jamflow.cli.commands.anneal.anneal", lambda *a, **k: pytest.fail("work started"))
    base = ["anneal", str(packing_file), "--dalpha", "0.05", "--out", str(tmp_path / "a.h5"), "--quiet"]
    # was: the whole anneal ran, then a TypeError traceback at the save (result lost)
    assert main([*base, "--to", "1.1", "--seed", "99999999999999999999999"]) == 2
    assert "--seed must be a non-negative integer below 2^63" in capsys.readouterr().err
    # was: "use ellipse:2", an option anneal does not have
    assert main([*base, "--to", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "use --to 2" in err and "ellipse:2" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args", [["jam", "--walls", "y", "--gamma", "0.1"], ["jam", "--vtol", "1e-30"],
                                  ["shear", "P", "--vtol", "1e-30", "--dgamma", "1e-3", "--to", "2e-3"],
                                  ["families", "--n", "1"]])
def test_a_refusal_without_quiet_prints_only_its_error(tmp_path, capsys, packing_file, args):
    # was: an empty progress bar ("jam: 0min [00:00, ?min/s]") drawn on stderr before the error
    args = [str(packing_file) if a == "P" else a for a in args]
    assert main([*args, "--out", str(tmp_path / "d")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"jamflow {args[0]}: error:"), lines


def test_a_run_without_quiet_still_shows_its_progress(tmp_path, capsys):
    assert main(["jam", "--n", "64", "--out", str(tmp_path / "p.h5")]) == 0
    err = capsys.readouterr().err
    assert "jam:" in err and "min/s" in err and "phi=" in err


@pytest.mark.parametrize("seeds", ["0:9223372036854775808", "9223372036854775808:9223372036854775810"])
def test_ensemble_seeds_past_int64_are_refused_before_work(tmp_path, seeds):
    """Was: the task list for every seed was built first (memory without bound), then an
    OverflowError traceback. Run with 2 GB of address space, so a regression fails, not the machine."""
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))

    done = subprocess.run([*JAMFLOW, "ensemble", "--seeds", seeds, "--out", str(tmp_path / "s"), "--quiet"],
                          capture_output=True, text=True, timeout=120, preexec_fn=limit)
    assert done.returncode == 2 and no_traceback(done.stderr) and "past 2^63 - 1" in done.stderr, done.stderr
    assert not (tmp_path / "s").exists()


def test_analyze_k_max_too_large_is_refused_with_what_fits(tmp_path, capsys, monkeypatch, packing_file):
    """Was: numpy's 'Unable to allocate 471. GiB' traceback (--k-max 100000). The value named as
    fitting does fit: with it S(k) is computed."""
    import re

    from jamflow.analysis import structure

    monkeypatch.setattr(structure, "physical_memory", lambda: 200e6)  # a machine of 200 MB
    monkeypatch.setattr("jamflow.analysis.structure.RDF.compute", lambda *a, **k: pytest.fail("work started"))
    code = main(["analyze", str(packing_file), "--out", str(tmp_path / "s.h5"), "--k-max", "100000"])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    largest = float(re.search(r"use k_max \(--k-max\) <= ([0-9.e+]+)", err).group(1))
    assert 20 < largest < 100000 and list(tmp_path.iterdir()) == []
    packing = load_packing(packing_file)
    assert structure.StructureFactor(k_max=largest).compute(packing).k.max() <= largest
    with pytest.raises(ValueError, match="needs about"):
        structure.StructureFactor(k_max=largest * 1.5).compute(packing)
