"""jamflow: jammed packings of soft, frictionless particles.

Generate them (isotropic compression to onset, chapter section 2.1, with the compiled engine
or LAMMPS), check their mechanical stability (dynamical matrix), measure their structure. The
package is layered (docs/architecture.md): model -> mechanics -> engines -> minimize -> protocols,
with analysis, io, plots, decks, ensemble and cli on top. Public names are imported lazily so
that ``import jamflow`` starts neither LAMMPS nor numba.
"""

from importlib import import_module

from jamflow.support import hooks

__version__ = "0.1.0"

_EXPORTS = {
    "Box": "jamflow.model.box",
    "Packing": "jamflow.model.packing",
    "random_packing": "jamflow.model.packing",
    "Spring": "jamflow.model.potentials",
    "RepulsiveLJ": "jamflow.model.potentials",
    "parse_potential": "jamflow.model.potentials",
    "parse_sizes": "jamflow.model.sizes",
    "parse_shape": "jamflow.model.shapes.parse",
    "contact_distance": "jamflow.model.shapes.contact_distance",
    "jam": "jamflow.protocols.compression",
    "JamSpec": "jamflow.protocols.spec",
    "run_jam": "jamflow.protocols.spec",
    "CompressionSettings": "jamflow.protocols.settings",
    "JamResult": "jamflow.protocols.outcome",
    "JammingFailed": "jamflow.protocols.outcome",
    "compress_above": "jamflow.protocols.above",
    "MinimizerSettings": "jamflow.minimize.settings",
    "check_packing": "jamflow.mechanics.checks",
    "save_packing": "jamflow.io.packing_file",
    "save_result": "jamflow.io.packing_file",
    "load_packing": "jamflow.io.packing_file",
    "run_ensemble": "jamflow.ensemble",
    "refine": "jamflow.protocols.refine",
    "refine_to_vtol": "jamflow.protocols.refine",
    "RefineSettings": "jamflow.protocols.refine",
    "RefineResult": "jamflow.protocols.refine",
}

__all__ = sorted(_EXPORTS)

# the layer packages (docs/architecture.md): ``jamflow.analysis`` etc. import on first use
LAYERS = ("support", "model", "mechanics", "engines", "minimize", "protocols", "analysis", "io", "decks", "plots",
          "ensemble", "cli")


def _save_result(result, path, checks=None, force=False):
    """``JamResult.save`` and ``PressureResult.save``: the protocols layer may not import the io
    layer, so this package (outside the layers) provides the writer through ``support.hooks``:
    ``jamflow.save_result``, loaded on use like every public name here (the io modules import
    ``jamflow.__version__``, so a static import of them here would be an import cycle)."""
    return __getattr__("save_result")(result, path, checks, force=force)


hooks.register("save_result", _save_result)


def _save_refined(result, path, force=False):
    """``RefineResult.save``: the io writer, provided here as ``_save_result`` is."""
    return import_module("jamflow.io.packing_file").save_refined(result, path, force=force)


hooks.register("save_refined", _save_refined)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    if name in LAYERS:
        return import_module(f"jamflow.{name}")
    raise AttributeError(f"module 'jamflow' has no attribute {name!r}")


def __dir__():
    """The public API (``__all__``), the layer packages and the version, not the module's helpers."""
    return sorted(set(__all__) | set(LAYERS) | {"__version__", "__all__", "__doc__", "__file__", "__name__",
                                                "__path__"})
