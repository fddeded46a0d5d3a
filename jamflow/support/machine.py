"""What this machine has (stdlib only): its physical memory, for refusing runs that cannot fit before work."""

from __future__ import annotations

import os


def physical_memory() -> int | None:
    """Bytes of physical memory, or None where the platform does not tell."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


MAX_BINS = 10_000_000  # histogram bins: 80 MB per float64 array, far more than any measured curve resolves


def check_bins(count, option: str, hint: str = "") -> int:
    """``count`` histogram bins, or a one-line ValueError (before any allocation) if there are more
    than MAX_BINS: ``option`` names what chose them (``--bins``), ``hint`` how to choose fewer."""
    if count > MAX_BINS:
        need = 8.0 * (count + 1) / 2**30
        raise ValueError(f"{option} gives {count:.4g} histogram bins, which would need {need:.3g} GiB per array; "
                         f"the limit is {MAX_BINS:,} bins{'; ' + hint if hint else ''}")
    return int(count)
