"""Command-line options declared once: the jam specification's options (``jamflow jam``,
``jamflow ensemble``) and the options many commands share (--engine, --vtol, --ftol, --force,
--quiet). Every default is the library's, read from ``JamSpec``'s fields."""

from __future__ import annotations

from jamflow.engines.choose import ENGINES
from jamflow.minimize.settings import CREEP_METHODS, MD_DAMPINGS, METHODS
from jamflow.model.box import STRESS_MODES
from jamflow.model.shapes.rotations import START_ORIENTATIONS
from jamflow.model.shapes.contact_distance import METHODS as METHODS_CONTACT
from jamflow.model.walls import WALL_TYPES
from jamflow.protocols.settings import DEFAULT_PROTOCOL, PROTOCOL_NAMES, PROTOCOLS
from jamflow.protocols.spec import PRECISIONS, JamSpec


def add_spec_arguments(p, skip=()) -> None:
    """Every option of ``JamSpec`` (same dests), except those named in ``skip``."""

    def add(flag, **kwargs):
        dest = flag.lstrip("-").replace("-", "_")
        if dest not in skip:
            p.add_argument(flag, default=getattr(JamSpec, dest), **kwargs)  # the default, written once: JamSpec's

    add("--dim", type=int, choices=(2, 3), help="spatial dimension")
    add("--n", type=int, help="number of particles")
    add("--sizes",
        help="mono | bi:RATIO:FRACTION_SMALL | poly-uniform:WIDTH | poly-normal:WIDTH | poly-lognormal:WIDTH")
    add("--potential", help="spring | hertz | spring:ALPHA | rlj")
    add("--shape",
        help="particle shape: disk | sphere (the same: round particles) | "
             "ellipse:ALPHA (2D, ALPHA = a/b >= 1) | spheroid:ALPHA (3D, ALPHA < 1 oblate); ALPHA = 1 is the "
             "disk/sphere | rigid n-mers of fused sites (docs/notes/nmers.md): nmer:N:ALPHA (linear, ALPHA = L/D), "
             "dimer:ALPHA:S (asymmetric, S = D2/D1), trimer:ALPHA:C (bent, C = h/L). --sizes scales whole "
             "particles (b; a = ALPHA b)")
    add("--contact", choices=METHODS_CONTACT,
        help="contact distance of ellipses/spheroids (chapter section 2.3.2): exact (Perram-Wertheim), "
             "gaussian (equal sizes only), cleaver; linear and quadratic are refused (no second derivatives "
             "for the packing checks; jamflow.model.shapes.contact_distance computes them); "
             "docs/notes/contact-distance.md")
    add("--protocol", choices=PROTOCOL_NAMES, metavar="{" + ",".join(sorted(PROTOCOLS)) + "}",
        help=f"chapter: the chapter's constant-increment bisection; fast: the same stopping rule with "
             f"growing increments and Newton jumps (docs/notes/speed.md). Default {DEFAULT_PROTOCOL}; "
             "chapter with --emit-deck (decks run the chapter's protocol)")
    add("--minimizer", choices=METHODS,
        help="energy minimiser; ellipses/spheroids: fire (compiled engine, over positions and "
             "orientations) or md (LAMMPS damped dynamics with rotations; no LAMMPS minimiser turns them); "
             "rigid bodies in LAMMPS: md (damped rigid-body dynamics)")
    add("--damping", type=float,
        help="md only: drag coefficient (sqrt(m eps)/diameter); rigid bodies: damping time 1/DAMPING")
    if "md_damping" not in skip:
        add_md_damping_argument(p)
    add("--creep", choices=CREEP_METHODS,
        help="what a creeping minimisation (unconverged after 10 000+ iterations near balance) does between FIRE "
             "windows: soft-modes (Newton steps along its softest modes, docs/notes/soft-modes.md), polish "
             "(Gauss-Newton active-set steps, disks/spheres and rigid bodies with the linear spring, "
             "docs/notes/speed-2.md section 8, docs/notes/nmers.md), newton (Newton-Krylov steps on the exact "
             "Hessian with a kept sparse Cholesky factor, disks/spheres with the linear spring, every 20 000 "
             "iterations; docs/notes/newton-krylov.md), off; auto: polish for rigid bodies and 2D disks, "
             "soft-modes for ellipses and spheroids, in the compiled engine")
    add_engine_argument(p, skip,
                        help="auto: the compiled engine (FIRE, in process) wherever it runs the scene, else LAMMPS "
                             "(docs/notes/speed.md). The engines sum forces in different orders, so from one start they "
                             "can reach different minima and phi_J (seed 0, N = 64: 0.8352519 numba, 0.8355434 lammps)")
    add("--phi0", type=float,
        help="initial packing fraction (default 0.80 in 2D, 0.55 in 3D; rigid bodies, which "
             "start without overlaps, 0.45 and 0.25)")
    add("--dphi0", type=float, help="initial packing-fraction increment")
    if "vtol" not in skip:
        add_vtol_argument(p)
    if "ftol" not in skip:
        add_ftol_argument(p)
    add("--seed", type=int, help="random seed of the initial positions and sizes")
    add("--above", type=float, metavar="DPHI",
        help="write the packing compressed from its onset by DPHI (phi_J -> phi_J + DPHI, affine) and "
             "minimised again (attribute dphi_above): the state jamflow moduli measures")
    add("--walls", metavar="AXES",
        help="walls on these axes (y, x,y, x,y,z): flat walls at both faces, the particles' own law at "
             "contact distance a_i/2; periodic along the others; phi between the walls")
    add("--wall-type", choices=WALL_TYPES,
        help="smooth: flat walls; rough: rows of fixed particles of the small diameter on the walls")
    add("--gravity", type=float, metavar="G",
        help="settle under gravity G (force per particle along -y in 2D, -z in 3D) on a floor: needs "
             "--walls y (2D) / z (3D); default phi0 0.5 (2D), 0.35 (3D)")
    add("--pressure", type=float, metavar="P",
        help="jam at target pressure P with the box as a degree of freedom (enthalpy minimisation), "
             "reached through decades from 1e-4; FIRE in the compiled engine, CG with fix box/relax in LAMMPS")
    add("--stress", choices=STRESS_MODES,
        help="with --pressure: iso (box shape kept), aniso (each P_aa = P), tri (shear stresses relaxed to "
             "0 too: the box tilts)")
    add("--gamma", type=float,
        help="jam at this fixed Lees-Edwards shear strain (any finite value; chapter section 2.2)")
    add("--precision", choices=PRECISIONS,
        help="double-double (disks/spheres, spring): the float64 onset refined by Newton steps in double-double "
             "(jamflow refine) to --pressure P (down to ~2e-18 at N ~ 300), or without --pressure to the pressure "
             "whose energy lands in the --vtol window (down to ~1e-35; docs/guide/precision.md)")
    add("--orientations", metavar="{" + ",".join(START_ORIENTATIONS) + "}",
        help="start orientations of particles with an axis: random (uniform, chapter step 1), aligned "
             "(every director along x: a nematic start, P2 = 1; Figure 2.23(c), docs/validation.md) or "
             "nematic:S (directors uniform in a cone about x with P2 = S in (0, 1]; nematic:1 = aligned)")


def add_md_damping_argument(p) -> None:
    p.add_argument("--md-damping", choices=MD_DAMPINGS, default=JamSpec.md_damping,
                   help="--minimizer md only: viscous (drag -b v on every particle) or pairwise (chapter eq. 2.3: "
                        "-b (v_ij . rhat) rhat on contacting pairs; docs/notes/damped-md.md)")




def add_engine_argument(p, skip=(), help="auto: the compiled engine where it runs the scene, else LAMMPS") -> None:
    if "engine" not in skip:
        p.add_argument("--engine", choices=ENGINES, default=JamSpec.engine, help=help)


def add_vtol_argument(p) -> None:
    p.add_argument("--vtol", type=float, default=JamSpec.vtol, help="energy window V_tol < V < 2 V_tol (per particle)")


def add_ftol_argument(p, help="max force component tolerance (default scales with box)") -> None:
    p.add_argument("--ftol", type=float, default=JamSpec.ftol, help=help)


def add_force_argument(p, help="replace outputs that are symlinks, device nodes or read-only files") -> None:
    p.add_argument("--force", action="store_true", help=help)


def add_quiet_argument(p) -> None:
    p.add_argument("--quiet", action="store_true", help="no progress display")


def spec_options(args) -> dict:
    """The ``JamSpec`` options present in parsed arguments (same names)."""
    return {name: getattr(args, name) for name in JamSpec.option_names() if hasattr(args, name)}
