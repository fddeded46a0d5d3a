"""The lowest layer, standard library only: atomic file writes and output paths (``files``), the
cache directory and the check that a compiled shared object is whole (``cache``)."""
