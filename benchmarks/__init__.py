"""jamflow's benchmark suite: one table of the maintained benchmarks (``python -m benchmarks list``).

Each entry is a script ``benchmarks/NAME.py`` with ``main(argv=None)``; ``quick`` is the argv
of its small, fast mode (``{tmp}`` is replaced by a scratch directory, so a quick run never
writes into docs/notes/) or None for no quick mode. Kinds: speed (time of one thing), scaling (time
against N), accuracy (a result against a reference), study (regenerates a documented study or
figure). Retired scripts are in ARCHIVE.md. This module imports nothing heavy: ``list`` is instant.
"""

from __future__ import annotations

from typing import NamedTuple


class Benchmark(NamedTuple):
    kind: str
    description: str
    quick: list[str] | None = None


KINDS = ("speed", "scaling", "accuracy", "study")

BENCHMARKS: dict[str, Benchmark] = {
    # --- speed -----------------------------------------------------------------------------------
    "speed_table": Benchmark(
        "speed", "default `jamflow jam` (whole process and in process) against the hand-written LAMMPS protocol",
        ["--n", "64", "--seeds", "1", "--handwritten", "64", "--process-max", "64", "--out", "{tmp}/speed-table.csv",
         "--trace", "{tmp}/trace.csv"]),
    "jump_ratio": Benchmark(
        "speed", "whole default jams against the fast protocol's Newton-jump ratio, phi_J paired by seed",
        ["--n", "64", "--seeds", "1:3", "--ratios", "10", "3", "--out", "{tmp}/jump-ratio.csv"]),
    "newton_minimizer": Benchmark(
        "speed", "the Newton-Krylov minimiser against FIRE: single minimisations above onset, whole jams by creep method",
        ["single", "--n", "64", "--seeds", "1", "--dphi", "1e-6", "--out", "{tmp}/newton-single.csv"]),
    "startup": Benchmark(
        "speed", "start-up of the jamflow command (--help, jam --n 64), its floors and a jam's first second",
        ["--repeats", "1", "--out", "{tmp}/startup.csv"]),
    "aot_startup": Benchmark(
        "speed", "whole `jam --n 64` processes with the AOT kernels against numba's, bytecode removed / cached",
        ["--repeats", "1", "--bytecode", "asis", "--out", "{tmp}/aot-startup.csv"]),
    "kernel": Benchmark(
        "speed", "compiled FIRE iteration against its bare force-loop floor; Morton order; skins",
        ["--sizes", "256", "--skins", "0.3", "--repeats", "1", "--out", "{tmp}/kernel.csv"]),
    "polish_factor": Benchmark(
        "speed", "the polish's factorisation (SuperLU, CHOLMOD) with particles in random and Morton order",
        ["--n", "512", "--repeats", "1", "--relax", "2000", "--out", "{tmp}/polish-factor.csv"]),
    "threads": Benchmark(
        "speed", "the compiled engine's threaded FIRE against its serial kernels per iteration, side by side (2D, 3D)",
        ["--sizes", "512", "--sizes-3d", "256", "--iterations", "50", "--repeats", "1", "--relax", "100",
         "--out", "{tmp}/threads.csv"]),
    "engines": Benchmark(
        "speed", "LAMMPS FIRE against the compiled FIRE: cost per iteration and whole packings",
        ["--sizes", "256", "--iterations", "200", "--reps", "1", "--jam-n", "64", "--jam-seeds", "1",
         "--out", "{tmp}/engines.csv"]),
    "ellipse_kernel_speed": Benchmark(
        "speed", "compiled ellipse kernel (every contact method) against the disk kernel and LAMMPS's plugin",
        ["--n", "128", "--iterations", "100", "--repeat", "1", "--out", "{tmp}/ellipse-kernel-speed.csv"]),
    "contact_distance_speed": Benchmark(
        "speed", "evaluations per second against accuracy of the contact-distance methods (vectorised numpy)",
        ["--n", "2000", "--repeat", "1", "--out-dir", "{tmp}"]),
    "pair_search": Benchmark(
        "speed", "float64 pair search in orthogonal and sheared cells beside freud's float32 one",
        ["--sizes", "1024", "--reps", "1", "--out", "{tmp}/pair-search.csv"]),
    "pair_styles": Benchmark(
        "speed", "LAMMPS pair styles jamflow can use, side by side (plugin, lepton/sphere, built-in)",
        ["--n", "64", "--iterations", "50", "--repeats", "1"]),
    "structure_timing": Benchmark(
        "speed", "wall-clock cost of the structure analyses (jamflow float64 against freud float32)",
        ["--n", "1024"]),
    "hessian_shapes_timing": Benchmark(
        "speed", "CPU seconds to build the sparse dynamical matrix of every shape against N",
        ["--sizes", "64"]),
    "memory_per_particle": Benchmark(
        "speed", "peak memory per particle of a jam run (basis of BYTES_PER_PARTICLE; one run per process)"),
    "ensemble_throughput": Benchmark(
        "speed", "200 packings on a 2-worker local cluster against a plain loop of jamflow jam (docs/notes/ensembles.md)"),
    # --- scaling ---------------------------------------------------------------------------------
    "scaling": Benchmark(
        "scaling", "time per packing against N: Python controller, LAMMPS deck (1 and 2 ranks), defaults",
        ["run", "--n", "32", "--seeds", "0", "--modes", "default", "controller-fast", "deck", "--limit", "60", "--strict",
         "--out", "{tmp}/scaling.csv"]),
    "modes_scaling": Benchmark(
        "scaling", "stability analysis (dynamical matrix, spectrum) against N, 2D disks above jamming",
        ["--sizes", "64", "--dense-max", "64"]),
    # --- accuracy --------------------------------------------------------------------------------
    "speed_accuracy": Benchmark(
        "accuracy", "time per packing against the error in phi_J, one protocol parameter varied at a time",
        ["run", "--n", "32", "--seeds", "0", "--variants", "seed", "dphi0=1e-3", "--limit", "60", "--strict",
         "--out", "{tmp}/speed-accuracy.csv"]),
    "shortcut_bias": Benchmark(
        "accuracy", "bias of mean phi_J for each protocol shortcut (paired against the chapter protocol)",
        ["run", "--n", "32", "--seeds", "0", "--variants", "seed", "fast (all)", "--limit", "60", "--strict",
         "--out", "{tmp}/shortcut-bias.csv"]),
    "protocol_bias": Benchmark(
        "accuracy", "does a protocol shortcut bias phi_J? variants against the exact protocol, same seeds",
        ["--n", "32", "--seeds", "1", "--variants", "seed", "fast", "--out", "{tmp}/protocol-bias.csv"]),
    "refine_cost": Benchmark(
        "speed", "double-double refinement to p = 1e-14 against the float64 onset (N = 64, 256; docs/guide/precision.md)",
        ["--n", "64", "--seeds", "1", "--out", "{tmp}/refine-cost.csv"]),
    "dd_vtol": Benchmark(
        "accuracy", "jam --precision double-double --vtol V: refinements, V / V_tol, pressure (N = 64, 256; docs/guide/precision.md)",
        ["--n", "64", "--vtol", "2e-35", "--seeds", "1"]),
    "dd_read": Benchmark(
        "accuracy", "a double-double file read back: contacts, zero modes, G, P from hi + lo against float64 (docs/guide/precision.md)",
        ["--n", "64", "--seeds", "2", "2"]),
    "pressure_ladder": Benchmark(
        "study", "pressure ladder 1e-2 .. 1e-14 in double-double: Delta z and G against p N^2, phi_J (docs/guide/precision.md)",
        ["--quick", "--out", "{tmp}/pressure-ladder.csv"]),
    "vtol_resolution": Benchmark(
        "accuracy", "where V_tol stops being resolvable in float64 (docs/notes/vtol-resolution.csv; minutes)"),
    "spring_exponents": Benchmark(
        "accuracy", "which spring exponents end in a checked packing (basis of SPRING_ALPHA_RANGE)"),
    "table_2_1": Benchmark(
        "accuracy", "chapter Table 2.1 and Figure 2.12: errors of the contact-distance approximations"),
    # --- studies (documented results and figures) ---------------------------------------------------
    "jamming_ensembles": Benchmark("study", "acceptance ensembles of jamming: 2D disks N=256, 3D spheres N=512"),
    "walls_gravity_pressure": Benchmark("study", "walls, gravity and constant-pressure ensembles (docs/notes/walls-gravity-pressure.md)"),
    "structure_data": Benchmark("study", "generate (and cache) the jammed packings behind docs/notes/structure.md"),
    "structure_measure": Benchmark("study", "the measured values and figures of docs/notes/structure.md"),
    "ellipse_ensembles": Benchmark("study", "jammed 2D bidisperse ellipses at several aspect ratios, checked"),
    "ellipse_ensemble_modes": Benchmark("study", "checks and spectra of the kept ellipse packings"),
    "ellipse_routes": Benchmark("study", "compiled FIRE against LAMMPS damped dynamics for ellipses, same starts"),
    "ellipse_spectra": Benchmark("study", "sorted normal-mode frequencies of ellipse packings (chapter Fig. 2.17)"),
    "ellipse_moduli": Benchmark("study", "shear modulus of ellipse packings against phi - phi_J (chapter Fig. 2.33)"),
    "anneal_vs_compression": Benchmark("study", "particle-shape annealing against compression (chapter Fig. 2.18)"),
    "nematic_protocols": Benchmark("study", "nematic order of ellipse packings: annealing against compression"),
    "contact_methods": Benchmark("study", "CPU per packing against phi_J / <z> bias of the contact methods"),
    "nmer_ensembles": Benchmark("study", "n-mer (dimer, trimer) ensembles, checked (docs/notes/nmers.md)"),
    "nmer_figures": Benchmark("study", "the figures and tables of docs/notes/nmers.md from the n-mer CSVs"),
    "nmer_stability": Benchmark("study", "checks and stability (dynamical matrix with rotations) of the n-mer ensembles"),
    "nmer_crosscheck": Benchmark("study", "LAMMPS vs compiled engine vs numpy reference for rigid n-mers: energy, forces, torques, pressure"),
    "modes_ensemble": Benchmark("study", "ensemble for the stability measurements of docs/notes/modes.md"),
    "modes_hessian_check": Benchmark("study", "analytic dynamical matrix against LAMMPS finite differences"),
    "modes_shapes_data": Benchmark("study", "jammed dimer packings behind docs/notes/modes-rotations.md"),
    "reference_jam": Benchmark("study", "small 2D packings jammed on the numpy reference energy (tests/data/)"),
    "soft_modes": Benchmark("study", "where a creeping minimisation's residual force lies (docs/notes/soft-modes.md)"),
    "creep_after": Benchmark(
        "study", "whole jams of turning shapes against the soft-mode steps' creep_after (docs/notes/ellipses.md)",
        ["run", "--dim", "2", "--sizes", "bi:1.4:0.5", "--shape", "ellipse:1.5", "--n", "16", "--seeds", "1",
         "--creep-after", "10000", "--strict", "--out", "{tmp}/creep-after.csv"]),
    "moduli_ensemble": Benchmark("study", "ensemble moduli G, B, P against phi - phi_J (docs/notes/moduli.md)"),
    "shear_path": Benchmark("study", "one quasistatic shear path, drawn, and what a step costs"),
    "shear_symmetry": Benchmark("study", "unit period and mirror symmetry of jamming at fixed strain"),
    "shear_cell_checks": Benchmark("study", "the Lees-Edwards checks of docs/notes/shear-cell.md, as numbers"),
    "family_checks": Benchmark("study", "how many jammed packings random starts find at one strain"),
    "families_stats": Benchmark("study", "the numbers docs/notes/shear.md quotes about a family sampling (needs DIR)"),
}

SUPPORT = ("__init__", "__main__", "common")
