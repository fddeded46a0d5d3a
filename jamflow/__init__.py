"""jamflow: jammed packings of soft, frictionless particles.

Generate them with LAMMPS (isotropic compression, seed chapter section 2.1), check their
mechanical stability (dynamical matrix), measure their structure. Public names are
imported lazily so that ``import jamflow`` does not start LAMMPS.
"""

from importlib import import_module

__version__ = "0.1.0"

_EXPORTS = {
    "Box": "jamflow.box",
    "Packing": "jamflow.packing",
    "random_packing": "jamflow.packing",
    "Spring": "jamflow.potentials",
    "RepulsiveLJ": "jamflow.potentials",
    "parse_potential": "jamflow.potentials",
    "parse_sizes": "jamflow.sizes",
    "jam": "jamflow.protocols.compression",
    "CompressionSettings": "jamflow.protocols.compression",
    "compress_above": "jamflow.protocols.above",
    "MinimizerSettings": "jamflow.minimize",
    "save_packing": "jamflow.io",
    "load_packing": "jamflow.io",
    "contact_distance": "jamflow.shapes.contact_distance",
    "run_ensemble": "jamflow.ensemble",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'jamflow' has no attribute {name!r}")
