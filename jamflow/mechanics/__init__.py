"""The mechanics layer: physics of a packing, engine-independent, in numpy. The reference energy,
forces, torques and stress; contacts and floaters; pair terms, the Hessian and the dynamical
matrix and its lowest eigenpairs; deformations and strains; the checks a packing must pass. Imports
``model`` only."""
