"""The model layer: what a packing is. Box, particle sizes, potentials, shapes, the ``Packing``
value object, the pair search and the wall geometry. Imports nothing else of jamflow."""
