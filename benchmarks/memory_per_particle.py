"""Peak memory per particle of a jam run (start, engine, a few minimisations), the basis of
jamflow.protocols.compression.BYTES_PER_PARTICLE (the refusal of an N that cannot fit).

    python benchmarks/memory_per_particle.py 131072 2 numba     (one run per process: ru_maxrss is a peak)

Prints N, dim, engine, resident memory after the imports, the peak, and (peak - base) / N.
"""

import resource
import sys
import warnings

from jamflow.minimize.settings import MinimizerSettings
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.settings import fast_protocol
from jamflow.protocols.compression import jam


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    n, dim, engine = int(argv[0]), int(argv[1]), argv[2]
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # kB on Linux
    settings = fast_protocol(max_steps=2, minimizer=MinimizerSettings(max_iterations=200, window=100))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            jam(n=n, dim=dim, settings=settings, engine=engine)
        except JammingFailed:
            pass  # two minimisations are enough to allocate everything
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(f"N = {n} dim {dim} {engine}: base {base / 1024:.0f} MB, peak {peak / 1024:.0f} MB, "
          f"{(peak - base) * 1024 / n / 1000:.2f} kB per particle")


if __name__ == "__main__":
    main()
