"""The files layer: every file jamflow writes or reads. Packing files (``packing_file``, HDF5
schema ``jamflow.packing``), shear paths, family points, exports for viewers, LAMMPS files read
through MDAnalysis (``readers``). Atomic writes come from ``jamflow.support.files``; LAMMPS data
files are the LAMMPS engine's (``write_lammps_data``, from ``jamflow.engines.lammps.data_file``)."""

from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.io.packing_file import (SCHEMA, SCHEMA_VERSION, load_packing, open_hdf5, read_attrs, read_checks,
                                     read_history, read_protocol, read_table, save_packing, to_universe)
from jamflow.support.files import atomic_path, check_writable, output_directory, replacing
from jamflow.support.lazy import lazy_submodules as _lazy_submodules

__all__ = ["SCHEMA", "SCHEMA_VERSION", "atomic_path", "check_writable", "load_packing", "open_hdf5",
           "output_directory", "read_attrs", "read_checks", "read_history", "read_protocol", "read_table",
           "replacing", "save_packing", "to_universe", "write_lammps_data"]

__getattr__, __dir__ = _lazy_submodules(__name__, __path__)  # dir() lists the modules; each imports on use
