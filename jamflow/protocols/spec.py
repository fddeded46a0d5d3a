"""The jam specification: every option of ``jamflow jam`` as one validated, serialisable value,
and the one function that runs it (``run_jam``). The command line parses its options into a
``JamSpec``; the ensemble stores its fields (``ensemble.json``) and ships them to the workers.

``prepare`` makes every refusal before any work (bad numbers, options that do not combine, an
engine that cannot run the scene, a V_tol that float64 cannot resolve); ``run_jam`` returns the
result and its checks, or raises ``JammingFailed`` so that nothing unchecked is written.
Units as in the packing file: diameters of the small particle, eps, eps/diameter.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from functools import cached_property

from jamflow.engines.choose import ENGINES, engine_name
from jamflow.mechanics.checks import check_packing
from jamflow.minimize.settings import CREEP_METHODS, MD_DAMPINGS, METHODS, MinimizerSettings
from jamflow.model.box import STRESS_MODES
from jamflow.model.shapes.contact_distance import HESSIAN_CONTACTS
from jamflow.model.shapes.contact_distance import METHODS as CONTACT_METHODS
from jamflow.model.shapes.parse import parse_shape
from jamflow.model.walls import WALL_TYPES
from jamflow.protocols.above import check_dphi
from jamflow.protocols.compression import (
    at_shear_strain,
    check_resolution,
    check_strain,
    initial_packing,
    jam,
    with_accumulated_strain,
)
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.settings import DEFAULT_PROTOCOL, PROTOCOLS, CompressionSettings
from jamflow.support.reprs import changed_fields_repr


PRECISIONS = ("double", "double-double")  # --precision: float64, or a float64 onset refined by jamflow.refine
ONSET_VTOL = 1e-16  # the float64 onset of --precision double-double --vtol V below it (the JamSpec default)


@dataclass(frozen=True)
class JamSpec:
    """One packing to jam: the options of ``jamflow jam`` (same names, same defaults), without
    the command's own (``--out``, ``--force``, ``--quiet``, ``--emit-deck``, ``--threads``: how the
    jam runs in this process, given to ``run_jam`` as ``engine_options``)."""

    dim: int = 2  #: dimension: 2 or 3
    n: int = 64  #: number of particles N
    #: size distribution, ``mono``, ``bi:RATIO:FRACTION_SMALL``, ``poly-uniform:WIDTH``, ... (``jamflow.parse_sizes``)
    sizes: str = "bi:1.4:0.5"
    #: pair law: ``spring`` (alpha = 2), ``hertz`` (alpha = 5/2), ``spring:ALPHA`` or ``rlj``
    #: (``jamflow.parse_potential``)
    potential: str = "spring"
    #: particle shape: ``disk`` (disks/spheres), ``ellipse:ALPHA``, ``spheroid:ALPHA``, ``dimer:...``, ...
    #: (``jamflow.parse_shape``)
    shape: str = "disk"
    contact: str = "exact"  #: contact distance of ellipses and spheroids: ``exact`` or an approximation of Table 2.1
    protocol: str | None = None  #: the protocol, ``chapter`` or ``fast``; None: ``fast``
    minimizer: str = "fire"  #: ``fire``, ``cg`` or ``md`` (damped molecular dynamics)
    damping: float = MinimizerSettings.damping  #: damping coefficient b of ``md``, in sqrt(m eps) / diameter
    #: ``viscous`` (-b v on each particle) or ``pairwise`` (the chapter's eq. 2.3); ``md`` only
    md_damping: str = "viscous"
    #: what a creeping minimisation does between windows: ``auto``, ``soft-modes``, ``polish``, ``newton``, ``off``
    #: (``MinimizerSettings.creep``)
    creep: str = "auto"
    engine: str = "auto"  #: ``auto``, ``lammps`` or ``numba`` (the compiled kernels)
    phi0: float | None = None  #: initial packing fraction; None: the dimension's default, well below phi_J
    dphi0: float = 1e-4  #: initial packing-fraction increment Delta phi
    vtol: float = 1e-16  #: V_tol of the energy window V_tol < V < 2 V_tol, energy per particle in eps
    ftol: float | None = None  #: force tolerance (largest force component, eps / diameter); None: the force floor
    seed: int = 0  #: random seed of the initial configuration
    #: after the onset, compress by this Delta phi and minimise again; None: stop at the onset
    above: float | None = None
    walls: str | None = None  #: walled axes, e.g. ``"y"`` or ``"x,y"``; None: periodic in every axis
    wall_type: str = "smooth"  #: ``smooth`` or ``rough`` (walls of fixed particles)
    gravity: float = 0.0  #: force per particle along -y (2D) or -z (3D), eps / diameter; needs walls on that axis
    pressure: float | None = None  #: target pressure (eps / diameter^d): the box relaxes to it; None: jam at the onset
    stress: str = "iso"  #: with ``pressure``: ``iso``, ``aniso`` (each P_aa) or ``tri`` (also the shear stresses to 0)
    gamma: float | None = None  #: fixed Lees-Edwards shear strain gamma = xy / ly; None: 0
    #: ``double``, or ``double-double`` (float64 onset, then refined to ``pressure`` or ``vtol``)
    precision: str = "double"
    #: start orientations of particles with an axis: ``random``, ``aligned`` or ``nematic:S``
    orientations: str = "random"

    __repr__ = changed_fields_repr  # only the options that differ from ``jamflow jam``'s defaults

    @classmethod
    def from_options(cls, **options) -> "JamSpec":
        """A spec from keyword options named as ``jamflow jam``'s (``wall_type``, ``md_damping``,
        ...); an unknown name is refused with the list of known ones."""
        unknown = sorted(set(options) - set(cls.option_names()))
        if unknown:
            raise ValueError(f"unknown jam option(s) {', '.join(unknown)}; use names of `jamflow jam --help`: "
                             f"{', '.join(cls.option_names())}")
        return cls(**options)

    @classmethod
    def option_names(cls) -> tuple[str, ...]:
        """The field names, which are the options of ``jamflow jam`` (``--wall-type`` is ``wall_type``)."""
        return tuple(f.name for f in fields(cls))

    def as_dict(self) -> dict:
        """The fields as plain values (JSON-serialisable)."""
        return asdict(self)

    @cached_property
    def particle(self):
        """The shape object of ``shape`` (with ``contact``), parsed once: what ``prepare`` starts
        from and what every check of the spec asks about the particles."""
        return parse_shape(self.shape, self.dim, self.contact)

    @property
    def protocol_name(self) -> str:
        """The protocol run: ``protocol``, or the default."""
        return self.protocol or DEFAULT_PROTOCOL

    @property
    def dd_vtol(self) -> bool:
        """--precision double-double without --pressure: the onset is refined to the window of ``vtol``."""
        return self.precision == "double-double" and self.pressure is None

    @property
    def onset_vtol(self) -> float:
        """V_tol of the float64 compression: ``vtol``, or with ``dd_vtol`` at most ``ONSET_VTOL``."""
        return max(self.vtol, ONSET_VTOL) if self.dd_vtol else self.vtol


def compression_settings(spec: JamSpec) -> CompressionSettings:
    """The compression protocol and minimiser of a spec; refuses bad numbers and combinations."""
    for name in ("phi0", "dphi0", "vtol", "ftol", "damping"):
        value = getattr(spec, name)
        if value is not None and (not math.isfinite(value) or value <= 0):
            raise ValueError(f"--{name} must be a finite positive number, got {value}")
    _check_choice("protocol", spec.protocol_name, PROTOCOLS)
    _check_choice("minimizer", spec.minimizer, METHODS)
    _check_choice("md-damping", spec.md_damping, MD_DAMPINGS)
    _check_choice("creep", spec.creep, CREEP_METHODS)
    v_tol = spec.onset_vtol
    minimizer = MinimizerSettings(method=spec.minimizer, force_tol=spec.ftol, v_min=v_tol, damping=spec.damping,
                                  md_damping=spec.md_damping, creep=spec.creep)
    return PROTOCOLS[spec.protocol_name](phi0=spec.phi0, dphi0=spec.dphi0, v_tol=v_tol, minimizer=minimizer)


def _check_choice(option: str, value, choices) -> None:
    if value not in choices:
        raise ValueError(f"--{option} {value!r} is not one of {', '.join(sorted(choices))}")


def check_boundaries(spec: JamSpec) -> None:
    """Refuse bad --gravity / --pressure / --above / --gamma / --precision combinations before any work."""
    _check_choice("engine", spec.engine, ENGINES)
    check_precision(spec)
    _check_choice("wall-type", spec.wall_type, WALL_TYPES)
    _check_choice("stress", spec.stress, STRESS_MODES)
    _check_choice("contact", spec.contact, CONTACT_METHODS)
    if not math.isfinite(spec.gravity) or spec.gravity < 0:
        raise ValueError(f"--gravity must be a finite number >= 0, got {spec.gravity}")
    if spec.pressure is not None:
        if not math.isfinite(spec.pressure) or spec.pressure <= 0:
            raise ValueError(f"--pressure must be a finite positive number, got {spec.pressure}")
        if spec.walls or spec.gravity:
            raise ValueError("--pressure relaxes a periodic box: it does not combine with --walls or --gravity")
    if spec.above is not None:
        check_dphi(spec.above, 0.0)  # not finite, not positive, >= 1: refused before any work
        if spec.pressure is not None or spec.gravity:
            raise ValueError("--above compresses the onset packing at a fixed box: it does not combine with "
                             "--pressure, --gravity or --emit-deck")
    if spec.gamma is not None:
        check_strain(spec.gamma, "--gamma")
    if spec.gamma is not None and spec.pressure is not None:
        raise ValueError("--gamma fixes the shear strain, --pressure relaxes the box: use one of them")
    check_partners(spec)


# option -> (has its partner, the partner, why): a value other than the JamSpec default means
# nothing without the partner, so it is refused rather than silently ignored
PARTNERS = {
    "stress": (lambda s: s.pressure is not None, "--pressure", "how the box relaxes at a target pressure"),
    "wall_type": (lambda s: bool(s.walls), "--walls", "the kind of the walls on the walled axes"),
    "damping": (lambda s: s.minimizer == "md", "--minimizer md", "the drag of damped dynamics"),
    "md_damping": (lambda s: s.minimizer == "md", "--minimizer md", "the drag of damped dynamics"),
    "dphi0": (lambda s: s.pressure is None and not s.gravity, "a compression run",
              "the first step of phi; --pressure and --gravity runs do not compress"),
    "vtol": (lambda s: s.pressure is None and not s.gravity, "a compression run",
             "the energy window of the onset; a pile under --gravity and a box at --pressure have none"),
}


def check_precision(spec: JamSpec) -> None:
    """--precision double-double: a float64 onset refined to --pressure, or to the energy window of
    --vtol, by ``jamflow.refine`` (the compiled engine's double-double kernel), periodic boxes only."""
    _check_choice("precision", spec.precision, PRECISIONS)
    if spec.precision == "double":
        return
    if spec.pressure is not None and spec.vtol != JamSpec.vtol:
        raise ValueError("--precision double-double refines the onset to one target: give --pressure P (a pressure) "
                         "or --vtol V (the energy window V < V_dd < 2 V), not both")
    if spec.engine == "lammps":
        raise ValueError("--precision double-double needs the numba engine (--engine numba or auto): LAMMPS computes "
                         "in float64 only")
    if spec.walls or spec.gravity or spec.gamma is not None or spec.above is not None or spec.stress != "iso":
        raise ValueError("--precision double-double refines in a periodic, unsheared box at isotropic pressure: it "
                         "does not combine with --walls, --gravity, --gamma, --above or --stress aniso/tri")


def check_partners(spec: JamSpec) -> None:
    """Refuse an option set to a value other than its default without the option it works with
    (``PARTNERS``): e.g. --stress without --pressure, --wall-type without --walls."""
    defaults = JamSpec()
    for name, (present, partner, why) in PARTNERS.items():
        value = getattr(spec, name)
        if value != getattr(defaults, name) and not present(spec):
            option = name.replace("_", "-")
            raise ValueError(f"--{option} {value} applies to {partner} only ({why}), and would be ignored here: "
                             f"leave --{option} out, or use it with {partner}")


def check_contact(spec: JamSpec) -> None:
    """Refuse a --contact method other than the default for a shape that has no contact-distance
    approximation (disks, spheres, ellipse:1, rigid bodies of spherical sites): it would be ignored;
    and the truncations 'linear' / 'quadratic', whose lack of second derivatives fails every
    packing's checks after the whole jam (``HESSIAN_CONTACTS``)."""
    if spec.contact == "exact":
        return
    shape = spec.particle  # the method is one of CONTACT_METHODS (check_boundaries)
    if not shape.elliptic:
        raise ValueError(f"--contact {spec.contact} applies to ellipses/spheroids (--shape ellipse:ALPHA or "
                         f"spheroid:ALPHA, ALPHA != 1), not to {shape.name(spec.dim)} particles: leave --contact out")
    if spec.contact not in HESSIAN_CONTACTS:  # the checks of every jammed packing would fail after the whole jam
        raise ValueError(f"--contact {spec.contact} cannot make a checked packing: the packing checks (and the soft-mode "
                         f"steps) need second derivatives of the contact distance, which the truncated root of "
                         f"'{spec.contact}' lacks; use --contact {' | '.join(HESSIAN_CONTACTS)}")


def prepare(spec: JamSpec):
    """(settings, start) of a spec: validated settings (``CompressionSettings``, or
    ``PressureSettings`` with a target pressure) and the random start. Every refusal comes here,
    before any work (shared by ``jamflow jam``, ``jamflow ensemble`` and ``run_jam``)."""
    check_boundaries(spec)
    check_contact(spec)
    settings = compression_settings(spec)
    particle = spec.particle if spec.dim in (2, 3) else spec.shape  # initial_packing refuses other dimensions first
    start = initial_packing(spec.n, spec.dim, spec.sizes, spec.potential, spec.seed,
                            settings.start_phi(spec.dim, spec.gravity, particle), particle, spec.walls,
                            spec.wall_type, spec.gravity, spec.contact, spec.orientations)
    if spec.gamma is not None:
        start = at_shear_strain(start, spec.gamma)  # refuses a strain that is not finite, or walls with a shear
    if spec.precision == "double-double":
        from jamflow.protocols.refine import (  # here: refine loads scipy (~0.3 s)
            RefineSettings,
            check_refine,
            check_vtol,
        )

        engine_name(start, spec.minimizer, spec.engine)
        check_resolution(start, settings)
        if spec.dd_vtol:
            check_vtol(start, spec.vtol)  # the double-double floor of V_tol, before the onset is made
        else:
            check_refine(start, RefineSettings(spec.pressure))  # the double-double floor, before the onset is made
        return settings, start
    if spec.pressure is not None:
        from jamflow.protocols.pressure import PressureSettings, check_pressure_start, pressure_sequence

        psettings = PressureSettings(pressure_sequence(spec.pressure), spec.stress, settings.minimizer)
        check_pressure_start(start, psettings)
        engine_name(start, spec.minimizer, spec.engine, pressure=True)
        return psettings, start
    engine_name(start, spec.minimizer, spec.engine)  # refuse an engine that cannot run the scene, before work
    if start.shape.made_of_sites and settings.minimizer.md_damping != "viscous":
        raise ValueError(f"--md-damping {settings.minimizer.md_damping} is for disks and spheres: rigid bodies are "
                         "damped by fix rigid langevin (set its rate with --damping)")
    check_float64_resolution(start, settings)
    return settings, start


def check_float64_resolution(start, settings) -> None:
    """``check_resolution``, whose refusal of a V_tol below float64 also names --precision double-double
    where it applies (disks/spheres, linear spring, periodic box)."""
    try:
        check_resolution(start, settings)
    except ValueError as err:
        pot = start.potential
        refinable = (start.shape.double_double and pot.name == "spring" and getattr(pot, "alpha", None) == 2.0
                     and not start.box.walls and not start.gravity)
        if not refinable or "vtol" not in str(err):
            raise
        raise ValueError(f"{err}; or --precision double-double, which refines the float64 onset to the window of "
                         f"--vtol V down to ~1e-32 (docs/guide/precision.md)") from None


def run_jam(spec: JamSpec, observers=(), engine_options=None, prepared=None, destination=None):
    """(result, checks) of the jam ``spec`` asks for (``--above`` is not applied here:
    ``protocols.above.compress_above`` on the result). ``JammingFailed`` if the protocol fails or
    the packing fails its checks, so nothing unchecked is written. ``prepared``: what
    ``prepare(spec)`` returned, if the caller already has it; ``destination``: the file the caller
    would write, named in the failure message.

    Parameters
    ----------
    spec : JamSpec
        The run (``jamflow jam``'s options).
    observers : iterable of callable, optional
        Progress callbacks, passed to ``jamflow.jam`` (or the pressure and refinement protocols).
    engine_options : dict, optional
        Options for the engine's constructor (LAMMPS: skin, comm, args; compiled: skin).
    prepared : tuple, optional
        (settings, start packing) as ``prepare(spec)`` returns them; default: prepared here.
    destination : str or os.PathLike, optional
        The file the caller would write, named in a failure message.

    Returns
    -------
    tuple
        (result, checks): a ``JamResult`` (a ``PressureResult`` when ``spec.pressure`` is set
        in double precision, a ``RefineResult`` in double-double) and its ``PackingChecks``.

    Raises
    ------
    jamflow.JammingFailed
        The protocol fails, or the packing fails its checks.
    """
    settings, start = prepared or prepare(spec)
    if spec.precision == "double-double":
        from jamflow.protocols.refine import refine, refine_to_vtol

        onset = jam(start=start, settings=settings, observers=observers, engine=spec.engine,
                    engine_options=engine_options)
        checked(onset, settings.minimizer, settings.v_tol, destination)
        refined = (refine_to_vtol(onset.packing, spec.vtol, onset=onset) if spec.dd_vtol else
                   refine(onset.packing, spec.pressure, onset=onset))
        checks = refined.checks()
        if not checks.passed:
            raise JammingFailed(f"the refined packing failed its checks: {'; '.join(checks.problems())}"
                                f"{f'. Nothing was written to {destination}' if destination else ''}")
        return refined, checks
    if spec.pressure is not None:
        from jamflow.protocols.pressure import jam_at_pressure

        result = jam_at_pressure(start, settings, observers=observers, engine=spec.engine,
                                 engine_options=engine_options)
        return result, checked(result, settings.minimizer, None, destination)
    result = jam(start=start, settings=settings, observers=observers, engine=spec.engine,
                 engine_options=engine_options)
    if spec.gamma is not None:
        result = with_accumulated_strain(result, spec.gamma)  # the file's gamma: the accumulated strain
    window = None if spec.gravity else settings.v_tol  # a pile under gravity has no energy window
    return result, checked(result, settings.minimizer, window, destination)


def failed_checks_remedy(packing, force_balanced: bool, v_tol: float | None) -> str:
    """What helps a packing that failed its checks: stronger contacts, set by the option that sets
    them in this scene (--vtol in a compression, --gravity for a pile, --pressure for a box at a
    pressure), and, when force balance failed, another minimiser."""
    if v_tol is not None:
        stronger = "a larger --vtol"
    elif packing.gravity > 0:
        stronger = "a larger --gravity (the weights set the contact forces of a pile)"
    else:
        stronger = "a larger --pressure"
    if not force_balanced:
        return f"another --minimizer, or {stronger} (stronger contacts)"
    return f"{stronger}: the contacts at this one are near round-off"


def checked(result, minimizer: MinimizerSettings, v_tol: float | None, destination=None):
    """The packing checks of a result; ``JammingFailed`` if any fails (naming ``destination``,
    the file not written). ``v_tol`` None skips the energy-window check (piles under gravity,
    constant pressure)."""
    packing = result.packing
    checks = check_packing(packing, result.energy_per_particle, None, v_tol, minimizer.force_tol_for(packing))
    if not checks.passed:
        reason = result.history["reason"][-1].decode()
        remedy = failed_checks_remedy(packing, checks.force_balanced, v_tol)
        at = f"phi_J = {result.phi_j:.10f}" if math.isfinite(result.phi_j) else f"phi = {packing.phi:.10f}"
        raise JammingFailed(f"the packing at {at} failed its checks: "
                            f"{'; '.join(checks.problems())} (final minimisation stopped by '{reason}'). "
                            f"{f'Nothing was written to {destination}; ' if destination else ''}use {remedy}")
    return checks
