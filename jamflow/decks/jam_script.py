"""The LAMMPS input decks that run jamflow's protocols on their own.

``HEADER`` / ``SHEAR_HEADER`` (formatted by ``jamflow.decks.jam``) document a deck and set its
parameters as ``index`` variables, which ``lmp -var NAME VALUE`` overrides; ``BODY`` (isotropic
compression, ``lammps_inputs/jam.lmp``) and ``SHEAR_BODY`` (quasistatic shear at zero pressure,
``lammps_inputs/shear.lmp``) are the protocols. Both are assembled from the same pieces (the
set-up, the bisection, the cell change with Lees-Edwards folds), each written once, and mirror
the Python controller command for command, so the same start gives the same trajectory;
tests/test_decks.py checks it.
"""

from jamflow.mechanics.force_floor import FORCE_TOL_BASE

_FTOL_BASE = repr(FORCE_TOL_BASE)  # the force floor's base (disks, spheres), as the deck's text writes it

_PLUGIN_OPTION = """#   -var plugin SO   jamflow's compiled LAMMPS plugin (needed by mddamping pairwise), from
#                    python -c "from jamflow.engines.lammps.plugin_build import plugin_library; print(plugin_library())"
"""

_MINIMIZER_VARIABLES = """variable minimizer index {minimizer:<12} # fire | cg | md (damped MD)
variable vmin      index {vmin:<12} # stop a minimisation when V < V_min
variable delta     index {delta:<12} # no-progress: energy decrease < delta V over a window
variable window    index {window:<12} # iterations per minimize call between rule checks
variable maxiter   index {maxiter:<12} # iteration cap per minimisation
variable dt        index {dt:<12} # FIRE initial step
variable mddt      index {mddt:<12} # damped-MD step
variable damping   index {damping:<12} # md only: damping coefficient b
variable mddamping index {mddamping:<12} # md only: viscous (-b v) | pairwise (chapter eq. 2.3, needs plugin)
variable mdsample  index {mdsample:<12} # md only: steps between energy samples (energy-steady rule)
"""

HEADER = """\
# jamflow deck: jam N soft disks (dim 2) or spheres (dim 3) at onset by isotropic
# compression (Schreck & O'Hern, chapter section 2.1) in the LAMMPS input language
# alone. Written by jamflow {version}; `jamflow jam --emit-deck FILE ...` writes it again.
#
#   lmp -in jam.lmp -var N 256 -var seed 1 -var out jammed              2D, 50:50 d 1 and 1.4
#   lmp -in jam.lmp -var dim 3 -var N 512 -var d2 1 -var seed 1         3D monodisperse
#   lmp -in jam.lmp -var data start.data -var out jammed               from a data file
#   mpirun -np 2 lmp -in jam.lmp ...                                    MPI ranks
#
# Writes OUT.data (the final packing) and OUT.protocol.txt (one line per minimisation:
# step phi V P dphi iterations max_force reason, then a "# result" line). Exit status 0
# when jammed (V_tol < V < 2 V_tol), 1 when the protocol failed (reason in both logs).
# Units: LJ with small diameter 1, epsilon 1, mass 1; V is the energy per particle.
# Potential: V(r) = eps/2 (1 - r/sigma_ij)^2 for r < sigma_ij (pair_style harmonic/cut).
# Walls (-var walls y, xy, ...; chapter section 2.3): those axes are boundary f with smooth walls
# at both faces, the same law at contact distance a/2 (fix wall/harmonic per size), and phi
# is measured between them (jamflow/model/walls.py; jamflow jam --walls y --emit-deck FILE).
# Optional variables (not set here):
#   -var data FILE   start from FILE (atom_style sphere; type 1 diameter d1, type 2 d2)
#   -var phi0 PHI    start packing fraction; default 0.80 (2D) / 0.55 (3D); with data,
#                    the file's own (and a given PHI must match it to 1e-12)
#   -var ftol F      max force component tolerance; default """ + _FTOL_BASE + """ max(1, L/20), L = box side
""" + _PLUGIN_OPTION + """{optional}
variable dim       index {dim:<12} # 2: disks, 3: spheres
variable N         index {N:<12} # particles (random start only)
variable d1        index {d1:<12} # small diameter, type 1
variable d2        index {d2:<12} # large diameter, type 2 (= d1: monodisperse)
variable fsmall    index {fsmall:<12} # fraction of small particles (random start)
variable seed      index {seed:<12} # random start: create_atoms seeds seed+1, seed+1000001
variable vtol      index {vtol:<12} # energy window V_tol < V < 2 V_tol (per particle)
variable dphi0     index {dphi0:<12} # initial packing-fraction increment
""" + _MINIMIZER_VARIABLES + """variable maxsteps  index {maxsteps:<12} # cap on minimisations
variable skin      index {skin:<12} # neighbour-list skin
variable out       index {out:<12} # output prefix
variable walls     index {walls:<12} # none | x | y | z | xy | xz | yz | xyz: smooth walls on those axes
"""

SHEAR_HEADER = """# jamflow deck: shear a jammed packing of soft disks (dim 2) or spheres (dim 3) quasistatically
# at zero pressure (Schreck & O'Hern, chapter section 2.2, eq. 2.4) in the LAMMPS input
# language alone: steps x_i -> x_i + dgamma y_i with shear-periodic boundaries (change_box ...
# xy final ... remap), each minimised at fixed strain and brought back into the energy window by
# the compression loop of jam.lmp at that strain. Written by jamflow {version};
# `jamflow shear --emit-deck FILE ...` writes it again with a run's parameters and start.
#
#   lmp -in shear.lmp -var data start.data -var dgamma 0.002 -var to 0.3 -var out path
#   lmp -in shear.lmp -var data start.data -var xy0 5.1 -var dgamma -0.001 -var to 1.2
#
# Writes OUT.data (the last packing) and OUT.protocol.txt: per shear step a "# shear step k
# gamma_k" line, one line per minimisation (step phi V P dphi iterations max_force reason) and a
# "# static k gamma phi_J V P Pxy minimisations iterations" line; then a "# result" line. Exit
# status 0 when every step reached the window, 1 when the protocol failed (reason in both logs).
# Units: LJ with small diameter 1, epsilon 1, mass 1; V is the energy per particle.
# Potential: V(r) = eps/2 (1 - r/sigma_ij)^2 for r < sigma_ij (pair_style harmonic/cut).
# Optional variables (not set here):
#   -var xy0 XY      accumulated xy tilt of the start (default: the data file's; jamflow passes
#                    the packing's, which may exceed lx/2: the strain history)
#   -var steps S     number of steps (default: (to - gamma_0) / dgamma, rounded up)
#   -var vsum V      total particle area/volume (default: summed from the atom types; jamflow
#                    passes its own sum, which may differ by ~1e-16)
#   -var ftol F      max force component tolerance; default """ + _FTOL_BASE + """ max(1, L/20), L = box side
""" + _PLUGIN_OPTION + """{optional}
variable dim       index {dim:<12} # 2: disks, 3: spheres
variable data      index {data:<12} # the start: atom_style sphere, type 1 diameter d1, type 2 d2
variable dgamma    index {dgamma:<12} # strain step (either sign)
variable to        index {to:<12} # final accumulated strain
variable d1        index {d1:<12} # small diameter, type 1
variable d2        index {d2:<12} # large diameter, type 2 (= d1: monodisperse)
variable vtol      index {vtol:<12} # energy window V_tol < V < 2 V_tol (per particle)
variable dphi0     index {dphi0:<12} # initial packing-fraction increment after each step
""" + _MINIMIZER_VARIABLES + """variable maxsteps  index {maxsteps:<12} # cap on minimisations of one bisection
variable skin      index {skin:<12} # neighbour-list skin
variable out       index {out:<12} # output prefix
"""

# --- the pieces, each written once ------------------------------------------------------------
_MIRROR_NOTE = r"""
# ---------------------------------------------------------------------------------------
# Everything below mirrors jamflow's Python controller command for command
# (jamflow/engines/lammps/engine.py, jamflow/minimize/rules.py, jamflow/protocols/compression.py), so a
# run from the same data file follows the same trajectory. Numbers that must be exact are
# kept in internal-style variables: LAMMPS folds a constant equal-style formula to 15
# digits, which would move phi by ~1e-16 and send FIRE down another path.
# ---------------------------------------------------------------------------------------

"""


LOG_OPEN = r"""variable jf_log string ${out}.protocol.txt
variable jf_logtmp string ${out}.protocol.txt.partial
shell rm -f ${jf_logtmp}
variable jf_hasdata internal $(is_defined(variable,data))
variable jf_autoftol internal $(!is_defined(variable,ftol))
if "${jf_hasdata} == 0" then "variable data string none"
if "${jf_autoftol} == 1" then "variable ftol string auto"
"""

# the compression decks' log header and phi0 default (shared with the ellipse deck)
JAM_START_OPTIONS = r"""print "# jamflow deck: isotropic compression to jamming onset (chapter section 2.1)" append ${jf_logtmp} screen no
variable jf_autophi internal $(!is_defined(variable,phi0))
if "${jf_autophi} == 1" then "variable phi0 string auto"
"""

_JAM_OPTIONS = JAM_START_OPTIONS + r"""print "# dim ${dim} N ${N} d1 ${d1} d2 ${d2} phi0 ${phi0} seed ${seed} vtol ${vtol} dphi0 ${dphi0} minimizer ${minimizer} ftol ${ftol} data ${data}" append ${jf_logtmp} screen no

"""

_SHEAR_OPTIONS = r"""print "# jamflow deck: quasistatic shear at zero pressure (chapter section 2.2)" append ${jf_logtmp} screen no
variable jf_autoxy internal $(!is_defined(variable,xy0))
variable jf_autosteps internal $(!is_defined(variable,steps))
variable jf_autovsum internal $(!is_defined(variable,vsum))
if "${jf_autoxy} == 1" then "variable xy0 string auto"
if "${jf_autosteps} == 1" then "variable steps string auto"
if "${jf_autovsum} == 1" then "variable vsum string auto"
variable walls index none
if "${walls} != none" then "variable jf_bad string 'the shear deck runs periodic cells: a walled axis takes part in no shear'" "jump SELF jf_fail"
print "# dim ${dim} d1 ${d1} d2 ${d2} xy0 ${xy0} dgamma ${dgamma} to ${to} steps ${steps} vsum ${vsum} vtol ${vtol} dphi0 ${dphi0} minimizer ${minimizer} ftol ${ftol} data ${data}" append ${jf_logtmp} screen no

"""

_CHECKS = r"""# ---- check the parameters before any work ----
if "${dim} != 2 && ${dim} != 3" then "variable jf_bad string 'dim must be 2 or 3'" "jump SELF jf_fail"
if "${minimizer} != fire && ${minimizer} != cg && ${minimizer} != md" then "variable jf_bad string 'minimizer must be fire, cg or md'" "jump SELF jf_fail"
if "$(v_vtol <= 0 || v_dphi0 <= 0 || v_dphi0 >= 0.1)" then "variable jf_bad string 'need vtol > 0 and 0 < dphi0 < 0.1'" "jump SELF jf_fail"
if "$(v_d1 <= 0 || v_d2 < v_d1)" then "variable jf_bad string 'need 0 < d1 <= d2'" "jump SELF jf_fail"
if "$(v_vmin > v_vtol)" then "variable jf_bad string 'vmin = ${vmin} is above vtol = ${vtol}: every state in the window would be stopped as unjammed; set -var vmin ${vtol}'" "jump SELF jf_fail"
variable jf_md internal 0
if "${minimizer} == md" then "variable jf_md internal 1"
if "${mddamping} != viscous && ${mddamping} != pairwise" then "variable jf_bad string 'mddamping must be viscous or pairwise'" "jump SELF jf_fail"
variable jf_pairwise internal 0
if "${mddamping} == pairwise" then "variable jf_pairwise internal 1"
if "$(v_jf_md == 1 && v_jf_pairwise == 0 && v_damping*v_mddt >= 2)" then "variable jf_bad string 'damped MD with damping x dt = $(v_damping*v_mddt) >= 2: the explicit drag -b v diverges (atoms fly off, V reads 0); use damping < 2/dt'" "jump SELF jf_fail"
if "$(v_jf_md == 1 && v_jf_pairwise == 1 && v_damping*v_mddt >= 2.0/24)" then "variable jf_bad string 'pairwise damping with damping x dt = $(v_damping*v_mddt) >= 2/24: contacts are damped at up to b (z_i + z_j) <= 24 b, and the explicit step diverges beyond rate x dt = 2; use damping x dt < 0.0833'" "jump SELF jf_fail"
if "$(v_mdsample < 1 || v_mdsample != floor(v_mdsample))" then "variable jf_bad string 'mdsample must be a positive integer'" "jump SELF jf_fail"
if "$(v_jf_md == 1 && v_window < 2*v_mdsample)" then "variable jf_bad string 'window ${window} < 2 x mdsample ${mdsample}: the energy-steady rule needs 2 energy samples per window'" "jump SELF jf_fail"
if "$(v_jf_md == 1 && v_jf_pairwise == 1 && !is_defined(variable,plugin))" then "variable jf_bad string 'mddamping pairwise needs jamflow plugin library: -var plugin PATH (see the header)'" "jump SELF jf_fail"
if "$(v_jf_md == 1 && v_jf_pairwise == 1)" then "plugin load ${plugin}"
# walls: boundary f on the walled axes (jamflow/engines/lammps/engine.py)
variable jf_bx string p
variable jf_by string p
variable jf_bz string p
if "${walls} == x || ${walls} == xy || ${walls} == xz || ${walls} == xyz" then "variable jf_bx string f"
if "${walls} == y || ${walls} == xy || ${walls} == yz || ${walls} == xyz" then "variable jf_by string f"
if "${walls} == z || ${walls} == xz || ${walls} == yz || ${walls} == xyz" then "variable jf_bz string f"
if "${walls} != none && ${jf_bx} == p && ${jf_by} == p && ${jf_bz} == p" then "variable jf_bad string 'walls must be none, x, y, z, xy, xz, yz or xyz'" "jump SELF jf_fail"
if "${dim} == 2 && ${jf_bz} == f" then "variable jf_bad string 'no walls on z in 2D'" "jump SELF jf_fail"

"""

_SHEAR_CHECKS_EXTRA = r"""if "${jf_hasdata} == 0" then "variable jf_bad string 'the shear deck starts from a packing: pass -var data FILE (jamflow shear --emit-deck writes one)'" "jump SELF jf_fail"
if "$(v_dgamma == 0)" then "variable jf_bad string 'dgamma must not be zero'" "jump SELF jf_fail"
"""

_SYSTEM = r"""units lj
dimension ${dim}
boundary ${jf_bx} ${jf_by} ${jf_bz}
atom_style sphere
atom_modify map array
comm_modify vel yes

variable jf_a1 internal $(ternary(v_dim==2,PI*v_d1^2/4.0,PI*v_d1^3/6.0):%.17g)
variable jf_a2 internal $(ternary(v_dim==2,PI*v_d2^2/4.0,PI*v_d2^3/6.0):%.17g)
variable jf_ntypes internal $(ternary(v_d1==v_d2,1,2))
"""

# shared with the ellipse deck through random_atoms
_RANDOM_ATOMS = r"""if "${jf_autophi} == 1" then "variable phi0 delete" "variable phi0 string $(ternary(v_dim==2,0.80,0.55))"
if "$(v_phi0 <= 0 || v_phi0 >= 1)" then "variable jf_bad string 'phi0 must lie in (0, 1)'" "jump SELF jf_fail"
if "$(v_seed < 0 || v_N < 2)" then "variable jf_bad string 'need seed >= 0 and N >= 2'" "jump SELF jf_fail"
variable jf_n1 internal $(ternary(v_jf_ntypes==1,v_N,round(v_fsmall*v_N)))
variable jf_n2 internal $(v_N-v_jf_n1)
variable jf_len internal $(((v_jf_n1*v_VOLUME1+v_jf_n2*v_VOLUME2)/v_phi0)^(1.0/v_dim):%.17g)
variable jf_zlo internal $(ternary(v_dim==2,-0.5,0.0))
variable jf_zhi internal $(ternary(v_dim==2,0.5,v_jf_len):%.17g)
region jf_box block 0 $(v_jf_len:%.17g) 0 $(v_jf_len:%.17g) ${jf_zlo} $(v_jf_zhi:%.17g) units box
create_box ${jf_ntypes} jf_box
create_atoms 1 random $(v_jf_n1) $(v_seed+1) NULL
if "$(v_jf_n2 > 0)" then "create_atoms 2 random $(v_jf_n2) $(v_seed+1000001) NULL"
"""


def random_atoms(volume: str) -> str:
    """The deck lines that create N random atoms of types 1 and 2 at phi0 (chapter step 1);
    ``volume``: the stem of the deck's per-type particle-volume variables (``jf_a``, ``jf_v``)."""
    return _RANDOM_ATOMS.replace("VOLUME", volume)


# a minimisation's window loop opens (its counters, the label, the steps of this window); shared
# with the ellipse deck
WINDOW_OPEN = r"""variable jf_done internal 0
variable jf_first internal 1
variable jf_eprev internal 0
variable jf_fmprev internal 0
label jf_window
variable jf_nsteps internal $(ternary(v_window<v_maxiter-v_jf_done,v_window,v_maxiter-v_jf_done))
variable jf_before internal $(step)
"""

_RANDOM_START = r"""if "${jf_hasdata} == 1" then "jump SELF jf_read"

# ---- random start (chapter step 1): uniform positions in a square/cubic box at phi0 ----
""" + random_atoms("jf_a") + r"""set type 1 diameter ${d1}
if "$(v_jf_n2 > 0)" then "set type 2 diameter ${d2}"
jump SELF jf_atoms_ready

"""

_READ_DATA = r"""# ---- start from a data file (atom_style sphere; type 1 diameter d1, type 2 diameter d2) ----
label jf_read
read_data ${data}
variable jf_wrongd atom "(type==1 && abs(2*radius-v_d1)>1e-12*v_d1) || (type==2 && abs(2*radius-v_d2)>1e-12*v_d2) || type>2"
group jf_wrongd variable jf_wrongd
if "$(count(jf_wrongd) > 0)" then "variable jf_bad string '$(count(jf_wrongd)) atoms of ${data} do not have diameter d1 = ${d1} (type 1) or d2 = ${d2} (type 2): pass -var d1 and -var d2'" "jump SELF jf_fail"
group jf_wrongd delete

"""

_ATOMS_READY = r"""label jf_atoms_ready
set atom * mass 1.0
"""

_JAM_PHI = r"""group jf_t1 type 1
group jf_t2 type 2
variable jf_phibox internal $((count(jf_t1)*v_jf_a1+count(jf_t2)*v_jf_a2)/ternary(v_dim==2,lx*ly,lx*ly*lz):%.17g)
group jf_t1 delete
group jf_t2 delete
# phi0 auto: the start's own packing fraction (summed in atom order: may differ from
# jamflow's by ~1e-16; jamflow passes its value). A given phi0 must match the start.
if "${jf_autophi} == 1" then "variable phi0 delete" "variable phi0 string $(v_jf_phibox:%.17g)"
if "$(abs(v_phi0-v_jf_phibox) > 1e-12*v_jf_phibox)" then "variable jf_bad string 'phi0 = ${phi0} but the start has phi = $(v_jf_phibox:%.17g): omit -var phi0 to use the start as it is'" "jump SELF jf_fail"

"""

_POTENTIAL = r"""# ---- the exact pair potential V = eps/2 (1 - r/sigma_ij)^2 (harmonic/cut, eps = 1) ----
pair_style harmonic/cut
pair_coeff 1 1 $(1.0/(2*v_d1^2):%.17g) $(v_d1:%.17g)
variable jf_s12 internal $(0.5*(v_d1+v_d2):%.17g)
if "${jf_ntypes} == 2" then "pair_coeff 1 2 $(1.0/(2*v_jf_s12^2):%.17g) $(v_jf_s12:%.17g)" "pair_coeff 2 2 $(1.0/(2*v_d2^2):%.17g) $(v_d2:%.17g)"
neighbor ${skin} bin
neigh_modify every 1 delay 0 check yes
# ---- smooth walls: E = K (a/2 - h)^2, K = 2 eps / a^2 = eps/2 (1 - h/(a/2))^2, one fix per size ----
if "${walls} == none" then "jump SELF jf_walls_done"
variable jf_k1 string $(2.0/v_d1^2:%.17g)
variable jf_r1 string $(v_d1/2.0:%.17g)
variable jf_k2 string $(2.0/v_d2^2:%.17g)
variable jf_r2 string $(v_d2/2.0:%.17g)
variable jf_w1 string ""
variable jf_w2 string ""
# the faces as equal-style variables of the box: an EDGE wall would stay where the box was
if "${jf_bx} == f" then "variable jf_xlo equal xlo" "variable jf_xhi equal xhi" "variable jf_w1 string '${jf_w1}xlo v_jf_xlo ${jf_k1} 0.0 ${jf_r1} xhi v_jf_xhi ${jf_k1} 0.0 ${jf_r1} '" "variable jf_w2 string '${jf_w2}xlo v_jf_xlo ${jf_k2} 0.0 ${jf_r2} xhi v_jf_xhi ${jf_k2} 0.0 ${jf_r2} '"
if "${jf_by} == f" then "variable jf_ylo equal ylo" "variable jf_yhi equal yhi" "variable jf_w1 string '${jf_w1}ylo v_jf_ylo ${jf_k1} 0.0 ${jf_r1} yhi v_jf_yhi ${jf_k1} 0.0 ${jf_r1} '" "variable jf_w2 string '${jf_w2}ylo v_jf_ylo ${jf_k2} 0.0 ${jf_r2} yhi v_jf_yhi ${jf_k2} 0.0 ${jf_r2} '"
if "${jf_bz} == f" then "variable jf_zlo equal zlo" "variable jf_zhi equal zhi" "variable jf_w1 string '${jf_w1}zlo v_jf_zlo ${jf_k1} 0.0 ${jf_r1} zhi v_jf_zhi ${jf_k1} 0.0 ${jf_r1} '" "variable jf_w2 string '${jf_w2}zlo v_jf_zlo ${jf_k2} 0.0 ${jf_r2} zhi v_jf_zhi ${jf_k2} 0.0 ${jf_r2} '"
group jf_w1 type 1
fix jf_wall1 jf_w1 wall/harmonic ${jf_w1}units box
fix_modify jf_wall1 energy yes virial yes
if "${jf_ntypes} == 2" then "group jf_w2 type 2" "fix jf_wall2 jf_w2 wall/harmonic ${jf_w2}units box" "fix_modify jf_wall2 energy yes virial yes"
label jf_walls_done
compute jf_press all pressure NULL virial
thermo_style custom step pe c_jf_press[*] fmax ke
thermo_modify norm no
thermo 0
if "${dim} == 2" then "fix jf_2d all enforce2d"

"""

_JAM_STATE = r"""# ---- protocol state (chapter steps 2-4); the cell the bisection scales is the start's ----
variable jf_basephi internal $(v_phi0:%.17g)
variable xy0 internal $(xy:%.17g)
variable jf_iters internal 0
variable jf_cg internal 0
if "${minimizer} == cg" then "variable jf_cg internal 1"
print "# step phi V P dphi iterations max_force reason" append ${jf_logtmp} screen no
variable jf_ret string jf_jammed
"""

_BISECT_HEAD = r"""
# ---- the bisection from the current cell (jf_clx, jf_cly, jf_clz, jf_cxy: its shape is kept) and
# phi = jf_basephi (jamflow/protocols/compression.py bisect); ends with a jump to ${jf_ret} in the window ----
label jf_bisect
variable jf_lx0 internal $(v_jf_clx:%.17g)
variable jf_ly0 internal $(v_jf_cly:%.17g)
variable jf_lz0 internal $(v_jf_clz:%.17g)
variable jf_xy0 internal $(v_jf_cxy:%.17g)
variable jf_phi internal $(v_jf_basephi:%.17g)
variable jf_dphi internal $(v_dphi0:%.17g)
variable jf_side internal 0
variable jf_step internal 0
variable jf_laststep internal 0
variable jf_resumes internal 0

label jf_step_loop
# the box is always set from the original one, so phi carries no accumulated round-off
variable jf_scale internal $((v_jf_basephi/v_jf_phi)^(1.0/v_dim):%.17g)
variable jf_nlx internal $(v_jf_lx0*v_jf_scale:%.17g)
variable jf_nly internal $(v_jf_ly0*v_jf_scale:%.17g)
variable jf_nlz internal $(v_jf_lz0*v_jf_scale:%.17g)
variable jf_nxy internal $(v_jf_xy0*v_jf_scale:%.17g)
variable jf_back string jf_scaled
jump SELF jf_setbox
label jf_scaled
variable jf_lmax internal $(ternary(lx>ly,lx,ly):%.17g)
if "${dim} == 3" then "variable jf_lmax internal $(ternary(lz>v_jf_lmax,lz,v_jf_lmax):%.17g)"
if "${jf_autoftol} == 1" then "variable jf_ftol internal $(""" + _FTOL_BASE + r"""*ternary(v_jf_lmax/20.0>1.0,v_jf_lmax/20.0,1.0):%.17g)" else "variable jf_ftol internal ${ftol}"

# ---- one minimisation with the chapter's stopping rules (jamflow/minimize/rules.py) ----
if "${minimizer} == md" then "timestep ${mddt}" else "timestep ${dt}"
variable jf_epp equal pe/atoms
fix jf_halt all halt 1 v_jf_epp < ${vmin} error continue
if "${minimizer} == fire" then "min_style fire" "min_modify norm max"
if "${minimizer} == cg" then "min_style cg" "min_modify norm max line forcezero"
variable jf_dampstyle string viscous
if "${jf_pairwise} == 1" then "variable jf_dampstyle string jamflow/damping"
if "${minimizer} == md" then "velocity all set 0.0 0.0 0.0" "fix jf_nve all nve" "fix jf_damp all ${jf_dampstyle} ${damping}"
# the energies of a damped-MD window (fix jf_vsamples) and their mean and rms deviation
variable jf_pe equal pe
variable jf_vmean equal ave(f_jf_vsamples)
variable jf_vdev vector (f_jf_vsamples-v_jf_vmean)^2
variable jf_vrms equal sqrt(ave(v_jf_vdev))
variable jf_vx atom f_jf_vstore[1]
variable jf_vy atom f_jf_vstore[2]
variable jf_vz atom f_jf_vstore[3]
""" + WINDOW_OPEN + r"""if "${minimizer} == md" then "fix jf_vsamples all vector ${mdsample} v_jf_pe"
if "${minimizer} == md" then "run $(v_jf_nsteps)" else "minimize 0.0 $(v_jf_ftol:%.17g) $(v_jf_nsteps) $(10*v_jf_nsteps)"
variable jf_ran internal $(step-v_jf_before)
# md: mean and rms of the energies sampled on the window's steps that are multiples of mdsample
variable jf_vm internal 0
variable jf_vr internal 0
if "$(v_jf_md == 1 && floor(step/v_mdsample)-ceil(v_jf_before/v_mdsample)+1 >= 2)" then "variable jf_vm internal $(v_jf_vmean:%.17g)" "variable jf_vr internal $(v_jf_vrms:%.17g)"
if "${minimizer} == md" then "unfix jf_vsamples"
variable jf_done internal $(v_jf_done+v_jf_ran)
variable jf_e internal $(pe/atoms:%.17g)
# no-progress compares V + K per particle in md (damping can only lower it), V alone otherwise
variable jf_et internal $(v_jf_e+v_jf_md*ke/atoms:%.17g)
# md: the potential's force alone, at rest (run 0 at v = 0), then the velocities put back
if "${minimizer} == md" then "fix jf_vstore all store/state 0 vx vy vz" "velocity all set 0.0 0.0 0.0" "run 0"
variable jf_fm internal $(fmax:%.17g)
if "${minimizer} == md" then "set group all vx v_jf_vx vy v_jf_vy vz v_jf_vz" "unfix jf_vstore"
"""

# the stopping rules of one window (jamflow/minimize/rules.py). Shared with the ellipse deck, which sets
# jf_e, jf_fm, jf_et (the energy no-progress compares) and jf_vm, jf_vr (the energy-steady rule's
# mean and rms; 0 switches it off) before them
RULES = r"""variable jf_reason string none
variable jf_capped internal 0
variable jf_conv internal 0
variable jf_vminstop internal 0
if "$(v_jf_fm < v_jf_ftol)" then "variable jf_reason string force" "variable jf_conv internal 1" "jump SELF jf_min_done"
if "$(v_jf_e < v_vmin)" then "variable jf_reason string energy-below-vmin" "variable jf_conv internal 1" "variable jf_vminstop internal 1" "jump SELF jf_min_done"
if "$(v_jf_vm > 0 && v_jf_vr/(v_jf_vm+(v_jf_vm<=0)) < v_delta)" then "variable jf_reason string energy-steady" "jump SELF jf_min_done"
if "$(v_jf_first == 0 && (v_jf_eprev-v_jf_et) < v_delta*v_jf_et && v_jf_fm > 0.5*v_jf_fmprev)" then "variable jf_reason string no-progress" "jump SELF jf_min_done"
if "$(v_jf_cg == 1 && v_jf_ran < v_jf_nsteps)" then "variable jf_reason string linesearch" "jump SELF jf_min_done"
if "$(v_jf_done >= v_maxiter)" then "variable jf_reason string iteration-cap" "variable jf_capped internal 1" "jump SELF jf_min_done"
variable jf_eprev internal $(v_jf_et:%.17g)
variable jf_fmprev internal $(v_jf_fm:%.17g)
variable jf_first internal 0
jump SELF jf_window
label jf_min_done
"""

_MINIMISATION_DONE = r"""unfix jf_halt
if "${minimizer} == md" then "unfix jf_nve" "unfix jf_damp" "velocity all set 0.0 0.0 0.0"
variable jf_iters internal $(v_jf_iters+v_jf_done)
variable jf_p internal $((c_jf_press[1]+c_jf_press[2]+ternary(v_dim==3,c_jf_press[3],0))/v_dim:%.17g)
print "$(v_jf_step) $(v_jf_phi:%.17g) $(v_jf_e:%.17g) $(v_jf_p:%.17g) $(v_jf_laststep:%.17g) $(v_jf_done) $(v_jf_fm:%.17g) ${jf_reason}" append ${jf_logtmp} screen no
"""

# resume a capped state in the window, decide the side, step phi (jumps to ${jf_ret} in the window);
# shared with the ellipse deck
DECIDE = r"""
# ---- a state in the window cut off by the iteration cap is not yet a minimum: minimise it
# again in place, at most 3 times a run (WINDOW_RESUMES in jamflow/protocols/compression.py) ----
if "$(v_jf_capped == 1 && v_jf_e > v_vtol && v_jf_e < 2*v_vtol && v_jf_resumes < 3)" then "variable jf_resumes internal $(v_jf_resumes+1)" "variable jf_laststep internal 0" "variable jf_step internal $(v_jf_step+1)" "jump SELF jf_step_loop"

# ---- decide: in the window, compress, or decompress; halve dphi on a crossing ----
# (a minimisation stopped by V < V_min counts as unjammed, whatever V is)
if "$(v_jf_e > v_vtol && v_jf_e < 2*v_vtol && v_jf_vminstop == 0)" then "jump SELF ${jf_ret}"
variable jf_newside internal $(ternary(v_jf_e<=v_vtol||v_jf_vminstop==1,1,-1))
if "$(v_jf_side != 0 && v_jf_side != v_jf_newside)" then "variable jf_dphi internal $(v_jf_dphi/2.0:%.17g)"
variable jf_side internal ${jf_newside}
variable jf_target internal $(ternary(v_jf_side>0,v_jf_phi+v_jf_dphi,v_jf_phi-v_jf_dphi):%.17g)
if "$(v_jf_target <= 0 || v_jf_target >= 1)" then "variable jf_bad string 'packing fraction left (0, 1) (next phi = $(v_jf_target)): start from a lower phi0'" "jump SELF jf_fail"
variable jf_laststep internal $(abs(v_jf_target-v_jf_phi):%.17g)
if "$(v_jf_laststep < 4*2.220446049250313e-16*v_jf_phi)" then "variable jf_bad string 'the increment $(v_jf_laststep:%.3e) reached float64 resolution at phi = $(v_jf_phi:%.15f) without V landing in (vtol, 2 vtol): the window is narrower than the energy step between adjacent representable densities or the minimiser is not converging; use a larger vtol or a tighter ftol'" "jump SELF jf_fail"
variable jf_phi internal $(v_jf_target:%.17g)
variable jf_step internal $(v_jf_step+1)
if "$(v_jf_step >= v_maxsteps)" then "variable jf_bad string 'no packing in the window after ${maxsteps} minimisations: raise maxsteps'" "jump SELF jf_fail"
jump SELF jf_step_loop

"""

_BISECT = _BISECT_HEAD + RULES + _MINIMISATION_DONE + DECIDE

_UNCONVERGED = r"""if "${jf_conv} == 0" then "print '# warning: final minimisation stopped by ${jf_reason} with max force $(v_jf_fm:%.2e) (tolerance $(v_jf_ftol:%.1e)): force balance is only that good' append ${jf_logtmp} screen yes"
"""

JAM_SUCCESS = r"""# ---- success: the final packing as a data file, and the summary line ----
label jf_jammed
""" + _UNCONVERGED + r"""write_data ${out}.data.partial
shell mv ${out}.data.partial ${out}.data
print "# result phi_J $(v_jf_phi:%.17g) V $(v_jf_e:%.17g) P $(v_jf_p:%.17g) max_force $(v_jf_fm:%.17g) minimisations $(v_jf_step+1) iterations $(v_jf_iters) status jammed" append ${jf_logtmp} screen no
shell mv ${jf_logtmp} ${jf_log}
print "jamflow deck: phi_J = $(v_jf_phi:%.12f)  V = $(v_jf_e:%.3e)  P = $(v_jf_p:%.3e)  max|F| = $(v_jf_fm:%.1e)  $(v_jf_step+1) minimisations  -> ${out}.data, ${jf_log}"
quit 0

"""

_SHEAR_START = r"""
# ---- the shear path (jamflow/protocols/shear.py): step 0 brings the start into the window at its
# own strain; step k shears x_i -> x_i + dgamma y_i (the cell's xy tilt to gamma_k l_y, chapter eq. 2.4)
# and runs the bisection at that fixed strain. The accumulated tilt xy0 of the start (the data file
# holds the reduced one) sets gamma_0 = xy0 / l_y. ----
if "${jf_autoxy} == 1" then "variable xy0 delete" "variable xy0 string $(xy:%.17g)"
"""

_SHEAR_PATH = r"""if "$(abs(v_jf_cxy-v_jf_k*v_jf_clx-xy) > 1e-12*v_jf_clx)" then "variable jf_bad string 'xy0 = ${xy0} does not fold to the data file tilt $(xy:%.17g): omit -var xy0 to start at the file tilt'" "jump SELF jf_fail"
variable jf_g0 internal $(v_jf_cxy/v_jf_cly:%.17g)
if "$((v_to-v_jf_g0)*v_dgamma <= 0)" then "variable jf_bad string 'dgamma = ${dgamma} does not move gamma from $(v_jf_g0:%.17g) towards to = ${to}'" "jump SELF jf_fail"
variable jf_ratio internal $((v_to-v_jf_g0)/v_dgamma:%.17g)
if "${jf_autosteps} == 1" then "variable steps delete" "variable steps string $(ternary(abs(v_jf_ratio-round(v_jf_ratio))<1e-6,round(v_jf_ratio),ceil(v_jf_ratio)))"
if "$(v_steps < 1)" then "variable steps delete" "variable steps string 1"
group jf_t1 type 1
group jf_t2 type 2
if "${jf_autovsum} == 1" then "variable vsum delete" "variable vsum string $(count(jf_t1)*v_jf_a1+count(jf_t2)*v_jf_a2:%.17g)"
group jf_t1 delete
group jf_t2 delete
variable jf_iters internal 0
variable jf_cg internal 0
if "${minimizer} == cg" then "variable jf_cg internal 1"
print "# layout: per shear step a line '# shear step k gamma_k', one line per minimisation (step phi V P dphi iterations max_force reason)" append ${jf_logtmp} screen no
print "# layout: and a line '# static k gamma phi_J V P Pxy minimisations iterations'" append ${jf_logtmp} screen no
variable jf_ret string jf_static
variable jf_sk internal 0
variable jf_gk internal $(v_jf_g0:%.17g)

label jf_shear_loop
print "# shear step $(v_jf_sk) $(v_jf_gk:%.17g)" append ${jf_logtmp} screen no
variable jf_basephi internal $(ternary(v_dim==2,v_vsum/(v_jf_clx*v_jf_cly),v_vsum/(v_jf_clx*v_jf_cly*v_jf_clz)):%.17g)
jump SELF jf_bisect

label jf_static
""" + _UNCONVERGED + r"""print "# static $(v_jf_sk) $(v_jf_gk:%.17g) $(v_jf_phi:%.17g) $(v_jf_e:%.17g) $(v_jf_p:%.17g) $(c_jf_press[4]:%.17g) $(v_jf_step+1) $(v_jf_iters)" append ${jf_logtmp} screen no
if "$(v_jf_sk >= v_steps)" then "jump SELF jf_path_done"
variable jf_sk internal $(v_jf_sk+1)
variable jf_gk internal $(ternary(v_jf_sk==v_steps,v_to,v_jf_g0+v_dgamma*v_jf_sk):%.17g)
variable jf_nlx internal $(v_jf_clx:%.17g)
variable jf_nly internal $(v_jf_cly:%.17g)
variable jf_nlz internal $(v_jf_clz:%.17g)
variable jf_nxy internal $(v_jf_gk*v_jf_cly:%.17g)
variable jf_back string jf_shear_loop
jump SELF jf_setbox

# ---- success: the final packing as a data file, and the summary line ----
label jf_path_done
write_data ${out}.data.partial
shell mv ${out}.data.partial ${out}.data
print "# result gamma $(v_jf_gk:%.17g) phi_J $(v_jf_phi:%.17g) V $(v_jf_e:%.17g) steps ${steps} iterations $(v_jf_iters) status sheared" append ${jf_logtmp} screen no
shell mv ${jf_logtmp} ${jf_log}
print "jamflow shear deck: ${steps} steps to gamma = $(v_jf_gk:%.6g), phi_J = $(v_jf_phi:%.12f)  -> ${out}.data, ${jf_log}"
quit 0

"""

_CURRENT_CELL = r"""# ---- the current cell as the controller holds it: accumulated tilt xy0 (may exceed lx/2), the fold k
# that reduces it into LAMMPS's range (Box.reduction), triclinic once any tilt was set ----
variable jf_clx internal $(lx:%.17g)
variable jf_cly internal $(ly:%.17g)
variable jf_clz internal $(lz:%.17g)
variable jf_cxy internal $(v_xy0:%.17g)
variable jf_tri internal $(v_jf_cxy != 0)
variable jf_k internal $(floor(v_jf_cxy/v_jf_clx)+(v_jf_cxy/v_jf_clx-floor(v_jf_cxy/v_jf_clx)>=0.5))
"""

FAIL = r"""label jf_fail
print "# result status failed: ${jf_bad}" append ${jf_logtmp} screen no
shell mv ${jf_logtmp} ${jf_log}
print "ERROR: jamflow deck: ${jf_bad}"
quit 1
"""

_SETBOX = r"""
# ---- set the cell to the accumulated box (jf_nlx, jf_nly, jf_nlz, jf_nxy), as LammpsEngine.set_box:
# LAMMPS holds the reduced cell (tilt folded by k cell lengths into [-lx/2, lx/2)); the affine
# step (remap) in the current folding, then, if the fold changed, the flip to the new reduced
# cell without remap (the same lattice: atoms do not move). Returns to ${jf_back}. ----
label jf_setbox
variable jf_x internal $(v_jf_nxy/v_jf_nlx:%.17g)
variable jf_kn internal $(floor(v_jf_x)+(v_jf_x-floor(v_jf_x)>=0.5))
if "$(v_jf_tri == 0 && v_jf_nxy != 0)" then "change_box all triclinic" "variable jf_tri internal 1"
variable jf_xyc internal $(v_jf_nxy-v_jf_k*v_jf_nlx:%.17g)
variable jf_xyn internal $(v_jf_nxy-v_jf_kn*v_jf_nlx:%.17g)
if "${jf_tri} == 0 && ${dim} == 2" then "change_box all x final 0 $(v_jf_nlx:%.17g) y final 0 $(v_jf_nly:%.17g) remap units box"
if "${jf_tri} == 0 && ${dim} == 3" then "change_box all x final 0 $(v_jf_nlx:%.17g) y final 0 $(v_jf_nly:%.17g) z final 0 $(v_jf_nlz:%.17g) remap units box"
if "${jf_tri} == 1 && ${dim} == 2" then "change_box all x final 0 $(v_jf_nlx:%.17g) y final 0 $(v_jf_nly:%.17g) xy final $(v_jf_xyc:%.17g) remap units box"
if "${jf_tri} == 1 && ${dim} == 3" then "change_box all x final 0 $(v_jf_nlx:%.17g) y final 0 $(v_jf_nly:%.17g) z final 0 $(v_jf_nlz:%.17g) xy final $(v_jf_xyc:%.17g) xz final 0 yz final 0 remap units box"
if "$(v_jf_kn != v_jf_k && v_dim == 2)" then "change_box all x final 0 $(v_jf_nlx:%.17g) y final 0 $(v_jf_nly:%.17g) xy final $(v_jf_xyn:%.17g) units box"
if "$(v_jf_kn != v_jf_k && v_dim == 3)" then "change_box all x final 0 $(v_jf_nlx:%.17g) y final 0 $(v_jf_nly:%.17g) z final 0 $(v_jf_nlz:%.17g) xy final $(v_jf_xyn:%.17g) xz final 0 yz final 0 units box"
variable jf_k internal ${jf_kn}
variable jf_clx internal $(v_jf_nlx:%.17g)
variable jf_cly internal $(v_jf_nly:%.17g)
variable jf_clz internal $(v_jf_nlz:%.17g)
variable jf_cxy internal $(v_jf_nxy:%.17g)
jump SELF ${jf_back}
"""


BODY = (_MIRROR_NOTE + LOG_OPEN + _JAM_OPTIONS + _CHECKS + _SYSTEM + _RANDOM_START + _READ_DATA + _ATOMS_READY + _JAM_PHI + _POTENTIAL
        + _JAM_STATE + _CURRENT_CELL + _BISECT + JAM_SUCCESS + FAIL + _SETBOX)

SHEAR_BODY = (_MIRROR_NOTE + LOG_OPEN + _SHEAR_OPTIONS + _CHECKS + _SHEAR_CHECKS_EXTRA + _SYSTEM + _READ_DATA + _ATOMS_READY
              + _POTENTIAL + _SHEAR_START + _CURRENT_CELL + _SHEAR_PATH + _BISECT + FAIL + _SETBOX)
