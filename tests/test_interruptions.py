"""Interrupted runs (docs/hardening.md has the catalogue): SIGTERM (exit 143) and Ctrl-C (exit
130, also while the command starts up) end in one line, earlier outputs untouched and no temporary
file left (LAMMPS's scratch directory, a figure half written); the hidden temporary file of a write
killed by SIGKILL is removed by the next run that writes that output; output into a closed pipe
still finishes the work."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from conftest import JAMFLOW, no_traceback

from jamflow.cli.app import EXIT_TERMINATED, main
from jamflow.io.packing_file import read_checks


def test_sigterm_removes_temporary_files_and_keeps_the_old_output(tmp_path, packing_file):
    """Was: /tmp/jamflow-*/start.data left behind on SIGTERM."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    out = tmp_path / "p.h5"
    out.write_bytes(packing_file.read_bytes())
    proc = subprocess.Popen([*JAMFLOW, "jam", "--n", "2048", "--engine", "lammps", "--quiet", "--out", str(out)],
                            env={**os.environ, "TMPDIR": str(scratch)}, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not list(scratch.glob("jamflow-*/start.data")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(scratch.glob("jamflow-*/start.data")), "LAMMPS never started"
    proc.send_signal(signal.SIGTERM)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == EXIT_TERMINATED and no_traceback(err) and "terminated" in err
    assert list(scratch.iterdir()) == []
    assert out.read_bytes() == packing_file.read_bytes() and sorted(p.name for p in tmp_path.iterdir()) == ["p.h5", "tmp"]


def test_sigterm_while_a_figure_is_written_leaves_no_hidden_file(tmp_path, packing_file, monkeypatch):
    """Was: hidden .*.tmp figure files left behind."""
    from matplotlib.figure import Figure

    def savefig(self, target, **kwargs):
        Path(target).write_bytes(b"half a png")
        os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(Figure, "savefig", savefig)
    p = tmp_path / "p.h5"
    p.write_bytes(packing_file.read_bytes())
    assert main(["modes", str(p)]) == EXIT_TERMINATED
    assert not [f for f in tmp_path.iterdir() if f.name.startswith(".")] and not (tmp_path / "p.modes.png").exists()


def test_a_write_killed_by_sigkill_leaves_debris_that_the_next_run_removes(tmp_path, capsys):
    # was: the hidden .p.h5.*.tmp of a SIGKILLed write stayed beside the output for good
    from jamflow.support.files import _temporary_prefix

    out = tmp_path / "p.h5"
    killed = subprocess.run([sys.executable, "-c", "import os, signal\nfrom jamflow.io.packing_file import atomic_path\n"
                             f"with atomic_path({str(out)!r}) as tmp:\n    tmp.write_bytes(b'half a file')\n"
                             "    os.kill(os.getpid(), signal.SIGKILL)"], cwd=tmp_path)
    assert killed.returncode == -signal.SIGKILL
    debris = list(tmp_path.glob(".p.h5.*.tmp"))
    assert len(debris) == 1 and debris[0].read_bytes() == b"half a file"
    live = tmp_path / f"{_temporary_prefix(out, os.getpid())}abcdefgh.tmp"  # a writer still running: kept
    others = [tmp_path / ".p.h5.notes.tmp",  # not atomic_path's pattern; below, another output's debris
              tmp_path / f"{_temporary_prefix(tmp_path / 'q.h5', 999_999_999)}abcdefgh.tmp"]
    for path in [live, *others]:
        path.write_bytes(b"not debris of this run")
    assert main(["jam", "--n", "16", "--quiet", "--out", str(out)]) == 0  # the same command again
    assert not debris[0].exists() and live.exists() and all(p.exists() for p in others)
    assert read_checks(out).passed


def test_ctrl_c_during_start_up(capsys, monkeypatch):
    """Was: a traceback from inside the imports."""
    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr("jamflow.cli.app.import_module", interrupted)
    assert main(["jam"]) == 130
    assert "interrupted" in capsys.readouterr().err


def test_ctrl_c_while_the_command_starts(tmp_path):
    # was: a KeyboardInterrupt traceback while the console script imported jamflow.cli.app (about 10 ms)
    import re

    text = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text()
    module, function = re.search(r'^jamflow = "([\w.]+):(\w+)"', text, re.M).groups()
    script = ("import importlib.abc, os, signal, sys\n"
              "class Interrupt(importlib.abc.MetaPathFinder):  # Ctrl-C as jamflow.cli.app starts to load\n"
              "    def find_spec(self, name, path, target=None):\n"
              "        if name == 'jamflow.cli.app':\n            os.kill(os.getpid(), signal.SIGINT)\n"
              "sys.meta_path.insert(0, Interrupt())\n"
              f"from {module} import {function}\nsys.exit({function}())\n")  # what pip's console script does
    done = subprocess.run([sys.executable, "-c", script, "jam"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 130 and no_traceback(done.stderr), done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "interrupted" in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_output_into_a_closed_pipe(tmp_path, packing_file):
    """Was: BrokenPipeError traceback (jamflow modes x.h5 | head -1). Now the command
    finishes its work (results and figure) and drops the lines nobody reads."""
    p = tmp_path / "p.h5"
    p.write_bytes(packing_file.read_bytes())
    proc = subprocess.Popen([*JAMFLOW, "modes", str(p)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # the reader is gone before the first line
    err = proc.stderr.read()
    proc.wait(timeout=120)
    assert proc.returncode == 0 and "Traceback" not in err and "Broken" not in err
    assert (tmp_path / "p.modes.h5").is_file() and (tmp_path / "p.modes.png").is_file()
