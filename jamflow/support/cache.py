"""jamflow's cache directory and the check that a compiled shared object is whole (stdlib only)."""

from __future__ import annotations

import os
from pathlib import Path


# cache location ----------------------------------------------------------------------------
def cache_root() -> Path:
    """``$JAMFLOW_CACHE_DIR``, else ``$XDG_CACHE_HOME/jamflow``, else ``~/.cache/jamflow``."""
    explicit = os.environ.get("JAMFLOW_CACHE_DIR")
    if explicit:
        return Path(explicit).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "jamflow"


def intact_shared_object(library: Path) -> bool:
    """Is ``library`` a complete 64-bit ELF file? (Garbage, empty and truncated files are not:
    the section header table, at the end of the file, must lie inside it.) LAMMPS itself only
    warns on a ``plugin load`` of a damaged file and then rejects the pair style."""
    try:
        with open(library, "rb") as fh:
            head = fh.read(64)
        size = library.stat().st_size
    except OSError:
        return False
    if len(head) < 64 or head[:4] != b"\x7fELF" or head[4] != 2:
        return False
    order = "little" if head[5] == 1 else "big"
    table_end = int.from_bytes(head[0x28:0x30], order) + int.from_bytes(head[0x3A:0x3C], order) * int.from_bytes(
        head[0x3C:0x3E], order)
    return 0 < table_end <= size
