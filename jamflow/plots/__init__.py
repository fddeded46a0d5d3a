"""The figures layer: matplotlib (Agg canvas) figures of packings, spectra, moduli, shear paths,
structure and walls, written atomically."""
