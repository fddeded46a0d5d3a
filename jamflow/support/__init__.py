"""The lowest layer, standard library only: atomic file writes and output paths (``files``), the
cache directory and the check that a compiled shared object is whole (``cache``), progress as
plain lines where stderr is not a terminal (``progress``), a bad settings value named by its field
(``settings_errors``)."""

from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
