"""Output files (docs/hardening.md has the catalogue): a path that is not a regular file (device
node, FIFO, symbolic link, read-only file) or that is the command's input is refused before work,
and --force replaces it (a read-only file keeps its mode, an emitted deck included); a refused or
interrupted run leaves no empty --out directory; a full disk (an HDF5 write, a figure, a really full
tmpfs, numba's cache) is one line, the earlier file intact and no temporary file left."""

import os
import stat
import subprocess

import h5py
import pytest
from conftest import JAMFLOW, no_traceback, run_jam

from jamflow.cli.app import main
from jamflow.io.packing_file import load_packing


def special_paths(tmp_path):
    """A device node (as root; else a FIFO), a symlink, a read-only file."""
    node = tmp_path / "node"
    if os.geteuid() == 0:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # like /dev/null
    else:
        os.mkfifo(node)
    target = tmp_path / "target.h5"
    target.write_text("keep me")
    link = tmp_path / "link.h5"
    link.symlink_to(target)
    readonly = tmp_path / "readonly.h5"
    readonly.write_text("keep me too")
    readonly.chmod(0o444)
    return {"node": node, "link": link, "readonly": readonly}


@pytest.mark.parametrize("kind,message", [("node", "not a regular file"), ("link", "symbolic link"),
                                          ("readonly", "read-only")])
def test_outputs_that_are_not_regular_files_are_refused_unless_forced(tmp_path, capsys, kind, message):
    """Was: /dev/full (as root) replaced by an HDF5 file; a symlink replaced; a read-only file
    overwritten and made 644."""
    path = special_paths(tmp_path)[kind]
    before = os.lstat(path)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(path))
    assert code == 2 and message in err and "--force" in err and no_traceback(err)
    after = os.lstat(path)
    assert (after.st_mode, after.st_ino) == (before.st_mode, before.st_ino)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(path), "--force")
    assert code == 0, err
    assert load_packing(path).n == 16 and not path.is_symlink()
    if kind == "readonly":
        assert stat.S_IMODE(path.stat().st_mode) == 0o444  # the file keeps its permissions
    assert (tmp_path / "target.h5").read_text() == "keep me"


@pytest.mark.parametrize("command", ["shear", "families", "moduli"])
def test_commands_refuse_a_symlinked_output_before_work_and_force_it(tmp_path, capsys, monkeypatch, packing_file,
                                                                     command):
    # was: "... or --force" advice where the command had no --force; families refused only after all its work
    work = {"shear": "jamflow.cli.commands.shear.shear", "families": "jamflow.cli.commands.families.sample",
            "moduli": "jamflow.protocols.moduli.Moduli.compute"}[command]
    monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "out"
    out.mkdir()
    source = out / "p.h5"
    source.write_bytes(packing_file.read_bytes())
    args, link = {"shear": (["shear", str(source), "--dgamma", "1e-3", "--to", "2e-3", "--out", str(out)], "p.shear.h5"),
                  "families": (["families", "--n", "8", "--out", str(out)], "families.h5"),
                  "moduli": (["moduli", str(source)], "p.moduli.h5")}[command]
    (out / link).symlink_to(tmp_path / "elsewhere.h5")
    assert main([*args, "--quiet", "--no-figure"] if command != "families" else [*args, "--quiet"]) == 2
    assert "symbolic link" in capsys.readouterr().err
    assert (out / link).is_symlink()
    from jamflow.cli.app import build_parser

    assert build_parser(command).parse_args([*args, "--force"]).force


def test_shear_force_replaces_a_symlinked_path_file(tmp_path, capsys, packing_file):
    out = tmp_path / "out"
    out.mkdir()
    (out / "p.shear.h5").symlink_to(tmp_path / "elsewhere.h5")
    args = ["shear", str(packing_file), "--dgamma", "1e-3", "--to", "2e-3", "--out", str(out), "--quiet", "--no-figure"]
    assert main([*args, "--force"]) == 0
    assert (out / "p.shear.h5").is_file() and not (out / "p.shear.h5").is_symlink()
    assert not (tmp_path / "elsewhere.h5").exists()


def test_emit_deck_force_replaces_a_read_only_deck(tmp_path, capsys):
    # was: refused with "or --force to replace it", and refused again with --force
    deck = tmp_path / "deck.lmp"
    deck.write_text("keep")
    deck.chmod(0o444)
    args = ["jam", "--n", "10", "--emit-deck", str(deck), "--out", str(tmp_path / "p.h5")]
    assert main(args) == 2 and "--force" in capsys.readouterr().err
    assert main([*args, "--force"]) == 0
    assert deck.read_text() != "keep" and (tmp_path / "deck.start.data").is_file()


@pytest.mark.parametrize("command", ["anneal", "refine"])
def test_an_output_that_is_the_input_is_refused_before_work(command, tmp_path, capsys, monkeypatch, packing_file):
    """Was: ``jamflow refine p.h5 --out p.h5`` (and ``anneal``) replaced the float64 onset it started
    from with the refined packing; now one line, exit 2, the input byte for byte as it was."""
    work = {"anneal": "jamflow.cli.commands.anneal.anneal", "refine": "jamflow.protocols.refine.refine"}[command]
    monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    source = tmp_path / "p.h5"
    source.write_bytes(packing_file.read_bytes())
    link = tmp_path / "link.h5"
    link.symlink_to(source)
    options = {"anneal": ["--to", "1.1", "--dalpha", "0.05", "--quiet"], "refine": ["--pressure", "1e-12"]}[command]
    for out in (source, link):
        assert main([command, str(source), *options, "--out", str(out), "--force"]) == 2
        assert f"is the input {source}" in capsys.readouterr().err
    assert source.read_bytes() == packing_file.read_bytes()


@pytest.mark.parametrize("command", ["shear-refused", "shear-interrupted", "families-refused", "families-interrupted"])
def test_a_failed_run_leaves_no_empty_out_directory(tmp_path, capsys, monkeypatch, packing_file, command):
    # was: shear --vtol 1e-30, families --n 1 / --seed -1 / --sizes x and Ctrl-C left an empty --out DIR
    out = tmp_path / "out"
    name, how = command.split("-")
    if how == "interrupted":
        def interrupt(*a, **k):
            raise KeyboardInterrupt
        monkeypatch.setattr(f"jamflow.cli.commands.{name}.{'shear' if name == 'shear' else 'sample'}", interrupt)
    args = {"shear": ["shear", str(packing_file), "--dgamma", "1e-3", "--to", "2e-3"],
            "families": ["families", "--n", "6", "--starts", "1", "--gamma-max", "0.02"]}[name]
    bad = {"shear": ["--vtol", "1e-30"], "families": ["--n", "1"]}[name] if how == "refused" else []
    code = main([*args, *bad, "--out", str(out), "--quiet"])
    assert code == (2 if how == "refused" else 130) and no_traceback(capsys.readouterr().err)
    assert not out.exists()


ENOSPC_TEXT = os.strerror(28)
H5_FLUSH_FAILED = ("Can't decrement id ref count (file write failed: time = Thu Dec  3 11:48:15 2026, filename = "
                   "'x.tmp', file descriptor = 3, errno = 28, error message = 'No space left on device')")


def one_line_disk_full(code, err, path):
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    assert f"cannot write {path}" in err and "no space left" in err and "free space and rerun" in err, err


@pytest.mark.parametrize("where", ["h5py-oserror", "h5py-flush", "fsync"])
def test_a_full_disk_is_one_line_and_keeps_the_earlier_file(tmp_path, capsys, monkeypatch, packing_file, where):
    """Was: h5py tracebacks (OSError [Errno 28], RuntimeError '... errno = 28 ...') and, for
    analyze, a segmentation fault; now one line, exit 2, the earlier file intact, no temporary file."""
    import errno

    out = tmp_path / "p.h5"
    out.write_bytes(packing_file.read_bytes())
    before = out.read_bytes()
    if where == "h5py-oserror":  # a dataset write that hits the full disk
        def full(self, name, value):
            raise OSError(errno.ENOSPC, f"Can't synchronously write data ({ENOSPC_TEXT})")
        monkeypatch.setattr(h5py.Group, "__setitem__", full)
    elif where == "h5py-flush":  # HDF5's flush at close: a RuntimeError that carries errno = 28 in its text
        def full(self, name, value):
            raise RuntimeError(H5_FLUSH_FAILED)
        monkeypatch.setattr(h5py.Group, "__setitem__", full)
    else:  # the file layer under every writer
        def full(fd):
            raise OSError(errno.ENOSPC, ENOSPC_TEXT)
        monkeypatch.setattr("jamflow.support.files.os.fsync", full)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(out), "--force")
    one_line_disk_full(code, err, out)
    assert out.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["p.h5"]


def test_a_figure_on_a_full_disk_is_one_line(tmp_path, capsys, monkeypatch, packing_file):
    import errno

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, ENOSPC_TEXT)

    monkeypatch.setattr("matplotlib.figure.Figure.savefig", full)
    out = tmp_path / "pic.png"
    code = main(["draw", str(packing_file), "-o", str(out)])
    one_line_disk_full(code, capsys.readouterr().err, out)
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def tiny_tmpfs(tmp_path):
    """A 64 kB tmpfs (as root): a disk that really fills."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    where = tmp_path / "full"
    where.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(where)]).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], check=True)


def test_analyze_onto_a_really_full_disk(tiny_tmpfs, packing_file):
    """Was (N = 64 and 32): h5py tracebacks, then 'Fatal Python error: Segmentation fault' (exit 139),
    and the hidden temporary file left on the full disk."""
    out = tiny_tmpfs / "s.h5"
    out.write_bytes(b"the earlier result")
    (tiny_tmpfs / "filler").write_bytes(bytes(48 * 1024))  # ~12 kB left: less than the results file
    plots = tiny_tmpfs.parent / "plots"
    plots.mkdir()
    done = subprocess.run([*JAMFLOW, "analyze", str(packing_file), "--out", str(out), "--plots", str(plots)],
                          capture_output=True, text=True, timeout=300)
    one_line_disk_full(done.returncode, done.stderr, out)
    assert out.read_bytes() == b"the earlier result"
    assert sorted(p.name for p in tiny_tmpfs.iterdir()) == ["filler", "s.h5"]


def test_a_full_numba_cache_warns_once_and_runs(tmp_path, monkeypatch):
    """Was: numba's OSError [Errno 28] traceback out of the first call of a kernel (a full
    JAMFLOW_CACHE_DIR); now the kernels run from memory after one warning."""
    import errno
    import warnings

    import numba.core.caching

    from jamflow.engines import compiled

    compiled.start_numba()
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(compiled, "_cache_unwritable", False)

    def full(self, name, data):
        raise OSError(errno.ENOSPC, ENOSPC_TEXT)

    monkeypatch.setattr(numba.core.caching.IndexDataCacheFile, "_save_data", full)

    def twice(x):
        return 2 * x

    def thrice(x):
        return 3 * x

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert compiled.jit(twice)(2) == 4 and compiled.jit(thrice)(2) == 6 and compiled.jit(twice)(2.5) == 5.0
    messages = [str(w.message) for w in caught if "cannot be cached" in str(w.message)]
    assert len(messages) == 1 and str(tmp_path) in messages[0] and "No space left" in messages[0], messages
