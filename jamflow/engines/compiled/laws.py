"""The potentials' laws in compiled kernels: ``energy_force(params, s)`` -> (V, dV/ds).

Dispatch is by the type of ``params`` (a potential's ``Params`` NamedTuple) at compile time:
numba compiles the potential's own ``energy_force`` function from ``jamflow.model.potentials``, so
the law is written once. Kernels call it only inside contact (s < 1).
"""

from __future__ import annotations

from jamflow.model.potentials import POTENTIALS, spring_of_overlap
from jamflow.engines.compiled import when_numba_starts

_LAWS = {cls.Params: cls.energy_force for cls in POTENTIALS.values()}


def energy_force(params, s):
    """(V, dV/ds) of the potential whose parameters are ``params``, at s = r / sigma < 1."""
    return _LAWS[type(params)](s, params)


def _register():
    import numba
    from numba.extending import overload

    @overload(energy_force, jit_options={"cache": True})
    def _energy_force(params, s):
        law = numba.njit(_LAWS[params.instance_class])

        def impl(params, s):
            return law(s, params)

        return impl

    @overload(spring_of_overlap, jit_options={"cache": True})
    def _spring_of_overlap(x, params):  # the spring's law of s calls its law of the overlap 1 - s
        law = numba.njit(spring_of_overlap)

        def impl(x, params):
            return law(x, params)

        return impl


when_numba_starts(_register)
