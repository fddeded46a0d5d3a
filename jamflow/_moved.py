"""Old module paths (before the layered package, docs/architecture.md) kept importable: ``import jamflow.checks``
gives a module that forwards every name to its new home (``jamflow.mechanics.checks``) and warns
once with the new path (DeprecationWarning). Stdlib only; nothing inside jamflow imports an old path."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings

MOVED = {
    "jamflow.box": ("jamflow.model.box",),
    "jamflow.sizes": ("jamflow.model.sizes",),
    "jamflow.potentials": ("jamflow.model.potentials",),
    "jamflow.packing": ("jamflow.model.packing",),
    "jamflow.pairs": ("jamflow.model.pairs",),
    "jamflow.walls": ("jamflow.model.walls", "jamflow.model.packing",),
    "jamflow.shapes": ("jamflow.model.shapes", "jamflow.plots.ellipse_pair"),
    "jamflow.shapes.contact_distance": ("jamflow.model.shapes.contact_distance",),
    "jamflow.shapes.nmers": ("jamflow.model.shapes.nmers",),
    "jamflow.shapes.rotations": ("jamflow.model.shapes.rotations",),
    "jamflow.shapes.shape": ("jamflow.model.shapes.shape", "jamflow.model.shapes.parse",),
    "jamflow.shapes.union": ("jamflow.model.shapes.union",),
    "jamflow.shapes.ellipse_plot": ("jamflow.plots.ellipse_pair",),
    "jamflow.engine.reference": ("jamflow.mechanics.reference",),
    "jamflow.analysis.contacts": ("jamflow.mechanics.contacts",),
    "jamflow.analysis.hessian": ("jamflow.mechanics.hessian", "jamflow.mechanics.dynamical_matrix",),
    "jamflow.analysis.deformation": ("jamflow.mechanics.deformation",),
    "jamflow.analysis.strains": ("jamflow.mechanics.strains",),
    "jamflow.analysis.elastic": ("jamflow.mechanics.elastic",),
    "jamflow.checks": ("jamflow.mechanics.checks",),
    "jamflow.engine": ("jamflow.engines",),
    "jamflow.engine.base": ("jamflow.engines.base", "jamflow.engines.choose",),
    "jamflow.engine.compiled": ("jamflow.engines.compiled",),
    "jamflow.engine.compiled.aot": ("jamflow.engines.compiled.aot",),
    "jamflow.engine.compiled.aot_build": ("jamflow.engines.compiled.aot_build",),
    "jamflow.engine.compiled.bodies": ("jamflow.engines.compiled.bodies",),
    "jamflow.engine.compiled.cells": ("jamflow.engines.compiled.cells",),
    "jamflow.engine.compiled.ellipsoids": ("jamflow.engines.compiled.ellipsoids",),
    "jamflow.engine.compiled.engine": ("jamflow.engines.compiled.engine",),
    "jamflow.engine.compiled.field": ("jamflow.engines.compiled.field",),
    "jamflow.engine.compiled.fire": ("jamflow.engines.compiled.fire",),
    "jamflow.engine.compiled.kernels": ("jamflow.engines.compiled.kernels",),
    "jamflow.engine.compiled.laws": ("jamflow.engines.compiled.laws",),
    "jamflow.engine.compiled.rotation": ("jamflow.engines.compiled.rotation",),
    "jamflow.engine.compiled.spheres": ("jamflow.engines.compiled.spheres",),
    "jamflow.engine.lammps": ("jamflow.engines.lammps.engine",),
    "jamflow.engine.lammps_bodies": ("jamflow.engines.lammps.bodies",),
    "jamflow.engine.lammps_lib": ("jamflow.engines.lammps.library",),
    "jamflow.engine.pair_styles": ("jamflow.engines.lammps.pair_styles",),
    "jamflow.engine.plugin_build": ("jamflow.engines.lammps.plugin_build", "jamflow.support.cache",),
    "jamflow.engine.plugin": ("jamflow.engines.lammps.plugin",),
    "jamflow.polish": ("jamflow.minimize.polish",),
    "jamflow.soft_modes": ("jamflow.minimize.soft_modes",),
    "jamflow.analysis.sweeps": ("jamflow.protocols.sweeps",),
    "jamflow.analysis.moduli": ("jamflow.protocols.moduli",),
    "jamflow.shear_file": ("jamflow.io.shear_file", "jamflow.io.families_file",),
    "jamflow.export": ("jamflow.io.export",),
    "jamflow.analysis.readers": ("jamflow.io.readers",),
    "jamflow.drawing": ("jamflow.plots.drawing",),
    "jamflow.analysis.plots_modes": ("jamflow.plots.modes",),
    "jamflow.analysis.plots_moduli": ("jamflow.plots.moduli",),
    "jamflow.analysis.plots_shear": ("jamflow.plots.shear",),
    "jamflow.analysis.plots_structure": ("jamflow.plots.structure",),
    "jamflow.analysis.plots_walls": ("jamflow.plots.walls",),
    "jamflow.deck": ("jamflow.decks.jam",),
    "jamflow.deck_script": ("jamflow.decks.jam_script",),
    "jamflow.deck_ellipsoids": ("jamflow.decks.ellipsoids",),
    "jamflow.deck_ellipsoids_script": ("jamflow.decks.ellipsoids_script",),
    "jamflow.shear_deck": ("jamflow.decks.shear",),
    "jamflow.crosscheck": ("jamflow.decks.crosscheck",),
    "jamflow.console": ("jamflow.cli.console",),
    "jamflow.progress": ("jamflow.cli.progress",),
    "jamflow.commands": ("jamflow.cli.commands",),
    "jamflow.commands.analyze": ("jamflow.cli.commands.analyze", "jamflow.io.structure_file"),
    "jamflow.commands.anneal": ("jamflow.cli.commands.anneal",),
    "jamflow.commands.crosscheck": ("jamflow.cli.commands.crosscheck",),
    "jamflow.commands.draw": ("jamflow.cli.commands.draw",),
    "jamflow.commands.ensemble": ("jamflow.cli.commands.ensemble",),
    "jamflow.commands.export": ("jamflow.cli.commands.export",),
    "jamflow.commands.families": ("jamflow.cli.commands.families",),
    "jamflow.commands.jam": ("jamflow.cli.commands.jam",),
    "jamflow.commands.modes": ("jamflow.cli.commands.modes", "jamflow.io.modes_file"),
    "jamflow.commands.moduli": ("jamflow.cli.commands.moduli", "jamflow.io.moduli_file"),
    "jamflow.commands.onsets": ("jamflow.cli.commands.onsets",),
    "jamflow.commands.shear": ("jamflow.cli.commands.shear",),
}


class _Forwarding(types.ModuleType):
    """An old path: attributes come from the new modules, in order."""

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        for target in MOVED[self.__name__]:
            module = importlib.import_module(target)
            if hasattr(module, name):
                return getattr(module, name)
        raise AttributeError(f"module {self.__name__!r} (now {MOVED[self.__name__][0]!r}) has no attribute {name!r}")

    def __dir__(self):
        return sorted({n for t in MOVED[self.__name__] for n in dir(importlib.import_module(t))})


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, fullname, path=None, target=None):
        if fullname not in MOVED:
            return None
        package = any(name.startswith(fullname + ".") for name in MOVED)
        return importlib.machinery.ModuleSpec(fullname, self, is_package=package)

    def create_module(self, spec):
        return _Forwarding(spec.name)

    def exec_module(self, module):
        new = MOVED[module.__name__][0]
        warnings.warn(f"{module.__name__} moved to {new} (jamflow's layered package, docs/architecture.md); "
                      f"import it from there", DeprecationWarning, stacklevel=2)
        importlib.import_module(new)  # fail here, with the new name, if it cannot load


def install() -> None:
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.append(_OldPaths())
