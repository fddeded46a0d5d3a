"""Build the ahead-of-time module of ``aot``: ``python -m jamflow.engines.compiled.aot_build OUT_DIR [TARGET_CPU]``.

numba.pycc compiles the compiled engine's own disk/sphere FIRE and force evaluation with the spring
law -- the very functions ``fire.fire`` and ``fire.forces`` over the ``spheres`` kernel, behind
wrappers of plain arrays with explicit signatures that build the ``Pairs`` / ``Field`` /
``SpringParams`` tuples inside compiled code -- and ``cells.cell_pairs`` into one extension module
that imports no numba at run time (docs/notes/speed-2.md sections 10 and 12). ``aot`` runs this in a
subprocess and moves the module into its cache.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

from jamflow.model.potentials import SpringParams
from jamflow.engines.compiled import cells, start_numba
from jamflow.engines.compiled.aot import MODULE
from jamflow.engines.compiled.field import Field
from jamflow.engines.compiled.fire import fire, forces
from jamflow.engines.compiled.spheres import Pairs

A1, A2, A3, I1 = "float64[::1]", "float64[:, ::1]", "float64[:, :, ::1]", "int64[::1]"
_PAIRS_AND_FIELD = (f"{I1}, {I1}, {A2}, {A1}, float64, float64, "  # i, j, shift, sigma, alpha, epsilon
                    f"{A2}, {A1}, {A1}, {A1}, boolean, float64, {A3}, float64, float64")  # Field without its law
FIRE_SIGNATURE = (f"Tuple((int64, int64, float64))({_PAIRS_AND_FIELD}, "
                  f"{A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A1}, {A2}, {A1}, {A1}, {A1}, {A2}, {A1}, {A1}, "
                  "float64, int64, float64, float64)")
FORCES_SIGNATURE = f"float64({_PAIRS_AND_FIELD}, {A2}, {A2}, {A2}, {A2}, {A2}, {A2}, {A1}, {A2}, {A1})"
CELL_PAIRS_SIGNATURE = "Tuple((int64[::1], int64[::1]))(float64[:, ::1], float64[::1], int64[::1], float64)"


def fire_spheres_spring(pi, pj, shift, sigma, alpha, epsilon, h, walled, half, mobile, any_fixed, gravity, basis,
                        pressure, length, x, v, f, o, w, tau, g, dk, mask, virial, ub, gb, state, x_built, turned,
                        reach, half_skin_sq, max_steps, ftol, energy_halt):
    """``fire.fire`` on a ``spheres.Pairs`` list with ``SpringParams(alpha, epsilon)``."""
    law = SpringParams(alpha, epsilon)
    return fire(Pairs(pi, pj, shift, sigma, law),
                Field(h, walled, law, half, mobile, any_fixed, gravity, basis, pressure, length),
                x, v, f, o, w, tau, g, dk, mask, virial, ub, gb, state, x_built, turned, reach, half_skin_sq,
                max_steps, ftol, energy_halt)


def forces_spheres_spring(pi, pj, shift, sigma, alpha, epsilon, h, walled, half, mobile, any_fixed, gravity, basis,
                          pressure, length, x, f, o, tau, g, dk, mask, virial, gb):
    """``fire.forces`` on a ``spheres.Pairs`` list with ``SpringParams(alpha, epsilon)``."""
    law = SpringParams(alpha, epsilon)
    return forces(Pairs(pi, pj, shift, sigma, law),
                  Field(h, walled, law, half, mobile, any_fixed, gravity, basis, pressure, length),
                  x, f, o, tau, g, dk, mask, virial, gb)


def build(out_dir: Path, target_cpu: str = "host") -> None:
    """Compile the module ``MODULE`` into ``out_dir`` for ``target_cpu`` ("host": this CPU, as numba's
    own kernels; "": pycc's generic target, 5-19 % slower per iteration, docs/notes/speed-2.md section 10)."""
    start_numba()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NumbaPendingDeprecationWarning: pycc (still in numba 0.68)
        from numba.pycc import CC
    cc = CC(MODULE)
    cc.output_dir = str(out_dir)
    cc.target_cpu = target_cpu
    cc.verbose = False
    exports = {"fire_spheres_spring": (fire_spheres_spring, FIRE_SIGNATURE),
               "forces_spheres_spring": (forces_spheres_spring, FORCES_SIGNATURE),
               "cell_pairs": (cells.cell_pairs.py_func, CELL_PAIRS_SIGNATURE)}
    for name, (function, signature) in exports.items():
        cc.export(name, signature)(function)
    cc.compile()


if __name__ == "__main__":  # run the package's module, whose globals start_numba swaps (not __main__'s)
    from jamflow.engines.compiled import aot_build

    aot_build.build(Path(sys.argv[1]), *sys.argv[2:3])
