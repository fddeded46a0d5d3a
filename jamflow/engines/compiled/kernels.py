"""The shape kernels and their dispatch.

Each kernel module defines ``KIND`` (the shape kind it runs), ``Pairs`` (its pair-list
NamedTuple), ``build(packing, x, skin) -> Pairs`` and the compiled
``forces(pairs, x, o, f, tau, virial) -> energy``; optionally ``COUNTERS``, the names of what its
kernel counts in ``Pairs.counters`` (an int64 array the engine adds up over pair lists), and
``TURNING_MOVES_SITES = False`` when rotations cannot bring a pair into reach of its list (then
only translations count towards a rebuild). ``evaluate`` picks the kernel by the type
of the pair list at compile time (the kernel is looked up then: before numba starts, a module's
``forces`` is a ``Deferred``). A new shape is one more module in ``MODULES``.
"""

from __future__ import annotations

from jamflow.engines.compiled import bodies, ellipsoids, spheres, when_numba_starts

MODULES = (spheres, bodies, ellipsoids)
MODULE_OF_PAIRS = {m.Pairs: m for m in MODULES}
BUILDERS = {m.KIND: m.build for m in MODULES}
COUNTERS = {m.KIND: getattr(m, "COUNTERS", ()) for m in MODULES}  # names of a kernel's ``Pairs.counters``
TURNING_MOVES_SITES = {m.KIND: getattr(m, "TURNING_MOVES_SITES", True) for m in MODULES}


def evaluate(model, x, o, f, tau, virial):
    """Energy; fills forces f (N, d), world torques tau (N, r) and the virial (d, d)."""
    return MODULE_OF_PAIRS[type(model)].forces(model, x, o, f, tau, virial)


def _register():
    from numba.extending import overload

    @overload(evaluate, jit_options={"cache": True})
    def _evaluate(model, x, o, f, tau, virial):
        kernel = MODULE_OF_PAIRS[model.instance_class].forces

        def impl(model, x, o, f, tau, virial):
            return kernel(model, x, o, f, tau, virial)

        return impl


when_numba_starts(_register)
