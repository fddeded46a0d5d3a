"""Isotropic compression to jamming onset (chapter section 2.1, steps 1-4).

Start from random positions (and orientations) at phi0; after each minimisation compress by dphi if
V < V_tol, decompress if V > 2 V_tol, halve dphi whenever the state crosses from one
side to the other, and stop when V_tol < V < 2 V_tol (V is the energy per particle).
Box changes are affine (LAMMPS ``change_box ... remap``); the box is always set from
the original one so phi carries no accumulated round-off. With walls (``jamflow.model.walls``)
the walls are the box faces and move with it, phi is measured between them, and the same
bisection runs unchanged; under gravity ``jam`` settles the packing instead
(``jamflow.protocols.gravity``).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import replace

import numpy as np

from jamflow.engines.choose import check_engine, open_engine
from jamflow.minimize.rules import minimize
from jamflow.minimize.settings import MinimizeResult, MinimizerSettings
from jamflow.model.packing import DENSEST_PHI, Packing, SeparationFailed, densest_phi, random_packing
from jamflow.model.potentials import POTENTIALS, Potential, Spring, parse_potential
from jamflow.model.shapes.parse import parse_shape
from jamflow.model.shapes.rotations import check_start
from jamflow.model.sizes import SizeSpec, parse_sizes
from jamflow.model.walls import parse_walls, wall_loads, with_walls
from jamflow.protocols.outcome import HISTORY_COLUMNS, JammingFailed, JamResult, record_minimization
from jamflow.protocols.settings import DEFAULT_PROTOCOL, PROTOCOLS, CompressionSettings
from jamflow.support.machine import physical_memory

NEWTON_FINAL_FACTOR = 3.0  # intermediate jumps stop at >= 3x the window's predicted distance from phi_J
LOOSE_TRUST = 10.0  # a loosely minimised state decides its side only if V > 10 V_tol
WINDOW_RESUMES = 3  # a state in the window cut off by the iteration cap is minimised again (at most 3 times a run)
GAP_CLOSING_STEPS = 10  # polish steps at most for a packing in the window that is short of isostatic


def jam(n: int = 64, dim: int = 2, sizes: str = "bi:1.4:0.5", potential: str | Potential = "spring",
        seed: int = 0, settings: CompressionSettings | None = None, *, start: Packing | None = None,
        observers=(), engine: str = "auto", engine_options: dict | None = None, shape="disk",
        walls=None, wall_type: str = "smooth", gravity: float = 0.0, contact: str = "exact",
        gamma: float | None = None, orientations: str = "random") -> JamResult:
    """Jam N particles by isotropic compression; ``start`` overrides the random start.

    The defaults are those of ``jamflow jam`` and ``JamSpec`` (N = 64, 2D, 50:50 bidisperse 1 : 1.4
    disks, springs, seed 0, the fast protocol).

    ``shape``: a ``--shape`` spec or shape object (``jamflow.model.shapes``; default disks/spheres);
    ``sizes`` scale whole particles (an ellipse's b; a = ALPHA b). ``contact``: the contact-distance
    method of ellipses/spheroids (exact, gaussian, cleaver, linear, quadratic).
    ``orientations``: the start's orientations of particles with an axis, "random" (uniform) or
    "aligned" (every director along x, a nematic start) or "nematic:S" (a partially nematic start
    about x, P2 = S; ``rotations.start_orientations``).
    ``walls``: walled axes (``"y"``, ``"x,y"``, ...; ``jamflow.model.walls``) of ``wall_type``
    smooth or rough. ``gravity`` g > 0 settles the packing on the floor instead of
    compressing it (``jamflow.protocols.gravity``; needs walls on the last axis).
    A start of a potential that diverges at contact (repulsive LJ) with deep overlaps (the
    random one always) is first relaxed with the linear spring (``remove_overlaps``).
    ``gamma``: jam at this fixed Lees-Edwards shear strain (chapter section 2.2; any finite value,
    the random start placed in the sheared cell, see ``at_shear_strain``); the packing's box
    carries gamma as its accumulated strain (periodic cells only).
    ``observers`` are callables ``f(step: dict)`` called after every minimisation
    (progress bars, writers). ``engine``: "auto" (the compiled engine wherever it runs the
    scene, else LAMMPS), "lammps" or "numba" (``jamflow.engines.base``).

    Parameters
    ----------
    n : int
        Number of particles N (>= 2).
    dim : int
        Dimension, 2 or 3.
    sizes : str or jamflow.model.sizes.SizeSpec
        Size distribution (``mono``, ``bi:RATIO:FRACTION_SMALL``, ``poly-uniform:WIDTH``, ...);
        the small diameter is the unit of length.
    potential : str or Potential
        Pair law: ``spring`` (alpha = 2), ``hertz``, ``spring:ALPHA`` or ``rlj``; energies in eps.
    seed : int
        Random seed of the start (0 <= seed < 2^63).
    settings : jamflow.CompressionSettings, optional
        The protocol (``fast_protocol()``, the default, or ``chapter_protocol()``): V_tol (eps per
        particle), dphi0, phi0 and the minimiser's settings.
    start : jamflow.Packing, optional
        Start from this packing instead of a random one (its box and phi).
    observers : sequence of callables, optional
        Each called as ``f(step)`` after every minimisation.
    engine : str
        ``auto``, ``lammps`` or ``numba``.
    engine_options : dict, optional
        Options of the engine's constructor (compiled: ``skin``, ``threads``; LAMMPS: ``skin``,
        ``comm``, ``args``); an option the engine does not take is refused.
    shape : str or shape object
        ``disk`` (disks/spheres), ``ellipse:ALPHA``, ``spheroid:ALPHA``, ``nmer:N:ALPHA``, ...
    walls : str, optional
        Walled axes, e.g. ``"y"``; None: periodic in every axis.
    wall_type : str
        ``smooth`` or ``rough``.
    gravity : float
        g, force per particle in eps / diameter; > 0 settles the packing instead.
    contact : str
        Contact distance of ellipses/spheroids: ``exact``, ``gaussian`` or ``cleaver``.
    gamma : float, optional
        Fixed Lees-Edwards shear strain (dimensionless).
    orientations : str
        ``random``, ``aligned`` or ``nematic:S``.

    Returns
    -------
    jamflow.JamResult
        The packing at onset with phi_J, V per particle (eps), the pressure tensor
        (eps / diameter^d), the max force (eps / diameter) and the history of every minimisation.

    Raises
    ------
    ValueError, TypeError
        A bad argument, before any work.
    jamflow.JammingFailed
        No packing landed in the window (the message says what to change).
    """
    if settings is None:
        settings = PROTOCOLS[DEFAULT_PROTOCOL]()
    if not isinstance(settings, CompressionSettings):
        raise TypeError(f"settings must be a CompressionSettings, e.g. fast_protocol() or chapter_protocol() from "
                        f"jamflow.protocols.settings, got {settings!r}")
    check_engine(engine)
    if gamma is not None:
        check_strain(gamma)
        if start is not None:
            raise ValueError("gamma sets the strain of the random start; a given start keeps its own box "
                             "(shear it with start.box.with_shear_strain, or pass gamma=None)")
    random_start = start is None
    if random_start:
        start = initial_packing(n, dim, sizes, potential, seed, settings.start_phi(dim, gravity, shape), shape, walls,
                                wall_type, gravity, contact, orientations)
        if gamma is not None:
            start = at_shear_strain(start, gamma)
    elif not isinstance(start, Packing):
        raise TypeError(f"start must be a Packing (or None for a random start), got {type(start).__name__}")
    if start.potential.soft_start and (random_start or deepest_overlap(start) < RLJ_MIN_START_RATIO):
        start = remove_overlaps(start, settings.minimizer, engine)
    if start.gravity > 0:
        from jamflow.protocols.gravity import settle

        return settle(start, settings.minimizer, observers=observers, engine=engine, engine_options=engine_options)
    result = compress(start, settings, observers=observers, engine=engine, engine_options=engine_options)
    return result if gamma is None else with_accumulated_strain(result, gamma)


MAX_STRAIN = 1e6  # float64 keeps a strain's fractional part (its lattice, chapter Figure 2.4) to ulp(1e6) = 1.2e-10


def check_strain(gamma, name: str = "shear strain gamma") -> float:
    """A finite shear strain of magnitude at most ``MAX_STRAIN`` as a float; ValueError (naming
    the value as ``name``) otherwise."""
    if isinstance(gamma, bool) or not isinstance(gamma, (int, float, np.integer, np.floating)) \
            or not math.isfinite(gamma):
        raise ValueError(f"{name} must be a finite number, got {gamma!r}")
    if abs(gamma) > MAX_STRAIN:
        raise ValueError(f"{name} {gamma:g} is beyond +-{MAX_STRAIN:g}, where float64 no longer resolves the "
                         f"strain's fractional part (the lattice repeats at every integer strain); give a strain "
                         f"within +-{MAX_STRAIN:g}")
    return float(gamma)


def at_shear_strain(packing: Packing, gamma: float) -> Packing:
    """``packing`` (particles where they are, Cartesian) in the Lees-Edwards cell at strain
    ``gamma`` of its cell, held as the reduced strain gamma - k (k the nearest integer, the
    subtraction exact): cells at gamma and gamma + 1 are one lattice (chapter Figure 2.4), so
    strains that are exactly one apart as doubles run the same floating-point operations.
    ``with_accumulated_strain`` gives the result its accumulated strain back."""
    k = math.floor(check_strain(gamma) + 0.5)
    box = packing.box.with_shear_strain(float(gamma) - k)
    return packing.with_positions(box.wrap(packing.positions), box=box)


def with_accumulated_strain(result: "JamResult", gamma: float) -> "JamResult":
    """The result with its packing's box tilted to the accumulated strain ``gamma`` (xy = gamma
    ly; the same lattice as the reduced cell it was jammed in, to round-off in the tilt)."""
    packing = result.packing  # positions stay as the engine left them (inside the reduced cell)
    return replace(result, packing=packing.with_positions(packing.positions, box=packing.box.with_shear_strain(gamma)))


BYTES_PER_PARTICLE = 4096  # peak memory of a jam run: measured 1.1-2.2 kB per particle at N = 131072 (docs/hardening.md)
MAX_SEED = 2**63 - 1  # seeds are stored as int64 in the packing file


def check_start_orientations(orientations, particle, dim: int) -> None:
    """Refuse an unknown start of the orientations, and "aligned" or "nematic:S" for round
    particles (no axis)."""
    if check_start(orientations) is not None and not particle.oriented:
        raise ValueError(f"--orientations {orientations} applies to particles with an axis (ellipses, spheroids, "
                         f"rigid bodies), not to {particle.name(dim)}s: leave --orientations out")


def initial_packing(n, dim, sizes, potential, seed, phi0, shape="disk", walls=None, wall_type="smooth",
                    gravity=0.0, contact="exact", orientations="random") -> Packing:
    """Validated random start (chapter step 1), with walls and gravity if given; errors before any
    engine work. ``contact``: the contact-distance method of ellipses/spheroids; ``orientations``:
    "random", "aligned" or "nematic:S" (``rotations.start_orientations``; particles with an axis only)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    if isinstance(dim, bool) or not isinstance(dim, (int, np.integer)) or dim not in (2, 3):
        raise ValueError(f"dim must be the integer 2 or 3, got {dim!r}")
    if not 0.0 < phi0 < DENSEST_PHI[dim]:
        raise ValueError(f"phi0 = {phi0} must lie in (0, {DENSEST_PHI[dim]:.4f}), below the densest "
                         f"packing of equal {'disks' if dim == 2 else 'spheres'}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed must be an integer in [0, 2^63 - 1], got {seed!r}")
    _check_memory(int(n))
    pot = _potential(potential)
    size_spec = parse_sizes(sizes) if isinstance(sizes, str) else sizes
    if not isinstance(size_spec, SizeSpec):
        raise TypeError(f"sizes must be a spec string such as 'bi:1.4:0.5' or a SizeSpec, got {sizes!r}")
    particle = parse_shape(shape, int(dim), contact)
    check_start_orientations(orientations, particle, int(dim))
    axes = parse_walls(walls, int(dim))
    try:
        start = random_packing(int(n), int(dim), size_spec, phi0, int(seed), pot, particle,
                               separated=particle.made_of_sites, orientations=orientations)  # bodies: no overlaps (separated_positions)
    except SeparationFailed:
        raise
    except ValueError as err:
        if "box too small" in str(err):
            raise ValueError(f"{err} (n = {n} is too small for these sizes)") from None
        raise
    return replace(with_walls(start, axes, wall_type), gravity=gravity)


def _potential(potential) -> Potential:
    if isinstance(potential, str):
        return parse_potential(potential)
    if not isinstance(potential, tuple(POTENTIALS.values())):
        raise TypeError(f"potential must be a spec string (spring | hertz | spring:ALPHA | rlj) or a Spring or "
                        f"RepulsiveLJ, got {potential!r}")
    return potential


def _check_memory(n: int) -> None:
    """Refuse an N whose run cannot fit in this machine's memory, before allocating anything."""
    total = physical_memory()
    if total is not None and n * BYTES_PER_PARTICLE > total:
        raise ValueError(f"n = {n} needs about {n * BYTES_PER_PARTICLE / 1e9:.3g} GB of memory ({BYTES_PER_PARTICLE // 1024} kB "
                         f"per particle), more than this machine's {total / 1e9:.3g} GB; use n <= {total // BYTES_PER_PARTICLE}")


def remove_overlaps(packing: Packing, minimizer: MinimizerSettings, engine: str = "auto") -> Packing:
    """Relax a random start with the linear spring until V < V_min, so that a potential
    that diverges at r -> 0 (repulsive LJ) starts without significant overlaps (chapter step 1;
    from a raw random start RLJ forces reach ~1e13 and LAMMPS loses atoms). Without gravity: the
    weights would press the pile into overlaps (and add m g h to V) whatever phi0 is; the pile
    settles afterwards, with the packing's own potential. V_min is the chapter's (1e-16) unless the
    minimiser's is smaller: a large V_tol (the minimiser's V_min) would stop at once, overlaps kept."""
    minimizer = replace(minimizer, v_min=min(minimizer.v_min, MinimizerSettings.v_min))
    soft = replace(packing, potential=Spring(), gravity=0.0)
    with open_engine(soft, minimizer.method, engine) as sim:
        result = minimize(sim, minimizer)
        relaxed = sim.packing()
    if result.energy_per_particle >= minimizer.v_min:
        raise JammingFailed(f"the random start at phi0 = {packing.phi:.4f} does not relax to zero overlap "
                            f"(V = {result.energy_per_particle:.2e}): phi0 is above jamming; use a lower phi0")
    return replace(relaxed, potential=packing.potential, gravity=packing.gravity)


def compress(packing: Packing, settings: CompressionSettings, *, observers=(), engine: str = "auto",
             engine_options=None) -> JamResult:
    """Run the compression/decompression bisection from ``packing`` (chapter steps 2-4)."""
    _check_start(packing)
    check_resolution(packing, settings)
    if packing.gravity > 0:
        raise ValueError("a packing under gravity is settled, not compressed: use jam(..., gravity=g) or "
                         "jamflow.protocols.gravity.settle")
    check_window_reachable(packing, settings, engine)
    with open_engine(packing, settings.minimizer.method, engine, **(engine_options or {})) as sim:
        return bisect(sim, settings, observers=observers)


def bisect(sim, settings: CompressionSettings, *, observers=()) -> JamResult:
    """The bisection on an open engine from its current configuration and box, whose shape
    (and shear strain) it keeps: every box is the current one scaled (chapter steps 2-4). The
    engine is left holding the jammed packing (the shear protocol continues from it)."""
    from jamflow.engines.lammps.library import lammps_version

    start_time = time.perf_counter()
    current = sim.packing()  # phi and the volume it counts (walls: between them) of the current state
    base_box, base_phi = current.box, current.phi
    mean_volume = current.phi * current.box.volume / current.n_mobile  # the volume phi counts, per mobile particle
    stepper = PhiStepper(settings, current.potential.onset_exponent, mean_volume, current.n_mobile)
    rows = {c: [] for c in HISTORY_COLUMNS}
    phi, resumes = base_phi, 0
    for step in range(settings.max_steps):
        sim.set_box(base_box.scaled((base_phi / phi) ** (1.0 / current.dim)))
        minimizer = stepper.minimizer()
        result = minimize(sim, minimizer)
        if result.reason == "blown-up":
            raise JammingFailed(f"the minimisation at phi = {phi:.10f} diverged (V = {result.energy_per_particle:.3g}, "
                                f"max force {result.max_force:.3g}): lower the timestep, or for damped MD use "
                                "damping x md_timestep well below 2")
        pressure = sim.state().pressure
        record_minimization(rows, phi, result, pressure, stepper.last_step)
        for observe in observers:
            observe({"step": step, "phi": phi, "dphi": stepper.last_step, "result": result})
        v = result.energy_per_particle
        loose = minimizer.force_tol != settings.minimizer.force_tol
        if loose and result.reason != "energy-below-vmin" and v < LOOSE_TRUST * settings.v_tol:
            stepper.final_approach, stepper.last_step = True, 0.0  # too close to the window to trust
            continue  # a loose minimum: polish it in place with the full tolerance
        in_window = settings.v_tol < v < 2 * settings.v_tol and result.reason != "energy-below-vmin"
        if in_window and result.reason == "iteration-cap" and resumes < WINDOW_RESUMES:
            # not yet a minimum (near onset FIRE can creep off a saddle for 10^5-10^6
            # iterations, docs/notes/speed.md): keep minimising before the window decides
            resumes += 1
            stepper.last_step = 0.0
            continue
        closed = close_gaps(sim, result, settings) if in_window else None
        if closed is not None:  # a row of its own: the gaps closed at the same phi (dphi 0)
            result, v, pressure = closed, closed.energy_per_particle, sim.state().pressure
            record_minimization(rows, phi, result, pressure, 0.0)
            for observe in observers:
                observe({"step": step, "phi": phi, "dphi": 0.0, "result": result})
            in_window = settings.v_tol < v < 2 * settings.v_tol  # below it if FIRE had stopped above the minimum
        if in_window:
            jammed = _finish(sim, phi, result, rows, settings, start_time, lammps_version())
            _warn_fallbacks(jammed)
            return jammed
        phi = stepper.next_phi(phi, v, pressure, unjammed=result.reason == "energy-below-vmin")
    raise JammingFailed(f"no packing in the window {settings.v_tol:g} < V < {2 * settings.v_tol:g} after "
                        f"{settings.max_steps} minimisations (last phi = {phi}); raise max_steps or check "
                        "the minimiser's stop reasons in the history")


RLJ_MIN_START_RATIO = 0.9  # r/sigma below this: repulsive-LJ forces > ~1e2 eps/sigma, LAMMPS loses atoms
CONTACT_RANGE = 1e-6  # ellipsoids: r / (smallest possible sigma) below this leaves r_hat, hence sigma, imprecise


def _check_start(packing: Packing) -> None:
    """Refuse before any work a start the engines cannot evaluate: ellipses/spheroids with centres so
    close that the contact distance is undefined or imprecise, repulsive LJ with deep overlaps."""
    if packing.shape.elliptic:
        _check_contact_range(packing)
    if not packing.potential.soft_start:
        return
    deepest = deepest_overlap(packing)
    if deepest < RLJ_MIN_START_RATIO:
        raise ValueError(f"repulsive LJ from a start with overlap r/sigma = {deepest:.3f} < "
                         f"{RLJ_MIN_START_RATIO}: forces diverge and LAMMPS loses atoms. Relax the start "
                         "first (jamflow.protocols.compression.remove_overlaps), or pass it to jam(), which does")


def deepest_overlap(packing: Packing) -> float:
    """Smallest r/sigma over overlapping pairs (of sites, for rigid bodies); 1.0 without overlaps."""
    from jamflow.model.pairs import (  # here, like resolution: scipy.spatial loads lazily
        overlapping_pairs,
        overlapping_sites,
    )

    r, sigma = (overlapping_sites(packing) if packing.shape.made_of_sites else overlapping_pairs(packing))[-2:]
    return float((r / sigma).min()) if len(r) else 1.0


SPRING_ALPHA_RANGE = (2.0, 3.0)  # FIRE reaches force balance here; outside it did not (docs/hardening.md)


def check_resolution(packing: Packing, settings: CompressionSettings) -> None:
    """Refuse, before any work, what cannot end in a checked packing: a V_tol that float64
    positions or the force tolerance cannot resolve at this N, box and potential
    (``jamflow.mechanics.checks.resolution``), or a spring exponent outside ``SPRING_ALPHA_RANGE``."""
    pot = packing.potential
    low, high = SPRING_ALPHA_RANGE
    if pot.name == "spring" and not low <= pot.alpha <= high:
        raise ValueError(f"spring exponent alpha = {pot.alpha:g}: jamflow's minimisers do not reach force balance "
                         f"for alpha outside [{low:g}, {high:g}] (measured for alpha = 1.5, 4, 6, 8, 10: net forces "
                         "3-66% of the contact forces, docs/hardening.md); use spring, hertz or spring:ALPHA "
                         f"with {low:g} <= ALPHA <= {high:g}")
    from jamflow.mechanics.checks import (
        resolution,  # imported here: the checks load scipy.spatial, not needed for --help
    )

    ftol = settings.minimizer.force_tol_for(packing)
    problem = resolution(packing, settings.v_tol, ftol).problem()
    if problem:
        raise ValueError(f"{problem} (N = {packing.n}, potential {pot.spec}, box side {packing.box.lengths.max():.3g})")


WINDOW_PROBE_VTOL = 1e-8  # from this V_tol on the window's reach is measured before work
WINDOW_PROBE_GAP = 1e-3  # the probe's box is this much (relative) wider than the densest with a unique minimum image


def check_window_reachable(packing: Packing, settings: CompressionSettings, engine: str = "auto",
                           denser: str | None = "--pressure for denser states") -> None:
    """Refuse, before any work, a V_tol above the energy the compression can reach: it stops at
    phi = 1 (``PhiStepper``) or where the box would lose its unique minimum image (``densest_phi``),
    so the window needs V > V_tol there. Measured from V_tol >= ``WINDOW_PROBE_VTOL`` (disks and
    spheres reach V ~ 1e-2 per particle at phi = 1): ``packing`` compressed affinely to that
    densest state and minimised there (not for repulsive LJ, whose energy diverges at contact and
    whose start may not be compressed affinely into deep overlaps). ``denser``: what else the
    caller offers for denser states."""
    if settings.v_tol < WINDOW_PROBE_VTOL or packing.gravity or packing.potential.soft_start:
        return
    phi = min(1.0 - 1e-6, densest_phi(packing) / (1.0 + WINDOW_PROBE_GAP) ** packing.dim)
    with open_engine(packing.scaled_to_phi(phi), settings.minimizer.method, engine) as sim:
        top = minimize(sim, replace(settings.minimizer, v_min=1e-300)).energy_per_particle
    if top <= settings.v_tol:
        boxed = phi < 1.0 - 1e-6
        limit = (f"at phi = {phi:.3g}, where the box side reaches twice the largest contact distance" if boxed
                 else "at phi = 1")
        other = "more particles" if boxed else denser
        raise ValueError(f"--vtol {settings.v_tol:g} is above the energy these particles reach before the compression "
                         f"stops {limit} (V = {top:.3g} per particle there): no state lands in the window; use "
                         f"--vtol below {top:.2g}{f', or {other}' if other else ''}")


def _check_contact_range(packing: Packing) -> None:
    """sigma_ij depends on the direction r_hat = r_ij / |r_ij|, known to ~1e-16 L / |r_ij| in a box of
    side L; at r_ij = 0 it is undefined (the contact-distance solver would return NaN)."""
    from jamflow.model.pairs import candidate_pairs  # here, like resolution: scipy.spatial loads lazily

    reach = packing.shape.reach(packing.diameters)
    i, j = candidate_pairs(packing, 2.0 * float(reach.max()))
    r = np.linalg.norm(packing.box.minimum_image(packing.positions[i] - packing.positions[j]), axis=1)
    shortest = packing.shape.axes(packing.diameters).min(axis=1)
    ratio = r / (0.5 * (shortest[i] + shortest[j]))  # <= r / sigma_ij
    if len(ratio) and ratio.min() < CONTACT_RANGE:
        k = int(np.argmin(ratio))
        raise ValueError(f"the start is too dense for the contact distance: particles {i[k]} and {j[k]} have centres "
                         f"{r[k]:.3g} apart (r/sigma <= {ratio[k]:.2g} < {CONTACT_RANGE:g}), where the direction r_hat, "
                         "and with it sigma_ij, is undefined or imprecise; use a lower phi0 or another seed, or "
                         "separate the pair")


def _warn_fallbacks(result: JamResult) -> None:
    """Warn when a truncated contact distance (linear, quadratic) fell back to lambda = 1/2."""
    fallbacks, evaluations = result.counters.get("fallbacks", 0), result.counters.get("approximate", 0)
    if fallbacks:
        warnings.warn(f"contact method {result.packing.shape.contact}: the truncated root left (0, 1) and lambda "
                      f"fell back to 1/2 in {fallbacks} of {evaluations} contact evaluations "
                      f"({100 * fallbacks / max(evaluations, 1):.2g} %) during this run; there sigma is Cleaver's "
                      "(eq. 2.6), and it jumps where the root leaves. Use --contact exact to avoid it", stacklevel=3)


class PhiStepper:
    """Chooses the next packing fraction after each minimisation.

    Seed rule (default): compress by dphi when V < V_tol, decompress when V > 2 V_tol, halve
    dphi when the side changes. Options (``CompressionSettings``): ``dphi_growth`` > 1 grows
    dphi (up to ``dphi_max``) after every step that stays below jamming, before the first
    crossing (and, with ``newton``, after it too);
    ``approach_force_rtol`` loosens the force tolerance of every minimisation that is not a
    final approach to that fraction of the pressure (``coarse_force_tol`` before the first
    crossing); a state that lands in the window anyway is re-minimised in place;
    ``coarse_v_min`` ends minimisations before the first crossing once V < coarse_v_min
    (counted as below jamming; a jammed state then shows up as V > coarse_v_min);
    ``newton`` jumps from a state above jamming to where V = 1.5 V_tol is predicted by
    V ~ (phi - phi_J)^alpha and the virial pressure P = phi^2 dV/dphi / v (v the mean particle
    volume), i.e. phi_J = phi - alpha V phi^2 / (P v), shrinking phi - phi_J by at most
    ``newton_ratio`` per jump, ``large_n_newton_ratio`` from ``large_n`` particles on (a long jump
    from a jammed state of many particles ends in an avalanche), and to no less than 3x the
    window's distance before the last jump, as the prediction errs by a few % of phi - phi_J, so
    the packing stays jammed and
    in the same basin while the prediction sharpens. A jump that lands below jamming is
    followed by the chapter's rule with dphi = that jump: compress by half of it, then by a
    growing step while still below. (An
    earlier version bisected between the latest below and above states; the above state
    can belong to another path's basin, and the bisection then converged onto it without
    ever reaching the window.)
    """

    def __init__(self, settings: CompressionSettings, alpha: float, mean_volume: float, n: int = 0):
        self.s, self.alpha, self.mean_volume = settings, alpha, mean_volume
        self.jump_ratio = settings.jump_ratio(n)  # ``newton_ratio``, or ``large_n_newton_ratio`` from ``large_n`` on
        self.dphi, self.side, self.crossed = settings.dphi0, None, False
        self.last_step = 0.0
        self.final_approach = False  # True when the next minimisation aims at the window itself
        self.pressure = 0.0  # pressure of the state the next step starts from

    def minimizer(self) -> MinimizerSettings:
        """Minimiser settings for the next step: the coarse V_min applies until the first
        crossing, the approach force tolerance to every step that is not a final approach."""
        m = self.s.minimizer
        if self.s.coarse_v_min is not None and not self.crossed:
            m = replace(m, v_min=self.s.coarse_v_min)
        if self.s.approach_force_rtol is not None and not self.final_approach:
            from_pressure = self.crossed and self.pressure > 0  # a state below jamming has P = 0
            loose = self.s.approach_force_rtol * self.pressure if from_pressure else self.s.coarse_force_tol
            m = replace(m, force_tol=max(loose, m.force_tol or 0.0))
        return m

    def next_phi(self, phi: float, v: float, pressure: float, unjammed: bool = False) -> float:
        side = "below" if (v <= self.s.v_tol or unjammed) else "above"
        self.pressure = pressure
        if self.side is not None and side != self.side:
            self.dphi /= 2.0
            self.crossed = True
        elif side == "below" and (not self.crossed or self.s.newton):
            # with Newton jumps a jump can land below with a tiny dphi; growing it again keeps a
            # creeping, barely unjammed state from being compressed in ~1e-8 steps for hundreds of steps
            self.dphi = min(self.dphi * self.s.dphi_growth, max(self.s.dphi_max, self.s.dphi0))
        self.side = side
        target = self._newton(phi, v, pressure) if self.s.newton else None
        if target is None:
            self.final_approach = self.crossed
            target = phi + self.dphi if side == "below" else phi - self.dphi
        self._check(phi, target, v)
        self.last_step = abs(target - phi)
        return target

    def _newton(self, phi, v, pressure):
        """Target of a Newton jump from a jammed state, or None where none applies."""
        if self.side != "above" or pressure <= 0:
            return None
        width = self.alpha * v * phi**2 / (pressure * self.mean_volume)  # predicted phi - phi_J
        window = width * (1.5 * self.s.v_tol / v) ** (1.0 / self.alpha)  # predicted phi - phi_J at V = 1.5 V_tol
        self.final_approach = width <= 2 * NEWTON_FINAL_FACTOR * window
        stop_at = window if self.final_approach else max(NEWTON_FINAL_FACTOR * window, width / self.jump_ratio)
        self.dphi = width - stop_at  # a jump that lands below is then halved by the chapter rule
        return phi - self.dphi

    def _check(self, phi, target, v):
        """Refuse a step to phi >= 1, a negative phi or one float64 cannot resolve (``v``: the
        energy per particle of the state at ``phi``)."""
        if target >= 1.0:
            raise JammingFailed(f"the compression reached phi = {phi:.4f} without any minimisation ending above "
                                f"V_tol = {self.s.v_tol:g} (the last: V = {v:.3g}): either the window lies beyond "
                                "phi = 1, where the compression stops (use a smaller vtol, or a target pressure for "
                                "denser states), or the minimiser's stops cannot see jamming with this potential and "
                                "tolerances (use a larger vtol, a smaller force tolerance, or the chapter protocol)")
        if target <= 0.0:
            raise JammingFailed(f"the decompression reached phi = {phi:.4f} without any minimisation ending below "
                                f"2 V_tol = {2 * self.s.v_tol:g}: the minimiser never removes the overlaps; use a "
                                "smaller force tolerance or another minimizer")
        if abs(target - phi) < 4 * np.finfo(float).eps * phi:
            raise JammingFailed(
                f"the increment {abs(target - phi):.3g} reached float64 resolution at phi = {phi:.15f} without V "
                f"landing in ({self.s.v_tol:g}, {2 * self.s.v_tol:g}); the window is narrower than the energy step "
                "between adjacent representable densities or the minimiser is not converging. Use a larger "
                "vtol (>= 1e-20 is resolvable for N <= 10^4) or a tighter force tolerance.")




def close_gaps(engine, result: MinimizeResult, settings: CompressionSettings) -> MinimizeResult | None:
    """Close the gaps of a packing in the window that is a contact or two short of isostatic.

    FIRE can stop on force balance while a floppy mode is still closing gaps at round-off (3D
    N = 4096 seed 1: 12 102 of the isostatic 12 103 contacts, the nearest gaps 1.7e-13 and 2.8e-13
    diameters; FIRE alone makes no progress), or at its iteration cap above the minimum (3D N = 512
    seed 25). The polish's active-set steps close such gaps exactly (``minimize.polish``; disks and
    spheres with the linear spring). Returns the polished state's result (0 FIRE
    iterations, its steps as creep steps) if it is jammed and force balanced -- the caller decides
    the window again -- and None otherwise, the engine put back: the packing's checks then say
    what is wrong. None too where there is nothing to close or the polish does not apply."""
    from jamflow.mechanics.checks import check_packing
    from jamflow.minimize.polish import polish, polish_reason

    packing = engine.packing()
    if not packing.shape.round or polish_reason(packing):
        return None
    if check_packing(packing, result.energy_per_particle, result.max_force).jammed:
        return None
    start = engine.positions()
    ftol = settings.minimizer.force_tol_for(packing)
    outcome = polish(engine, np.finfo(float).tiny, max_steps=GAP_CLOSING_STEPS)  # until a step is refused
    polished = engine.packing()
    v = engine.state().energy / polished.n_mobile
    if outcome.max_force < ftol and check_packing(polished, v, outcome.max_force).jammed:
        return MinimizeResult(converged=True, reason="force", iterations=0, energy_per_particle=v,
                              max_force=outcome.max_force, seconds=outcome.seconds,
                              creep_steps=sum(1 for s in outcome.steps if s.alpha > 0))
    engine.set_positions(start)
    engine.evaluate()
    return None


def _finish(engine, phi, result, rows, settings, start_time, version) -> JamResult:
    state = engine.state()
    packing = engine.packing()
    if not result.converged:
        tol = settings.minimizer.force_tol_for(packing)
        warnings.warn(f"final minimisation stopped by '{result.reason}' with max force {result.max_force:.2e} "
                      f"(tolerance {tol:.1e}); the packing is in the energy window but force balance is only as "
                      "good as that max force", stacklevel=3)
    history = {k: np.array(v) for k, v in rows.items()}
    history["reason"] = history["reason"].astype("S")
    return JamResult(packing=packing, phi_j=phi, energy_per_particle=result.energy_per_particle,
                     pressure_tensor=state.pressure_tensor, max_force=result.max_force, history=history,
                     settings=settings, seconds=time.perf_counter() - start_time, lammps_version=version,
                     engine=engine.name, kernels=engine.kernels, max_torque=result.max_torque,
                     wall_forces=wall_loads(packing) if packing.box.walls else None, counters=engine.counters())
