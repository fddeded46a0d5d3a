"""The LAMMPS input deck that jams ellipses (2D) or spheroids (3D) on its own, with jamflow's
plugin pair style jamflow/ellipsoid and damped dynamics over positions and orientations.

``HEADER`` (formatted by ``jamflow.decks.ellipsoids.deck_text``) documents the deck and sets its
parameters as ``index`` variables (``lmp -var NAME VALUE`` overrides them); ``BODY`` is the
chapter protocol (section 2.1), minimising as ``LammpsEngine`` does for ellipsoids (its rotating
session: fix nve/asphere + fix langevin at T = 0 with angmom; forces and generalized torques
measured without the drag) and stopping by ``jamflow.minimize.rules``'s rules on both. The window's
stopping rules and the bisection that follows each minimisation are the disk deck's own text
(``deck_script.RULES``, ``deck_script.DECIDE``, ``JAM_SUCCESS``, ``FAIL``).
"""

from jamflow.decks.jam_script import (DECIDE, FAIL, JAM_START_OPTIONS, JAM_SUCCESS, LOG_OPEN, RULES, WINDOW_OPEN,
                                      random_atoms)

from jamflow.model.shapes.shape import ELLIPSOID_FORCE_TOL_BASE

_FTOL_BASE = repr(ELLIPSOID_FORCE_TOL_BASE)  # the force floor's base (ellipses, spheroids), as the deck's text writes it

HEADER = """\
# jamflow deck: jam N soft ellipses (dim 2) or spheroids (dim 3) at onset by isotropic
# compression (Schreck & O'Hern, chapter section 2.1) in the LAMMPS input language alone,
# with jamflow's plugin pair style jamflow/ellipsoid (exact contact distance, section 2.3.2) and
# damped dynamics over positions and orientations. Written by jamflow {version};
# `jamflow jam --shape ellipse:ALPHA --emit-deck FILE ...` writes it again.
#
#   lmp -in jam-ellipses.lmp -var plugin /path/jamflow_pairs.so -var N 64 -var alpha 1.6
#   lmp -in jam-ellipses.lmp -var plugin ... -var dim 3 -var N 128 -var alpha 0.5 -var d2 1
#   lmp -in jam-ellipses.lmp -var plugin ... -var data start.data -var out jammed
#
# PLUGIN: the jamflow plugin compiled for this LAMMPS (python -c "from jamflow.engines.lammps.plugin_build
# import plugin_library; print(plugin_library())" builds and prints it).
# Writes OUT.data (the final packing, atom_style ellipsoid) and OUT.protocol.txt (one line per
# minimisation: step phi V P dphi iterations max_force reason; max_force is the larger of the
# max force component and the max generalized torque tau_a / d_k; then a "# result" line). Exit
# status 0 when jammed (V_tol < V < 2 V_tol), 1 when the protocol failed (reason in both logs).
# Units: LJ with small across-axis length b = 1, epsilon 1, mass 1; V is the energy per particle.
# Potential: V = eps/2 (1 - r/sigma_ij)^2 for r < sigma_ij, sigma_ij the contact distance.
# Particles: a = alpha b along the director (body x), b across; sizes scale whole particles.
# Optional variables (not set here):
#   -var data FILE   start from FILE (atom_style ellipsoid with an Ellipsoids section)
#   -var phi0 PHI    start packing fraction; default 0.80 (2D) / 0.55 (3D); with data, the file's own
#   -var ftol F      force and generalized-torque tolerance; default """ + _FTOL_BASE + """ max(1, L/20), L = box side
{optional}
variable plugin    index {plugin:<12} # the jamflow plugin library
variable dim       index {dim:<12} # 2: ellipses, 3: spheroids
variable N         index {N:<12} # particles (random start only)
variable alpha     index {alpha:<12} # aspect ratio a/b (2D >= 1; 3D < 1 oblate)
variable contact   index {contact:<12} # exact | gaussian | cleaver | linear | quadratic
variable d1        index {d1:<12} # small size b, type 1
variable d2        index {d2:<12} # large size b, type 2 (= d1: monodisperse)
variable fsmall    index {fsmall:<12} # fraction of small particles (random start)
variable seed      index {seed:<12} # random start: create_atoms seeds seed+1, seed+1000001; quat/random seed+2
variable vtol      index {vtol:<12} # energy window V_tol < V < 2 V_tol (per particle)
variable dphi0     index {dphi0:<12} # initial packing-fraction increment
variable vmin      index {vmin:<12} # stop a minimisation when V < V_min
variable delta     index {delta:<12} # no-progress: energy decrease < delta V over a window
variable window    index {window:<12} # steps per run between rule checks
variable maxiter   index {maxiter:<12} # step cap per minimisation
variable mddt      index {mddt:<12} # damped-dynamics step
variable damping   index {damping:<12} # drag rate (1/damp of fix langevin) on translations and rotations
variable maxsteps  index {maxsteps:<12} # cap on minimisations
variable skin      index {skin:<12} # neighbour-list skin
variable out       index {out:<12} # output prefix
"""

_SETUP = "\n" + LOG_OPEN + JAM_START_OPTIONS + r"""print "# dim ${dim} N ${N} alpha ${alpha} contact ${contact} d1 ${d1} d2 ${d2} phi0 ${phi0} seed ${seed} vtol ${vtol} dphi0 ${dphi0} damping ${damping} ftol ${ftol} data ${data}" append ${jf_logtmp} screen no

# ---- check the parameters before any work ----
if "${dim} != 2 && ${dim} != 3" then "variable jf_bad string 'dim must be 2 or 3'" "jump SELF jf_fail"
if "$(v_alpha <= 0)" then "variable jf_bad string 'alpha must be > 0'" "jump SELF jf_fail"
if "$(v_dim == 2 && v_alpha < 1)" then "variable jf_bad string 'an ellipse with alpha < 1 is the ellipse with 1/alpha turned: use alpha >= 1 in 2D'" "jump SELF jf_fail"
if "$(v_vtol <= 0 || v_dphi0 <= 0 || v_dphi0 >= 0.1)" then "variable jf_bad string 'need vtol > 0 and 0 < dphi0 < 0.1'" "jump SELF jf_fail"
if "$(v_d1 <= 0 || v_d2 < v_d1)" then "variable jf_bad string 'need 0 < d1 <= d2'" "jump SELF jf_fail"
if "$(v_vmin > v_vtol)" then "variable jf_bad string 'vmin = ${vmin} is above vtol = ${vtol}: set -var vmin ${vtol}'" "jump SELF jf_fail"
if "$(v_damping*v_mddt >= 2 || v_damping <= 0)" then "variable jf_bad string 'need 0 < damping x mddt < 2'" "jump SELF jf_fail"
variable jf_gauss internal 0
variable jf_trunc internal 0
if "${contact} == gaussian" then "variable jf_gauss internal 1"
if "${contact} == linear || ${contact} == quadratic" then "variable jf_trunc internal 1"
if "${contact} != exact && ${contact} != cleaver && $(v_jf_gauss+v_jf_trunc) == 0" then "variable jf_bad string 'contact must be exact, gaussian, cleaver, linear or quadratic'" "jump SELF jf_fail"
if "$(v_jf_gauss == 1 && v_d1 != v_d2)" then "variable jf_bad string 'contact gaussian (Berne-Pechukas eq. 2.5) assumes identical particles: use cleaver or exact, or d2 = d1'" "jump SELF jf_fail"
if "$(v_jf_trunc == 1 && v_dim == 3 && v_d1 != v_d2)" then "variable jf_bad string 'contact ${contact} truncates the quintic of identical spheroids: use exact or cleaver, or d2 = d1'" "jump SELF jf_fail"

units lj
dimension ${dim}
boundary p p p
atom_style ellipsoid
atom_modify map array
comm_modify vel yes
plugin load ${plugin}

# full axes a = alpha d along the director, d across; volumes pi a b / 4 (2D), pi a b^2 / 6 (3D)
variable jf_a1 internal $(v_alpha*v_d1:%.17g)
variable jf_a2 internal $(v_alpha*v_d2:%.17g)
variable jf_v1 internal $(ternary(v_dim==2,PI*v_jf_a1*v_d1/4.0,PI*v_jf_a1*v_d1^2/6.0):%.17g)
variable jf_v2 internal $(ternary(v_dim==2,PI*v_jf_a2*v_d2/4.0,PI*v_jf_a2*v_d2^2/6.0):%.17g)
variable jf_ntypes internal $(ternary(v_d1==v_d2,1,2))
if "${jf_hasdata} == 1" then "jump SELF jf_read"

# ---- random start (chapter step 1): uniform positions and orientations at phi0 ----
""" + random_atoms("jf_v") + r"""set type 1 shape ${jf_a1} ${d1} ${d1}
if "$(v_jf_n2 > 0)" then "set type 2 shape ${jf_a2} ${d2} ${d2}"
set group all quat/random $(v_seed+2)
jump SELF jf_atoms_ready

# ---- start from a data file (atom_style ellipsoid; type 1 across-axis d1, type 2 d2) ----
label jf_read
read_data ${data}

label jf_atoms_ready
# mass 1: LAMMPS's ellipsoid mass is density x (pi/6) x the product of the three full axes
variable jf_rho1 internal $(6.0/(PI*v_jf_a1*v_d1^2):%.17g)
variable jf_rho2 internal $(6.0/(PI*v_jf_a2*v_d2^2):%.17g)
set type 1 density ${jf_rho1}
if "${jf_ntypes} == 2" then "set type 2 density ${jf_rho2}"
group jf_t1 type 1
group jf_t2 type 2
variable jf_phibox internal $((count(jf_t1)*v_jf_v1+count(jf_t2)*v_jf_v2)/ternary(v_dim==2,lx*ly,lx*ly*lz):%.17g)
group jf_t1 delete
group jf_t2 delete
if "${jf_autophi} == 1" then "variable phi0 delete" "variable phi0 string $(v_jf_phibox:%.17g)"
if "$(abs(v_phi0-v_jf_phibox) > 1e-12*v_jf_phibox)" then "variable jf_bad string 'phi0 = ${phi0} but the start has phi = $(v_jf_phibox:%.17g): omit -var phi0 to use the start as it is'" "jump SELF jf_fail"

# ---- the pair potential: spring law, contact distance of the chosen method ----
pair_style jamflow/ellipsoid ${contact} spring 2 $(ternary(v_alpha>1,v_jf_a2,v_d2):%.17g)
pair_coeff * * 1
neighbor ${skin} bin
neigh_modify every 1 delay 0 check yes
compute jf_press all pressure NULL virial
compute jf_shape all property/atom shapex shapey shapez
compute jf_q all property/atom quatw quati quatj quatk
compute jf_tq all property/atom tqx tqy tqz
if "${dim} == 2" then "fix jf_2d all enforce2d"

# generalized torques tau_a / d_k on the rotational degrees of freedom (jamflow.model.shapes.rotations):
# 2D tau_z / d_k, d_k = sqrt(a^2 + b^2) / 4; 3D the body-frame components across the director,
# (R^T tau)_y,z / d_k, d_k = sqrt((a^2 + b^2) / 20), R the rotation of the quaternion
variable jf_qw atom c_jf_q[1]
variable jf_qi atom c_jf_q[2]
variable jf_qj atom c_jf_q[3]
variable jf_qk atom c_jf_q[4]
variable jf_dk2 atom sqrt(c_jf_shape[1]^2+c_jf_shape[2]^2)/4.0
variable jf_dk3 atom sqrt((c_jf_shape[1]^2+c_jf_shape[2]^2)/20.0)
variable jf_gy atom (2*(v_jf_qi*v_jf_qj-v_jf_qw*v_jf_qk)*c_jf_tq[1]+(1-2*(v_jf_qi^2+v_jf_qk^2))*c_jf_tq[2]+2*(v_jf_qj*v_jf_qk+v_jf_qw*v_jf_qi)*c_jf_tq[3])/v_jf_dk3
variable jf_gz atom (2*(v_jf_qi*v_jf_qk+v_jf_qw*v_jf_qj)*c_jf_tq[1]+2*(v_jf_qj*v_jf_qk-v_jf_qw*v_jf_qi)*c_jf_tq[2]+(1-2*(v_jf_qi^2+v_jf_qj^2))*c_jf_tq[3])/v_jf_dk3
if "${dim} == 2" then "variable jf_g atom abs(c_jf_tq[3])/v_jf_dk2" else "variable jf_g atom max(abs(v_jf_gy),abs(v_jf_gz))"
compute jf_gmax all reduce max v_jf_g
thermo_style custom step pe c_jf_press[*] fmax c_jf_gmax
thermo_modify norm no
thermo 0
run 0
variable jf_wrong atom "(type==1 && (abs(c_jf_shape[2]-v_d1)>1e-12*v_d1 || abs(c_jf_shape[1]-v_jf_a1)>1e-12*v_jf_a1)) || (type==2 && (abs(c_jf_shape[2]-v_d2)>1e-12*v_d2 || abs(c_jf_shape[1]-v_jf_a2)>1e-12*v_jf_a2)) || type>2"
group jf_wrong variable jf_wrong
if "$(count(jf_wrong) > 0)" then "variable jf_bad string '$(count(jf_wrong)) atoms are not ellipsoids of axes alpha d, d (d1 = ${d1} type 1, d2 = ${d2} type 2, alpha = ${alpha}): pass -var alpha, d1, d2'" "jump SELF jf_fail"
group jf_wrong delete

# ---- protocol state (chapter steps 2-4) ----
variable jf_basephi internal $(v_phi0:%.17g)
variable jf_lx0 internal $(lx:%.17g)
variable jf_ly0 internal $(ly:%.17g)
variable jf_lz0 internal $(lz:%.17g)
variable jf_phi internal $(v_phi0:%.17g)
variable jf_dphi internal $(v_dphi0:%.17g)
variable jf_side internal 0
variable jf_step internal 0
variable jf_laststep internal 0
variable jf_iters internal 0
variable jf_resumes internal 0
variable jf_cg internal 0
variable jf_ret string jf_jammed
print "# step phi V P dphi iterations max_force reason" append ${jf_logtmp} screen no

label jf_step_loop
variable jf_scale internal $((v_jf_basephi/v_jf_phi)^(1.0/v_dim):%.17g)
if "${dim} == 2" then "change_box all x final 0 $(v_jf_lx0*v_jf_scale:%.17g) y final 0 $(v_jf_ly0*v_jf_scale:%.17g) remap units box" else "change_box all x final 0 $(v_jf_lx0*v_jf_scale:%.17g) y final 0 $(v_jf_ly0*v_jf_scale:%.17g) z final 0 $(v_jf_lz0*v_jf_scale:%.17g) remap units box"
variable jf_lmax internal $(ternary(lx>ly,lx,ly):%.17g)
if "${dim} == 3" then "variable jf_lmax internal $(ternary(lz>v_jf_lmax,lz,v_jf_lmax):%.17g)"
if "${jf_autoftol} == 1" then "variable jf_ftol internal $(""" + _FTOL_BASE + r"""*ternary(v_jf_lmax/20.0>1.0,v_jf_lmax/20.0,1.0):%.17g)" else "variable jf_ftol internal ${ftol}"

# ---- one minimisation: damped dynamics over positions and orientations ----
timestep ${mddt}
variable jf_epp equal pe/atoms
fix jf_halt all halt 1 v_jf_epp < ${vmin} error continue
velocity all set 0.0 0.0 0.0
set group all angmom 0.0 0.0 0.0
fix jf_nve all nve/asphere
fix jf_lang all langevin 0.0 0.0 $(1.0/v_damping:%.17g) 4928459 angmom 1.0
if "${dim} == 2" then "unfix jf_2d" "fix jf_2d all enforce2d"
""" + WINDOW_OPEN + r"""run $(v_jf_nsteps)
variable jf_ran internal $(step-v_jf_before)
variable jf_done internal $(v_jf_done+v_jf_ran)
# forces and torques without the drag: its fix out, one force evaluation
unfix jf_lang
run 0
variable jf_e internal $(pe/atoms:%.17g)
variable jf_fm internal $(ternary(fmax>c_jf_gmax,fmax,c_jf_gmax):%.17g)
# no-progress on V alone (the drag only lowers V + K, as in LammpsEngine's rotating session); no energy-steady rule
variable jf_et internal $(v_jf_e:%.17g)
variable jf_vm internal 0
variable jf_vr internal 0
fix jf_lang all langevin 0.0 0.0 $(1.0/v_damping:%.17g) 4928459 angmom 1.0
if "${dim} == 2" then "unfix jf_2d" "fix jf_2d all enforce2d"
"""

_MINIMISATION_DONE = r"""unfix jf_halt
unfix jf_nve
unfix jf_lang
velocity all set 0.0 0.0 0.0
set group all angmom 0.0 0.0 0.0
variable jf_iters internal $(v_jf_iters+v_jf_done)
variable jf_p internal $((c_jf_press[1]+c_jf_press[2]+ternary(v_dim==3,c_jf_press[3],0))/v_dim:%.17g)
print "$(v_jf_step) $(v_jf_phi:%.17g) $(v_jf_e:%.17g) $(v_jf_p:%.17g) $(v_jf_laststep:%.17g) $(v_jf_done) $(v_jf_fm:%.17g) ${jf_reason}" append ${jf_logtmp} screen no
"""

BODY = _SETUP + RULES + _MINIMISATION_DONE + DECIDE + JAM_SUCCESS + FAIL
