"""Input files (docs/hardening.md has the catalogue): an empty, truncated, non-HDF5, incomplete or
damaged packing file is one line naming the file (modes, analyze, draw, export) or a ValueError
naming it (load_packing, read_attrs, read_history); the same packing file given twice (another
spelling, a symbolic link, its directory) is refused, not counted as two packings."""

from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import no_traceback

from jamflow.cli.app import main
from jamflow.io.packing_file import load_packing, read_attrs, read_history


def bad_files(tmp_path, good):
    files = {"empty": b"", "truncated": good.read_bytes()[:3000], "text": b"hello\n"}
    out = {}
    for name, content in files.items():
        out[name] = tmp_path / f"{name}.h5"
        out[name].write_bytes(content)
    out["incomplete"] = tmp_path / "incomplete.h5"
    with h5py.File(out["incomplete"], "w") as f:
        f.attrs.update(schema="jamflow.packing", schema_version=1)
        f["positions"] = np.zeros((2, 2))
    out["badjson"] = tmp_path / "badjson.h5"
    out["badjson"].write_bytes(good.read_bytes())
    with h5py.File(out["badjson"], "r+") as f:
        f.attrs["shape"] = '{"kind": "sph'  # a damaged JSON attribute (was: a JSONDecodeError traceback, exit 1)
    return out


EXPECTED = {"empty": "is empty", "truncated": "truncated or damaged", "text": "not an HDF5 file",
            "incomplete": "incomplete jamflow packing file: can't locate attribute: 'potential'",
            "badjson": "damaged jamflow packing file: an attribute is not valid JSON"}


@pytest.mark.parametrize("kind", sorted(EXPECTED))
@pytest.mark.parametrize("command", [["modes"], ["analyze"], ["draw"], ["export", "--format", "xyz"]])
def test_bad_input_files_give_one_line(tmp_path, capsys, packing_file, kind, command):
    """Was: raw h5py tracebacks without the file name (modes, analyze)."""
    path = bad_files(tmp_path, packing_file)[kind]
    code = main([command[0], str(path), *command[1:], *(["--out", str(tmp_path / "s.h5")] if command[0] == "analyze" else [])])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and str(path) in err and EXPECTED[kind] in err


@pytest.mark.parametrize("kind,reader", [(k, r) for k in sorted(EXPECTED) for r in (load_packing, read_attrs, read_history)
                                         if k not in ("incomplete", "badjson") or r is load_packing])
def test_bad_files_raise_clear_errors_in_python(tmp_path, packing_file, kind, reader):
    path = bad_files(tmp_path, packing_file)[kind]
    with pytest.raises(ValueError, match=EXPECTED[kind]) as info:
        reader(path)
    assert str(path) in str(info.value)


def test_read_history_names_a_missing_group(tmp_path, packing_file):
    path = bad_files(tmp_path, packing_file)["incomplete"]
    with pytest.raises(ValueError, match="incomplete jamflow packing file.*history"):
        read_history(path)


@pytest.mark.parametrize("command", ["modes", "analyze", "moduli"])
def test_the_same_file_twice_is_refused(tmp_path, capsys, monkeypatch, packing_file, command):
    # was: `modes p.h5 ./p.h5` / `analyze p.h5 p.h5` averaged the one packing as two (exit 0)
    import shutil

    (tmp_path / "store").mkdir()
    packing_file = Path(shutil.copy(packing_file, tmp_path / "store" / "p.h5"))  # a directory of its own
    link = tmp_path / "same.h5"
    link.symlink_to(packing_file)
    monkeypatch.chdir(packing_file.parent)
    extra = ["--out", str(tmp_path / "a.h5")] if command == "analyze" else []
    pairs = [[str(packing_file), f"./{packing_file.name}"], [str(packing_file), str(link)]]
    if command != "moduli":  # modes and analyze take a store directory for its files
        pairs.append([str(packing_file.parent), str(packing_file)])
    for pair in pairs:
        code = main([command, *pair, *extra])
        err = capsys.readouterr().err
        assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
        assert "it would count as two packings; give each packing file once" in err
    assert [p.name for p in packing_file.parent.iterdir()] == ["p.h5"]  # nothing written beside it
