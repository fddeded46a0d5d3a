"""Ensembles of packings: one packing per Dask task into a resumable store, and the
distribution of jamming onsets (chapter section 2.4). Dask is imported only when a run starts."""

from jamflow.ensemble.runner import EnsembleReport, jam_parameters, run_ensemble, seed_range
from jamflow.ensemble.store import Store, Task

__all__ = ["EnsembleReport", "Store", "Task", "jam_parameters", "run_ensemble", "seed_range"]
