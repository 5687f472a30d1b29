#!/usr/bin/env bash
# Command-line behaviour: every case in inputs/ validates; a bad case exits
# with code 2 and writes nothing; a run leaves a .pvd series whose files VTK
# reads back with the expected arrays and values.
set -euo pipefail
talus=$1
repo=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

for case in "$repo"/inputs/*.yaml; do
  "$talus" check "$case" > /dev/null || { echo "FAIL: talus check $case"; exit 1; }
done

# The explicit case: `check` reports the step it chose, time.cfl (0.5) x the
# stability limit 2 dx / (c_p sqrt(2 * 3)) = 2.985e-4 s for E = 1 MPa, nu = 0.3,
# rho = 1800, dx = 0.01 (docs/explicit.md#the-step).
"$talus" check "$repo/inputs/reference_column_explicit.yaml" > explicit_check.log
grep -q "is a valid 2D case, explicit steps of 0.000149 s" explicit_check.log ||
  { echo "FAIL: talus check does not report the explicit step"; cat explicit_check.log; exit 1; }

# The particle file of inputs/landslide_from_particles.yaml is what
# scripts/fill_between_surfaces.py writes from its two profiles (the command
# in the case's header), particle for particle.
/usr/bin/python3 "$repo/scripts/fill_between_surfaces.py" "$repo/inputs/terrain/hillside_2d.txt" \
  "$repo/inputs/terrain/slide_top_2d.txt" --spacing 0.05 --out slide.csv > fill.log
grep -v '^#' slide.csv > slide.rows
grep -v '^#' "$repo/inputs/particles/slide_mass_2d.csv" > committed.rows
cmp -s slide.rows committed.rows || { echo "FAIL: fill_between_surfaces.py does not reproduce slide_mass_2d.csv"; exit 1; }
grep -q "800 particles, area 2 m^2" fill.log || { echo "FAIL: fill_between_surfaces.py: $(cat fill.log)"; exit 1; }
# The same for the 3D particle file of inputs/landslide_3d_from_dem.yaml.
/usr/bin/python3 "$repo/scripts/fill_between_surfaces.py" "$repo/inputs/terrain/channel_3d.asc" \
  "$repo/inputs/terrain/channel_3d_slide_top.asc" --spacing 0.075 --out slide3d.csv > fill.log
grep -v '^#' slide3d.csv > slide.rows
grep -v '^#' "$repo/inputs/particles/channel_slide_3d.csv" > committed.rows
cmp -s slide.rows committed.rows || { echo "FAIL: fill_between_surfaces.py does not reproduce channel_slide_3d.csv"; exit 1; }
# The disc of inputs/rolling_disc.yaml is what scripts/ring_disc.py writes
# (the command in the case's header): 804 particles on 16 rings, and its
# area pi R^2 = 0.125664 m^2 (the rings' areas shared out exactly).
/usr/bin/python3 "$repo/scripts/ring_disc.py" --centre 0.5 0.3 --radius 0.2 --rings 16 --out disc.csv > disc.log
grep -v '^#' disc.csv > slide.rows
grep -v '^#' "$repo/inputs/particles/ring_disc_2d.csv" > committed.rows
cmp -s slide.rows committed.rows || { echo "FAIL: ring_disc.py does not reproduce ring_disc_2d.csv"; exit 1; }
grep -q "804 particles, area 0.125664 m^2" disc.log || { echo "FAIL: ring_disc.py: $(cat disc.log)"; exit 1; }

# Two rigid blocks side by side, each paired with the base under them, share
# grid points from the start: they are not held apart from each other, and
# the run says so once (docs/contact.md#rigid-bodies).
cat > rigid_pair.yaml <<EOF
grid: {lower: [0, 0], upper: [1.2, 0.6], cell_size: 0.05}
time: {end: 0.02, step: 0.01}
output: {enabled: false}
gravity: [0, -9.81]
materials: [{name: rock, model: linear_elastic, density: 2000, youngs_modulus: 2.0e7, poisson_ratio: 0.3}]
bodies: [{name: base, material: rock, box: {lower: [0.0, 0.0], upper: [1.2, 0.2]}},
         {name: left, material: rock, rigid: true, box: {lower: [0.2, 0.2], upper: [0.5, 0.4]}},
         {name: right, material: rock, rigid: true, box: {lower: [0.5, 0.2], upper: [0.8, 0.4]}}]
contact: {bodies: [{pair: [left, base], friction: 0.3}, {pair: [right, base], friction: 0.3}]}
boundaries: {x_min: fixed, x_max: fixed, y_min: fixed, y_max: free}
EOF
"$talus" run rigid_pair.yaml > rigid_pair.log 2>&1 || { echo "FAIL: the two rigid blocks did not run"; cat rigid_pair.log; exit 1; }
[ "$(grep -c 'warning: two rigid bodies share' rigid_pair.log)" -eq 1 ] ||
  { echo "FAIL: no single warning of two rigid bodies on one grid point"; cat rigid_pair.log; exit 1; }

# 3D: a bumpy sliding surface (an ESRI height map, 0.5 m cells) and the same
# surface raised by 0.5 m at 15 interior nodes. Both are split into the same
# triangles, so the mass between them is the piecewise-linear tent of the
# thickness: exactly 15 x 0.5 x 0.5^2 = 1.875 m^3. The lattice volume must
# match it to 2 % (spacing 0.05 m: a column's count is off by less than one
# point, and the errors of about 300 columns average out). The case that puts
# the particles on the sliding surface as its terrain obstacle must pass
# `talus check`, which stops on any particle inside the obstacle: the script
# must split the cells along the obstacle's diagonal.
/usr/bin/python3 - <<'PY'
import math
def write(path, thickness):
    with open(path, "w") as f:
        f.write("ncols 9\nnrows 5\nxllcenter 0.0\nyllcenter 0.0\ncellsize 0.5\n")
        for j in reversed(range(5)):  # north row first
            row = []
            for i in range(9):
                z = 1.0 - 0.125 * i + 0.15 * math.sin(3 * i + 5 * j)
                if thickness and 2 <= i <= 6 and 1 <= j <= 3:
                    z += 0.5
                row.append(f"{z:.17g}")
            f.write(" ".join(row) + "\n")
write("lower.asc", False)
write("upper.asc", True)
PY
/usr/bin/python3 "$repo/scripts/fill_between_surfaces.py" lower.asc upper.asc --spacing 0.05 --out mass3d.csv > fill3d.log
count=$(grep -cv '^#' mass3d.csv)
/usr/bin/python3 -c "
n = $count - 1  # the header line
v = n * 0.05**3
assert abs(v - 1.875) <= 0.02 * 1.875, (n, v)
print(f'3D fill: {n} particles, {v:.5f} m^3 against 1.875')" || { echo "FAIL: fill_between_surfaces.py 3D volume"; cat fill3d.log; exit 1; }
cat > mass3d.yaml <<EOF
grid: {lower: [-0.5, -0.5, -0.5], upper: [4.5, 2.5, 2.0], cell_size: 0.1}
time: {end: 0.01, step: 0.01}
output: {enabled: false}
gravity: [0, 0, -9.81]
materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]
bodies: [{name: slide, material: m, particles: mass3d.csv}]
obstacles: [{name: ground, type: terrain, file: lower.asc, friction: 0.5}]
EOF
"$talus" check mass3d.yaml > check3d.log 2>&1 || { echo "FAIL: talus check of the 3D particle file"; cat check3d.log; exit 1; }

# A non-physical value: exit code 2, the key and line named, no output directory.
sed -e 's/poisson_ratio: 0.3/poisson_ratio: 0.7/' -e "s#directory: .*#directory: $work/bad_out#" \
  "$repo/inputs/elastic_column.yaml" > bad.yaml
set +e
"$talus" run bad.yaml > bad.log 2>&1
code=$?
set -e
[ "$code" -eq 2 ] || { echo "FAIL: exit code $code for a bad case (want 2)"; cat bad.log; exit 1; }
grep -q "bad.yaml:[0-9]*: materials\[0\].poisson_ratio = 0.7" bad.log || { echo "FAIL: message"; cat bad.log; exit 1; }
[ ! -e "$work/bad_out" ] || { echo "FAIL: a bad case wrote output"; exit 1; }

# A bad value of talus's own PETSc option: exit 2, named, no output.
sed -e "s#directory: .*#directory: $work/bad_option_out#" "$repo/inputs/elastic_column.yaml" > bad_option.yaml
for bad in "refactor_iterations 3x" "stagnation_iterations -1" "direct_fallback_limit 1e9" "ilu_fill_limit 2e4"; do
  set -- $bad
  set +e
  "$talus" run bad_option.yaml -talus_$1 "$2" > bad_option.log 2>&1
  code=$?
  set -e
  [ "$code" -eq 2 ] || { echo "FAIL: exit code $code for -talus_$1 $2 (want 2)"; cat bad_option.log; exit 1; }
  grep -q -- "talus_$1: expected an integer in \[0, 1000000\], got '$2'" bad_option.log ||
    { echo "FAIL: message for -talus_$1 $2"; cat bad_option.log; exit 1; }
  [ ! -e "$work/bad_option_out" ] || { echo "FAIL: a bad option wrote output"; exit 1; }
done
# The 2D fill: ILU(1) up to -talus_ilu_fill_limit unknowns (the column has
# about 500), ILU(0) above it (docs/solver.md#incomplete-factors-the-default-on-one-rank).
sed -e "s#directory: .*#directory: $work/fill_out#" -e "s#end: .*#end: 0.01#" "$repo/inputs/elastic_column.yaml" > fill.yaml
for limit in 20000:1 100:0; do
  "$talus" run fill.yaml --overwrite -talus_snes_view -talus_ilu_fill_limit "${limit%%:*}" > fill.log 2>&1 ||
    { echo "FAIL: run with -talus_ilu_fill_limit ${limit%%:*}"; cat fill.log; exit 1; }
  grep -q "^ *${limit##*:} levels\{0,1\} of fill" fill.log ||
    { echo "FAIL: -talus_ilu_fill_limit ${limit%%:*} should give ILU(${limit##*:})"; grep "of fill" fill.log; exit 1; }
done
# A case "file" that is a device would be read without end.
set +e
"$talus" check /dev/zero > zero.log 2>&1
code=$?
set -e
[ "$code" -eq 2 ] && grep -q "talus: error: /dev/zero: is not a regular file, not a case file" zero.log ||
  { echo "FAIL: /dev/zero as a case file: exit $code"; cat zero.log; exit 1; }

# refused ARGS MESSAGE: `talus run bad_option.yaml ARGS` exits with 2, prints
# "talus: error: MESSAGE", no PETSc trace, and writes no output.
refused() {
  set +e
  "$talus" run bad_option.yaml $1 > bad_option.log 2>&1
  local code=$?
  set -e
  [ "$code" -eq 2 ] || { echo "FAIL: exit code $code for '$1' (want 2)"; cat bad_option.log; exit 1; }
  grep -qF -- "talus: error: $2" bad_option.log || { echo "FAIL: message for '$1'"; cat bad_option.log; exit 1; }
  ! grep -q "PETSC ERROR" bad_option.log || { echo "FAIL: a PETSc trace for '$1'"; cat bad_option.log; exit 1; }
  [ ! -e "$work/bad_option_out" ] || { echo "FAIL: '$1' wrote output"; exit 1; }
}

# PETSc options with values this PETSc cannot use: exit 2 before anything is written.
refused "-talus_ksp_type nonsense" "PETSc option -talus_ksp_type nonsense: not a Krylov method"
refused "-talus_snes_rtol nan" "PETSc option -talus_snes_rtol nan: expected a finite number >= 0"
refused "-talus_snes_linesearch_minlambda nan" "PETSc option -talus_snes_linesearch_minlambda nan: expected a finite number"
refused "-talus_pc_factor_zeropivot inf" "PETSc option -talus_pc_factor_zeropivot inf: expected a finite number"
refused "-talus_pc_type nothing" "PETSc option -talus_pc_type nothing: not a preconditioner"
refused "-talus_snes_linesearch_order 1" "PETSc option -talus_snes_linesearch_order 1: expected 2 (quadratic) or 3 (cubic)"
refused "-talus_snes_linesearch_order cubic" "PETSc option -talus_snes_linesearch_order cubic: expected 2 (quadratic) or 3 (cubic)"

# A misspelled solver option is refused before anything is written: no
# configuration of the solver reads it (a throwaway one is configured below
# and above the direct limit). So is a value PETSc itself refuses, named.
refused "-talus_snes_monitr -talus_snes_converged_reason" \
  "PETSc option -talus_snes_monitr: read by no solver configuration of talus"
refused "-talus_ksp_monitr -talus_snes_monitr" "PETSc options -talus_ksp_monitr, -talus_snes_monitr: read by no"
refused "-talus_snes_monitor -talus_ksp_norm_type bogus" \
  "PETSc option -talus_ksp_norm_type bogus: PETSc does not accept it (Unknown option bogus"
# Debian's SuperLU has no MC64: its incomplete LU would abort the process
# when it permutes rows (talus then sets NOROWPERM, and refuses MC64 by name);
# its own options are read when it factors, and are no misspelling.
refused "-talus_pc_factor_mat_solver_type superlu -talus_mat_superlu_rowperm LargeDiag_MC64" \
  "PETSc option -talus_mat_superlu_rowperm: 'LargeDiag_MC64' needs MC64"
"$talus" check bad_option.yaml -talus_pc_factor_mat_solver_type superlu -talus_mat_superlu_ilu_droptol 1e-4 > good.log 2>&1 ||
  { echo "FAIL: SuperLU's incomplete LU options refused"; cat good.log; exit 1; }
"$talus" check bad_option.yaml -talus_snes_monitor -talus_pc_type gamg -talus_pc_gamg_threshold 0.01 \
  -talus_mat_type aij -talus_newton_predictor gravity > good.log 2>&1 ||
  { echo "FAIL: valid solver options refused"; cat good.log; exit 1; }
"$talus" check bad_option.yaml -talus_snes_type ngmres -talus_npc_ksp_rtol 1e-3 -talus_npc_pc_type ilu > good.log 2>&1 ||
  { echo "FAIL: valid nonlinear-preconditioner options refused"; cat good.log; exit 1; }
# Values PETSc checks only when it sets up or solves: the throwaway solver
# solves a small block system with each configuration the case can use, so
# they are refused here too, named, instead of stopping the run at its first
# step. Types that need what talus does not give them (a DM, a user's solve)
# or that it does not assemble are refused by name, before PETSc sees them
# (-talus_snes_type aspin and -talus_mat_type dense crashed the process).
refused "-talus_pc_factor_fill 0" "PETSc option -talus_pc_factor_fill 0: PETSc does not accept it"
refused "-talus_ksp_type fgmres -talus_ksp_pc_side left" "PETSc options: PETSc does not accept them together"
refused "-talus_pc_type bddc" "PETSc option -talus_pc_type bddc: PETSc does not accept it (PCBDDC preconditioner requires matrix of type MATIS)"
refused "-talus_pc_type gamg -talus_mat_type baij" "PETSc options: PETSc does not accept them together (No method creategraph"
refused "-talus_snes_type aspin" "PETSc option -talus_snes_type aspin: not a nonlinear solver talus can drive"
refused "-talus_snes_type fas" "PETSc option -talus_snes_type fas: not a nonlinear solver talus can drive"
refused "-talus_ksp_type pipelcg" "PETSc option -talus_ksp_type pipelcg: PETSc's pipelined CG loops without end"
refused "-talus_mat_type dense" "PETSc option -talus_mat_type dense: not a matrix type talus assembles (aij, baij)"
refused "-talus_snes_mf_operator" "PETSc option -talus_snes_mf_operator : talus's Jacobian is exact"
# BAIJ with the default incomplete LU is fine: the configuration above the
# direct limit (GAMG, which refuses BAIJ) cannot occur in this case.
"$talus" check bad_option.yaml -talus_mat_type baij > good.log 2>&1 ||
  { echo "FAIL: -talus_mat_type baij refused below the direct limit"; cat good.log; exit 1; }
# The same from the case file's solver.petsc_options: the file line is
# named. And a command-line option that the case file also sets is checked
# as well (it wins; before 2026-11-27 asking whether it was given marked it
# used, and it escaped the checks and stopped the first step).
grep -q "^solver:" bad_option.yaml && { echo "FAIL: bad_option.yaml has a solver section"; exit 1; }
cp bad_option.yaml file_option.yaml
printf 'solver:\n  petsc_options:\n    pc_factor_fill: 0\n' >> file_option.yaml
line=$(grep -n "pc_factor_fill" file_option.yaml | cut -d: -f1)
set +e
"$talus" run file_option.yaml > file_option.log 2>&1; code=$?
set -e
[ "$code" -eq 2 ] || { echo "FAIL: exit code $code for a case file's pc_factor_fill 0 (want 2)"; cat file_option.log; exit 1; }
grep -qF "talus: error: file_option.yaml:$line: solver.petsc_options.pc_factor_fill = 0: PETSc option -talus_pc_factor_fill 0: PETSc does not accept it" file_option.log ||
  { echo "FAIL: message for a case file's pc_factor_fill 0"; cat file_option.log; exit 1; }
sed -i 's/pc_factor_fill: 0/pc_factor_fill: 2/' file_option.yaml
set +e
"$talus" run file_option.yaml -talus_pc_factor_fill -1 > file_option.log 2>&1; code=$?
set -e
[ "$code" -eq 2 ] || { echo "FAIL: exit code $code for -talus_pc_factor_fill -1 over the case file's (want 2)"; cat file_option.log; exit 1; }
grep -qF "talus: error: PETSc option -talus_pc_factor_fill -1: PETSc does not accept it" file_option.log ||
  { echo "FAIL: message for -talus_pc_factor_fill -1 over the case file's"; cat file_option.log; exit 1; }
! grep -q "PETSC ERROR" file_option.log || { echo "FAIL: a PETSc trace for -talus_pc_factor_fill -1"; exit 1; }
[ ! -e "$work/bad_option_out" ] || { echo "FAIL: a refused case-file option wrote output"; exit 1; }
# The rehearsal prints nothing of the user's monitors: the first line of
# the run is talus's own.
"$talus" run bad_option.yaml --overwrite --quiet -talus_snes_monitor -talus_ksp_converged_reason > monitor.log 2> monitor.err ||
  { echo "FAIL: run with monitors"; cat monitor.log monitor.err; exit 1; }
head -1 monitor.log | grep -q "^talus: " || { echo "FAIL: the rehearsal printed before the run"; head -3 monitor.log; exit 1; }
grep -q "SNES Function norm" monitor.log || { echo "FAIL: no monitor output from the run"; exit 1; }
rm -rf "$work/bad_option_out"
# With NGMRES the outer Newton has no linear solver: its -talus_pc_type is
# for another configuration (the inner Newton's is -talus_npc_pc_type).
refused "-talus_snes_type ngmres -talus_pc_type ilu" "PETSc option -talus_pc_type: read by no solver configuration"
# An option read only when a preconditioner is set up (a block solver's
# sub-PC) is judged after the first step: a warning, since on one rank the
# default ILU has no blocks to read it, and a correct one is not named.
sed -e "s#directory: .*#directory: $work/unused_out#" -e "s#  end: .*#  end: 0.01#" "$repo/inputs/elastic_column.yaml" > unused.yaml
"$talus" run unused.yaml -talus_sub_pc_type lu -talus_snes_converged_reason > unused.log 2> unused.err
grep -q "talus: warning: PETSc options never read by the solver (misspelled, or for another solver configuration): -talus_sub_pc_type$" unused.err ||
  { echo "FAIL: no warning for -talus_sub_pc_type"; cat unused.err; exit 1; }

# 3D defaults to the Jacobian as an operator (docs/solver.md#the-jacobian-as-an-operator)
# preconditioned by point-block Jacobi (docs/solver.md#point-block-jacobi):
# no matrix at all, one block diagonal per Newton iteration, no factors.
# With ILU(0) the operator assembles matrices only for the factors;
# -talus_jacobian matrix assembles one per Newton iteration, with the same
# Newton iterations (the same iterates up to round-off). Steps that a P-wave
# crosses in 30 cells or more take ILU(0) by default (58 cells at h = 0.05 s).
sed -e "s#directory: .*#directory: $work/operator_out#" -e "s#  end: .*#  end: 0.1#" "$repo/inputs/rock_block_polyhedron_3d.yaml" > operator.yaml
sed -e "s#  step: .*#  step: 0.05#" operator.yaml > large_step.yaml
"$talus" run operator.yaml --quiet > default.log 2>&1 || { echo "FAIL: 3D default run"; cat default.log; exit 1; }
"$talus" run operator.yaml --quiet --overwrite -talus_pc_type ilu > operator.log 2>&1 || { echo "FAIL: 3D operator run"; cat operator.log; exit 1; }
"$talus" run operator.yaml --quiet --overwrite -talus_pc_type ilu -talus_jacobian matrix > matrix.log 2>&1 || { echo "FAIL: 3D matrix run"; cat matrix.log; exit 1; }
"$talus" run large_step.yaml --quiet --overwrite > large_step.log 2>&1 || { echo "FAIL: 3D large-step run"; cat large_step.log; exit 1; }
/usr/bin/python3 - default.log operator.log matrix.log large_step.log <<'PY' || exit 1
import json, sys
default, op, mat, large = (json.loads(open(f).read().split("talus-summary:", 1)[1].splitlines()[0]) for f in sys.argv[1:5])
ok = (default["jacobian_matrices"] == 0 and default["factorizations"] == 0
      and default["block_diagonals"] == default["newton_iterations"] > 0
      and op["jacobian_matrices"] < op["newton_iterations"] and op["jacobian_matrices"] == op["factorizations"]
      and op["block_diagonals"] == 0
      and mat["jacobian_matrices"] == mat["newton_iterations"] and op["newton_iterations"] == mat["newton_iterations"]
      and large["block_diagonals"] == 0 and large["factorizations"] > 0)
print(f"3D default: {default['newton_iterations']} Newton, {default['block_diagonals']} block diagonals, "
      f"{default['jacobian_matrices']} matrices; ILU(0) on the operator: {op['newton_iterations']} Newton, "
      f"{op['jacobian_matrices']} matrices; on the matrix: {mat['newton_iterations']} Newton, {mat['jacobian_matrices']} matrices; "
      f"at h = 0.05 s: {large['block_diagonals']} block diagonals, {large['factorizations']} factorizations")
sys.exit(0 if ok else "FAIL: the 3D default assembles matrices, or the operator more than its factors need")
PY

# Linear hats are accepted with a warning about the cell-crossing error (docs/grid.md).
sed -e "s#directory: .*#directory: $work/linear_out#" -e "s#shape_function: .*#shape_function: linear#" "$repo/inputs/elastic_column.yaml" > linear.yaml
"$talus" check linear.yaml > linear.log 2> linear.err || { echo "FAIL: a linear-hat case was refused"; cat linear.err; exit 1; }
grep -q "talus: warning: linear.yaml: grid.shape_function = linear has the cell-crossing error of classic MPM" linear.err ||
  { echo "FAIL: no cell-crossing warning"; cat linear.yaml linear.err; exit 1; }
# ... and without it with GIMP's domain quadrature.
sed -e "s#shape_function: linear#shape_function: linear\n  quadrature: domain#" linear.yaml > gimp.yaml
"$talus" check gimp.yaml > gimp.log 2> gimp.err || { echo "FAIL: a GIMP case was refused"; cat gimp.err; exit 1; }
grep -q "quadrature: domain" gimp.yaml && ! grep -q "cell-crossing" gimp.err ||
  { echo "FAIL: a GIMP case warned of the cell-crossing error"; cat gimp.yaml gimp.err; exit 1; }

# Arguments that are neither talus's nor PETSc options: exit 2, named, no output.
refused "--bogus" "command line: unknown option --bogus"
refused "-help" "command line: -help: talus --help prints the usage"
refused "other.yaml" "command line: unexpected argument 'other.yaml'"
refused "-talus_snes_monitor a b" "command line: unexpected argument 'b'"
refused "--progress-steps 1.5" "command line: --progress-steps 1.5: expected an integer in [0, 1e9]"
refused "--progress-seconds" "command line: --progress-seconds needs a value"
refused "--overwite" "command line: unknown option --overwite"
refused "-talus_newton_predictor lats" "PETSc option -talus_newton_predictor: expected one of last, gravity, got 'lats'"
refused "-talus_newton_tangent dual" "PETSc option -talus_newton_tangent: expected one of primal_dual, consistent, got 'dual'"

# A short run: .pvd, .pvtu and .vtu files, read back with VTK.
sed -e "s#directory: .*#directory: $work/out#" -e 's/end: 0.5/end: 0.02/' \
  "$repo/inputs/elastic_column.yaml" > run.yaml
"$talus" run run.yaml > run.log
/usr/bin/python3 - "$work/out" <<'PY'
import sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
out = sys.argv[1]
entries = ET.parse(out + "/particles.pvd").getroot().findall(".//DataSet")
times = [float(e.get("timestep")) for e in entries]
assert len(entries) == 2 and abs(times[-1] - 0.02) < 1e-12, times   # t = 0 and the end
first = vtk.vtkXMLPUnstructuredGridReader()
first.SetFileName(out + "/" + entries[0].get("file"))
first.Update()
g = first.GetOutput()
pd = g.GetPointData()
names = {pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())}
want = {"velocity", "displacement", "stress", "mean_stress", "deviatoric_stress", "mass", "volume",
        "material_id", "body_id", "particle_id"}
assert want <= names, names - want
# Initial state of inputs/elastic_column.yaml: 0.5 x 1 m body, 2x2 particles per 0.05 m cell.
n = g.GetNumberOfPoints()
assert n == 10 * 20 * 4, n
mass = vtk_to_numpy(pd.GetArray("mass"))
assert abs(mass.sum() - 2000.0 * 0.5 * 1.0) < 1e-9 * 1000, mass.sum()
assert np.all(vtk_to_numpy(pd.GetArray("stress")) == 0.0)
assert pd.GetArray("stress").GetNumberOfComponents() == 6
last = vtk.vtkXMLPUnstructuredGridReader()
last.SetFileName(out + "/" + entries[-1].get("file"))
last.Update()
v = vtk_to_numpy(last.GetOutput().GetPointData().GetArray("velocity"))
assert v.shape == (n, 3) and np.all(v[:, 2] == 0.0)
assert v[:, 1].mean() < 0.0      # the column starts to settle downwards
print("cli ok:", n, "particles,", len(entries), "outputs")
PY

# The same run on two ranks: one .vtu piece per rank, same particles in total.
sed -e "s#directory: .*#directory: $work/out2#" run.yaml > run2.yaml
mpiexec -n 2 "$talus" run run2.yaml > run2.log
/usr/bin/python3 - "$work/out2" <<'PY'
import sys, glob
import vtk
out = sys.argv[1]
assert len(glob.glob(out + "/particles_000001_*.vtu")) == 2, glob.glob(out + "/*")
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(out + "/particles_000001.pvtu")
r.Update()
assert r.GetOutput().GetNumberOfPoints() == 800, r.GetOutput().GetNumberOfPoints()
print("cli ok on 2 ranks")
PY

# SIGINT ends a run after the current step with a checkpoint (exit 130);
# --restart continues it to the end, on two ranks; h5dump reads the checkpoint.
sed -e "s#directory: .*#directory: $work/sig#" -e "s#end: .*#end: 1.0#" "$repo/inputs/column_collapse_psi0.yaml" > sig.yaml
"$talus" run sig.yaml > sig.log 2>&1 &
pid=$!
# Up to 60 s for the first step line: on a loaded machine (ctest -j2 beside
# other jobs) the start can take long, and a signal before the run installs
# its handler would kill it without a checkpoint.
for _ in $(seq 1 600); do grep -q "^step " sig.log 2>/dev/null && break; sleep 0.1; done
kill -INT $pid
set +e
wait $pid
code=$?
set -e
[ "$code" -eq 130 ] || { echo "SIGINT: expected exit 130, got $code"; cat sig.log; exit 1; }
checkpoint=$(sed -n 's/.*continue with --restart \(.*\)$/\1/p' sig.log)
[ -f "$checkpoint" ] || { echo "SIGINT: no checkpoint named in the log"; cat sig.log; exit 1; }
# The closing lines: why the run stopped, before the totals, with the status
# and the time reached: the checkpoint's time, 0 < t < 1; the steps this run
# made are the checkpoint's number (a run from t = 0: none before it).
/usr/bin/python3 - sig.log "$checkpoint" <<'PY'
import json, re, subprocess, sys
log = open(sys.argv[1]).read().splitlines()
stopped = [k for k, l in enumerate(log) if l.startswith("talus: stopped by signal 2 at t = ")]
done = [k for k, l in enumerate(log) if l.startswith("talus: done in ")]
assert len(stopped) == 1 and len(done) == 1 and stopped[0] < done[0], log[-6:]
summary = json.loads(next(l for l in log if l.startswith("talus-summary:")).split(":", 1)[1])
h5 = subprocess.run(["h5dump", "-a", "/run/time", sys.argv[2]], capture_output=True, text=True).stdout
t = float(re.search(r"\(0\): ([0-9.eE+-]+)", h5).group(1))
steps = int(re.search(r"checkpoint_(\d+)\.h5", sys.argv[2]).group(1))
assert summary["status"] == "interrupted" and summary["signal"] == 2, summary
assert abs(summary["time"] - t) <= 1e-12 * t and 0 < t < 1 and summary["end_time"] == 1, (summary["time"], t)
assert summary["steps"] == steps and summary["steps_before"] == 0 and summary["start_time"] == 0, (summary, steps)
assert f"interrupted by signal 2 at t = {summary['time']:.6g} s of 1 s; this run {steps} steps" in log[done[0]], log[done[0]]
print(f"cli ok: SIGINT at t = {t} after {steps} steps: 'stopped' before 'done', status interrupted")
PY
[ ! -e "$checkpoint.tmp" ] || { echo "SIGINT: temporary checkpoint left behind"; exit 1; }
h5dump -a /run/time "$checkpoint" | grep -q "DATA" || { echo "h5dump cannot read $checkpoint"; exit 1; }
# The same checkpoint with another gravity in the case: exit 2, the section
# named, nothing written (tests/test_checkpoint_damage.cpp has the rest).
sed -e "s#gravity: .*#gravity: [0.0, -1.62]#" sig.yaml > sig_moon.yaml
before=$(ls -l "$work/sig" | md5sum)
set +e
"$talus" run sig_moon.yaml --restart "$checkpoint" > moon.log 2>&1
code=$?
set -e
[ "$code" -eq 2 ] || { echo "restart with another case: exit $code (want 2)"; cat moon.log; exit 1; }
grep -q "the checkpoint belongs to another case: \`gravity\` differs" moon.log || { echo "restart with another case: message"; cat moon.log; exit 1; }
[ "$(ls -l "$work/sig" | md5sum)" = "$before" ] || { echo "restart with another case wrote output"; exit 1; }
# The serial checkpoint continues on two ranks: each keeps the particles in its cells.
mpiexec -n 2 "$talus" run sig.yaml --restart "$checkpoint" > restart.log
grep -q "restarting from $checkpoint" restart.log || { echo "restart not reported"; cat restart.log; exit 1; }
grep -q '^talus-summary: {"status": "completed", "signal": 0, ' restart.log && grep -q '"time": 1, "end_time": 1,' restart.log ||
  { echo "restart: no completed status at t = 1"; cat restart.log; exit 1; }
/usr/bin/python3 - "$work/sig" <<'PY'
import sys, xml.etree.ElementTree as ET
out = sys.argv[1]
times = [float(d.get("timestep")) for d in ET.parse(out + "/particles.pvd").getroot().iter("DataSet")]
# One series from t = 0 to the end: the outputs before the signal are kept.
assert times[0] == 0.0 and abs(times[-1] - 1.0) < 1e-9, times
assert all(b > a for a, b in zip(times, times[1:])), times
import vtk
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(out + "/" + list(ET.parse(out + "/particles.pvd").getroot().iter("DataSet"))[-1].get("file"))
r.Update()
assert r.GetOutput().GetNumberOfPoints() == 800, r.GetOutput().GetNumberOfPoints()
print("cli ok: interrupted and restarted on 2 ranks,", len(times), "outputs from 0 to", times[-1])
PY

# A known non-zero state read back from the VTK files: the elastic column
# seeded with a geostatic stress, output at t = 0 only (time.end = one step).
sed -e "s#directory: .*#directory: $work/geo#" -e "s#end: .*#end: 0.005#" \
    -e "s#particles_per_cell: 2#particles_per_cell: 2\n    initial_stress: geostatic#" \
    "$repo/inputs/elastic_column.yaml" > geo.yaml
"$talus" run geo.yaml > geo.log
/usr/bin/python3 - "$work/geo" <<'PY'
import sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
out = sys.argv[1]
first = list(ET.parse(out + "/particles.pvd").getroot().iter("DataSet"))[0]
assert float(first.get("timestep")) == 0.0
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(out + "/" + first.get("file"))
r.Update()
g = r.GetOutput()
pd = g.GetPointData()
a = lambda name: vtk_to_numpy(pd.GetArray(name))
x = vtk_to_numpy(g.GetPoints().GetData())
n = g.GetNumberOfPoints()
rho, grav, nu, H, d = 2000.0, 9.81, 0.3, 1.0, 0.025
sv = -rho * grav * (H - x[:, 1])            # lithostatic, at the particle centres
k0 = nu / (1 - nu)
s = a("stress")                              # ParaView order XX YY ZZ XY YZ XZ, Cauchy
scale = rho * grav * H
assert np.abs(s[:, 1] - sv).max() < 1e-9 * scale, np.abs(s[:, 1] - sv).max()
assert np.abs(s[:, 0] - k0 * sv).max() < 1e-9 * scale
assert np.abs(s[:, 2] - k0 * sv).max() < 1e-9 * scale
assert np.abs(s[:, 3:]).max() == 0.0
p = (1 + 2 * k0) * sv / 3
assert np.abs(a("mean_stress") - p).max() < 1e-9 * scale
q = np.abs(1 - k0) * np.abs(sv)              # von Mises of (k0, 1, k0) sigma_v
assert np.abs(a("deviatoric_stress") - q).max() < 1e-9 * scale
assert np.abs(a("volume") - d * d).max() < 1e-15
assert np.abs(a("mass") - rho * d * d).max() < 1e-12
assert np.all(a("cumulative_plastic_strain") == 0.0) and np.all(a("separation_strain") == 0.0)
assert np.all(a("velocity") == 0.0) and np.all(a("displacement") == 0.0)
assert np.all(a("material_id") == 0) and np.all(a("body_id") == 0)
assert sorted(a("particle_id").tolist()) == list(range(n))
print("cli ok: geostatic state read back,", n, "particles, sigma_v at the base", sv.min())
PY

# A case without obstacles writes none of the obstacle files.
for f in obstacle_forces.csv obstacles.pvd contacts.pvd; do
  [ ! -e "$work/out/$f" ] || { echo "FAIL: $f written for a case without obstacles"; exit 1; }
done

# Obstacles (docs/output.md#obstacles-and-contacts): a 0.4 x 0.2 m elastic
# block resting on a frictional floor (a half-plane at y = 0.1), a tilted
# half-plane, a moving box and a frictional face x_min that it never touches.
# obstacle_forces.csv: one row per step; at the end the floor carries the
# block's weight m g (m from the particle masses) to 1e-6; the contact points
# sum to the table's force; the .vtp geometry equals the closed-form clip to
# the grid box; the impulse, running total and window-force columns are the
# force x step, their sum and the window's mean (the window, 0.035 s, no
# multiple of the step, cuts steps in half). A restart continues the table
# (running totals and window included) and the two series exactly.
cat > obs.yaml <<EOF
grid: {lower: [0.0, 0.0], upper: [1.0, 0.6], cell_size: 0.05}
time: {end: 0.2, step: 0.01}
output: {directory: $work/obs, interval: 0.05, force_window: 0.035}
checkpoint: {interval: 7}
gravity: [0.0, -9.81]
materials:
  - {name: rock, model: linear_elastic, density: 2000.0, youngs_modulus: 2.0e7, poisson_ratio: 0.3}
bodies:
  - {name: block, material: rock, box: {lower: [0.3, 0.1], upper: [0.7, 0.3]}}
obstacles:
  - {name: floor, type: half_plane, point: [0.0, 0.1], normal: [0.0, 1.0], friction: 0.5}
  - {name: ramp, type: half_plane, point: [1.0, 0.2], normal: [-1.0, 1.0], friction: 0.25}
  - {name: wall, type: box, lower: [0.8, 0.45], upper: [1.2, 0.55], velocity: [-1.0, 0.0], friction: 0.3}
boundaries: {x_min: {condition: frictional, friction: 0.4}}
EOF
"$talus" run obs.yaml --progress-steps 1 > obs.log 2>&1 || { echo "FAIL: obstacle case"; cat obs.log; exit 1; }
cp -r obs obs_full
# Restart from step 7 in the same directory, after a crash that tore the
# table's last line: rows after t = 0.07 are dropped and written again, the
# torn line is gone; on the same rank count the run repeats bit for bit.
printf '0.21,-1569.6,0' >> obs/obstacle_forces.csv
cp obs/checkpoint_000007.h5 obs_checkpoint_000007.h5  # for the attributes, below: the restart rewrites it
"$talus" run obs.yaml --restart obs/checkpoint_000007.h5 > obs_restart.log 2>&1 ||
  { echo "FAIL: obstacle restart"; cat obs_restart.log; exit 1; }
for f in obstacle_forces.csv obstacles.pvd contacts.pvd particles.pvd; do
  cmp -s "obs/$f" "obs_full/$f" ||
    { echo "FAIL: $f after the restart differs from the run straight through"; diff "obs/$f" "obs_full/$f" | head; exit 1; }
done
# The same case on two ranks (contact pieces of ranks without contact points
# are empty but valid), and restarted on two ranks from the serial step 14.
sed -e "s#directory: $work/obs#directory: $work/obs2#" obs.yaml > obs2.yaml
mpiexec -n 2 "$talus" run obs2.yaml > obs2.log 2>&1 || { echo "FAIL: obstacle case on 2 ranks"; cat obs2.log; exit 1; }
mpiexec -n 2 "$talus" run obs.yaml --restart obs/checkpoint_000014.h5 > obs_restart2.log 2>&1 ||
  { echo "FAIL: obstacle restart on 2 ranks"; cat obs_restart2.log; exit 1; }
/usr/bin/python3 - "$work" <<'PY'
import csv, glob, json, os, sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work = sys.argv[1]

def table(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(v) for v in r] for r in rows[1:]])

def series(path):
    return [(float(d.get("timestep")), d.get("file")) for d in ET.parse(path).getroot().iter("DataSet")]

def read(reader, path):
    reader.SetFileName(path)
    reader.Update()
    return reader.GetOutput()

out = os.path.join(work, "obs_full")
header, table_all = table(os.path.join(out, "obstacle_forces.csv"))
names = ["floor", "ramp", "wall", "x_min"]
blocks = [("_f{}", "N/m"), ("_impulse_{}", "N s/m"), ("_cumulative_impulse_{}", "N s/m"), ("_window_f{}", "N/m")]
assert header == ["time [s]"] + [f"{n}{stem.format(a)} [{unit}]" for stem, unit in blocks for n in names for a in "xy"], header
assert table_all.shape == (20, 33), table_all.shape         # one row per step of 0.01 s, 4 blocks of 8
f = table_all[:, :9]                                        # time and the forces
assert np.abs(f[:, 0] - 0.01 * np.arange(1, 21)).max() < 1e-12 and np.all(np.diff(f[:, 0]) > 0), f[:, 0]

# The loads for wall design (docs/output.md): per step the impulse F h, with
# h read from the times (0 before the first row); its running total; the
# window force, here computed independently as the exact mean over (t - T, t]
# of the piecewise-constant step force: (J(t) - J(t - T)) / min(T, t), J the
# running impulse interpolated linearly within a step. Tolerances: round-off
# of a product (impulse), of a sum of 20 terms (total), of the difference of
# two totals of up to 0.2 s against a window of 0.035 s (window).
T = 0.035
t = table_all[:, 0]
h = np.diff(np.concatenate(([0.0], t)))
F, I, J, W = (table_all[:, 1 + 8 * b:9 + 8 * b] for b in range(4))
scale = np.abs(F).max()
impulse_error = np.abs(I - F * h[:, None]).max() / (scale * h.max())
total_error = np.abs(J - np.cumsum(I, axis=0)).max() / (scale * t[-1])
J0 = np.vstack([np.zeros(8), J])
t0 = np.concatenate(([0.0], t))
want = np.empty_like(W)
for c in range(8):
    want[:, c] = (J[:, c] - np.interp(np.maximum(t - T, 0.0), t0, J0[:, c])) / np.minimum(T, t)
window_error = np.abs(W - want).max() / scale
assert impulse_error <= 1e-14, impulse_error
assert total_error <= 1e-14, total_error
assert window_error <= 1e-12, window_error
# The window is not the step force (the block settles on the floor: its force
# varies from step to step), so the comparison above is not vacuous.
assert np.abs(W[:, 1] - F[:, 1]).max() > 1e-3 * scale, np.abs(W[:, 1] - F[:, 1]).max()
# The run summary's peak: the largest |window force| of each obstacle and its time.
def summary(log):
    line = [l for l in open(os.path.join(work, log)) if l.startswith("talus-summary: ")][-1]
    return json.loads(line.split(" ", 1)[1])
s = summary("obs.log")
assert s["force_window"] == T and list(s["peak_window_force"]) == names, s
for k, n in enumerate(names):
    magnitude = np.hypot(W[:, 2 * k], W[:, 2 * k + 1])
    peak = s["peak_window_force"][n]
    assert peak["force"] == magnitude.max(), (n, peak, magnitude.max())
    assert peak["time"] == (t[np.argmax(magnitude)] if magnitude.max() > 0 else 0.0), (n, peak)
assert s["peak_window_force"]["floor"]["force"] > 0 and s["peak_window_force"]["wall"]["force"] == 0.0
# The restart from step 7 reports the same peaks as the run straight through.
assert summary("obs_restart.log")["peak_window_force"] == s["peak_window_force"]
print(f"cli ok: loads, impulse = F h to {impulse_error:.1e}, total = cumulative sum to {total_error:.1e}, "
      f"window force = mean over {T} s to {window_error:.1e} (relative); floor peak "
      f"{s['peak_window_force']['floor']['force']:.6g} N/m at t = {s['peak_window_force']['floor']['time']}")

# The checkpoint of step 7 describes itself (docs/checkpoints.md) and holds
# the loads the table showed then: the running totals of row 7.
import h5py
with h5py.File(os.path.join(work, "obs_checkpoint_000007.h5"), "r") as c:
    run = c["run"].attrs
    assert run["case_file"].decode() == os.path.join(work, "obs.yaml") and run["case_name"].decode() == "obs", dict(run)
    assert c["particles/kirchhoff_stress"].attrs["component_order"].decode() == "xx yy zz yz xz xy"
    assert c["particles/position"].attrs["units"].decode() == "m" and c["particles/mass"].attrs["units"].decode() == "kg/m"
    o = c["obstacles"]
    assert o.attrs["names"].decode().split() == names and o.attrs["force_window"] == T
    assert o["impulse_total"].attrs["units"].decode() == "N s/m"
    assert np.array_equal(o["impulse_total"][:].ravel(), J[6]), (o["impulse_total"][:], J[6])

# The block's weight, from the particle masses of the last output.
particles = series(os.path.join(out, "particles.pvd"))
g = read(vtk.vtkXMLPUnstructuredGridReader(), os.path.join(out, particles[-1][1]))
m = vtk_to_numpy(g.GetPointData().GetArray("mass")).sum()
W = m * 9.81
assert abs(m - 2000.0 * 0.4 * 0.2) < 1e-9 * m, m
last = f[-1]
# The force on the floor is the weight, pointing down (the force ON the obstacle).
assert abs(last[2] + W) <= 1e-6 * W, (last[2], -W)
assert abs(last[1]) <= 1e-6 * W, last[1]
assert np.all(f[:, 3:] == 0.0), "force on an obstacle the block never touches"
assert np.all(f[:, 2] < 0.0)

# Contact points at the last output: they sum to the table's row, and each
# one's state agrees with its force (mu = 0.5, floor normal +y; the force on
# the body is r = -contact_force).
contacts = series(os.path.join(out, "contacts.pvd"))
assert [t for t, _ in contacts] == [t for t, _ in particles], (contacts, particles)
c = read(vtk.vtkXMLPUnstructuredGridReader(), os.path.join(out, contacts[-1][1]))
pd = c.GetPointData()
F = vtk_to_numpy(pd.GetArray("contact_force"))
ob = vtk_to_numpy(pd.GetArray("obstacle"))
state = vtk_to_numpy(pd.GetArray("contact_state"))
assert F.shape[1] == 3 and np.all(F[:, 2] == 0.0) and np.all(ob == 0) and len(ob) > 0, (F.shape, ob)
assert np.abs(F[:, :2].sum(axis=0) - last[1:3]).max() <= 1e-9 * W, (F.sum(axis=0), last[1:3])
rN, rT = -F[:, 1], np.abs(F[:, 0])
tol = 1e-6 * W
for s, n_, t_ in zip(state, rN, rT):
    assert s in (0, 1, 2), s
    if s == 0: assert t_ <= 0.5 * n_ + tol, (s, n_, t_)              # sticking: inside the cone
    if s == 1: assert n_ <= tol and t_ <= tol, (s, n_, t_)          # separating: no force
    if s == 2: assert abs(t_ - 0.5 * n_) <= tol, (s, n_, t_)        # sliding: on the cone
assert (state == 0).sum() > 0
first = read(vtk.vtkXMLPUnstructuredGridReader(), os.path.join(out, contacts[0][1]))
assert contacts[0][0] == 0.0 and first.GetNumberOfPoints() == 0    # no contact before the first step
assert first.GetPointData().GetArray("contact_state") is not None

# Obstacle geometry: at every output, each obstacle clipped to the grid box
# [0, 1] x [0, 0.6], the box moved by velocity * t.
def clip_line(p, n):
    """End points of the line (x - p) . n = 0 inside the grid box: its crossings of the box edges."""
    pts = []
    for axis, value in ((0, 0.0), (0, 1.0), (1, 0.0), (1, 0.6)):
        other = 1 - axis
        if n[other] == 0.0:
            continue
        x = np.zeros(2)
        x[axis] = value
        x[other] = p[other] - (value - p[axis]) * n[axis] / n[other]
        if -1e-12 <= x[0] <= 1 + 1e-12 and -1e-12 <= x[1] <= 0.6 + 1e-12 and not any(np.allclose(x, q) for q in pts):
            pts.append(x)
    return sorted(map(tuple, pts))

obstacles = series(os.path.join(out, "obstacles.pvd"))
assert [t for t, _ in obstacles] == [t for t, _ in particles] and len(obstacles) == 5, obstacles
for t, name in obstacles:
    assert name.endswith(".vtp")
    o = read(vtk.vtkXMLPolyDataReader(), os.path.join(out, name))
    P = vtk_to_numpy(o.GetPoints().GetData())
    assert np.all(P[:, 2] == 0.0)
    ids = vtk_to_numpy(o.GetCellData().GetArray("obstacle"))
    mu = vtk_to_numpy(o.GetCellData().GetArray("friction"))
    names = o.GetFieldData().GetAbstractArray("obstacle_names")
    assert [names.GetValue(k) for k in range(names.GetNumberOfValues())] == ["floor", "ramp", "wall", "x_min"]
    assert sorted(ids.tolist()) == [0, 1, 2, 3], ids
    cells = {}
    for k in range(o.GetNumberOfCells()):
        cell = o.GetCell(k)
        cells[ids[k]] = (o.GetCellType(k), np.array([P[cell.GetPointId(j), :2] for j in range(cell.GetNumberOfPoints())]))
        assert mu[k] == [0.5, 0.25, 0.3, 0.4][ids[k]], (ids[k], mu[k])
    for k, (p, n) in {0: ((0.0, 0.1), (0.0, 1.0)), 1: ((1.0, 0.2), (-1.0, 1.0)), 3: ((0.0, 0.0), (1.0, 0.0))}.items():
        kind, ends = cells[k]
        want = clip_line(np.array(p), np.array(n) / np.linalg.norm(n))
        assert kind == vtk.VTK_LINE and len(want) == 2, (k, kind, want)
        got = sorted(map(tuple, ends))
        assert np.abs(np.array(got) - np.array(want)).max() < 1e-12, (t, k, got, want)
    kind, corners = cells[2]
    lo, hi = np.array([max(0.8 - t, 0.0), 0.45]), np.array([min(1.2 - t, 1.0), 0.55])
    want = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    assert kind in (vtk.VTK_QUAD, vtk.VTK_POLYGON) and np.abs(corners - want).max() < 1e-12, (t, corners, want)
print(f"cli ok: obstacles, {len(f)} rows; floor force {-last[2]!r} N/m vs m g = {W!r} "
      f"(relative {abs(last[2] + W) / W:.1e}); {len(ob)} contact points; ramp end points "
      f"{clip_line(np.array((1.0, 0.2)), np.array((-1.0, 1.0)) / 2**0.5)}")

# Two ranks: one contact piece per rank, those at t = 0 empty and readable;
# the table equals the serial one to solver tolerance, also after a restart.
# (The block rests on the floor: the balance test bounds each step's
# unbalanced force by balance_tolerance W = 1e-8 W, the bound used here. The
# GMRES solves on reused LU factors differ between 1 rank (PETSc's LU) and 2
# (MUMPS); measured 1.6e-9 W. docs/solver.md#non-unique-steps: at 1e-10 the
# two runs select different contact states, 3.8e-3 W apart.)
worst = 0.0
for run in ("obs2", "obs"):
    header2, f2 = table(os.path.join(work, run, "obstacle_forces.csv"))
    assert header2 == header and f2.shape == table_all.shape and np.all(f2[:, 0] == f[:, 0]), (run, f2.shape)
    # All four blocks: forces and window forces scale with W, impulses and
    # their totals with W times a step or t <= 0.2 s, so W bounds them all.
    worst = max(worst, np.abs(f2[:, 1:] - table_all[:, 1:]).max() / W)
    assert worst <= 1e-8, (run, worst)
out2 = os.path.join(work, "obs2")
with open(os.path.join(out2, "contacts_000000.pvtu")) as fh:
    pieces = [e.get("Source") for e in ET.fromstring(fh.read()).iter("Piece")]
assert pieces == ["contacts_000000_0.vtu", "contacts_000000_1.vtu"], pieces
for piece in pieces:
    g = read(vtk.vtkXMLUnstructuredGridReader(), os.path.join(out2, piece))
    assert g.GetNumberOfPoints() == 0 and g.GetPointData().GetArray("contact_force") is not None, piece
c2 = read(vtk.vtkXMLPUnstructuredGridReader(), os.path.join(out2, "contacts_000004.pvtu"))
F2 = vtk_to_numpy(c2.GetPointData().GetArray("contact_force"))
assert len(F2) == len(F) and np.abs(F2.sum(axis=0) - F.sum(axis=0)).max() <= 1e-9 * W
assert not glob.glob(os.path.join(work, "obs*", ".staging*")) and not glob.glob(os.path.join(work, "obs*", "*.tmp"))
print(f"cli ok: obstacles on 2 ranks and restarted on 2 ranks, tables equal to {worst:.1e} W")
PY

# 3D obstacle geometry: a horizontal and a tilted half-plane (their sections
# of the grid box), a box cut by the grid box (6 outward faces) and a height
# map (2 triangles (00, 10, 11), (00, 11, 01) per cell; those reaching below
# z = 0 cut by the grid box).
printf '%s\n' 'ncols 5' 'nrows 3' 'xllcenter 0.0' 'yllcenter 0.0' 'cellsize 0.25' \
  '0.05 0.06 0.07 0.06 0.05' '0.04 0.05 0.08 0.05 0.04' '-0.05 0.04 0.06 0.03 0.02' > map.asc
cat > obs3.yaml <<EOF
grid: {lower: [0.0, 0.0, 0.0], upper: [1.0, 0.5, 0.5], cell_size: 0.1}
time: {end: 0.01, step: 0.01}
output: {directory: $work/obs3}
gravity: [0.0, 0.0, -9.81]
materials:
  - {name: rock, model: linear_elastic, density: 2000.0, youngs_modulus: 2.0e7, poisson_ratio: 0.3}
bodies:
  - {name: block, material: rock, box: {lower: [0.1, 0.1, 0.15], upper: [0.3, 0.3, 0.3]}, particles_per_cell: 1}
obstacles:
  - {name: floor, type: half_plane, point: [0.0, 0.0, 0.1], normal: [0.0, 0.0, 1.0], friction: 0.5}
  - {name: tilted, type: half_plane, point: [1.0, 0.0, 0.3], normal: [-1.0, 0.0, 1.0], friction: 0.2}
  - {name: wall, type: box, lower: [0.8, 0.1, -0.2], upper: [1.3, 0.4, 0.2], friction: 0.3}
  - {name: ground, type: terrain, file: map.asc, friction: 0.6}
EOF
"$talus" run obs3.yaml > obs3.log 2>&1 || { echo "FAIL: 3D obstacle case"; cat obs3.log; exit 1; }
head -1 "$work/obs3/obstacle_forces.csv" | cut -d, -f1-13 | grep -qx \
  'time \[s\],floor_fx \[N\],floor_fy \[N\],floor_fz \[N\],tilted_fx \[N\],tilted_fy \[N\],tilted_fz \[N\],wall_fx \[N\],wall_fy \[N\],wall_fz \[N\],ground_fx \[N\],ground_fy \[N\],ground_fz \[N\]' ||
  { echo "FAIL: 3D obstacle_forces.csv header"; head -1 "$work/obs3/obstacle_forces.csv"; exit 1; }
for column in 'ground_impulse_z \[N s\]' 'floor_cumulative_impulse_x \[N s\]' 'ground_window_fz \[N\]'; do
  head -1 "$work/obs3/obstacle_forces.csv" | tr , '\n' | grep -qx "$column" ||
    { echo "FAIL: 3D obstacle_forces.csv has no column $column"; head -1 "$work/obs3/obstacle_forces.csv"; exit 1; }
done
/usr/bin/python3 - "$work/obs3" <<'PY'
import sys
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
r = vtk.vtkXMLPolyDataReader()
r.SetFileName(sys.argv[1] + "/obstacles_000000.vtp")
r.Update()
o = r.GetOutput()
P = vtk_to_numpy(o.GetPoints().GetData())
ids = vtk_to_numpy(o.GetCellData().GetArray("obstacle"))
cells = []
for k in range(o.GetNumberOfCells()):
    cell = o.GetCell(k)
    cells.append((ids[k], P[[cell.GetPointId(j) for j in range(cell.GetNumberOfPoints())]]))
lo, hi = np.zeros(3), np.array([1.0, 0.5, 0.5])
assert np.all(P >= lo) and np.all(P <= hi), "a point outside the grid box"

def normal(x):   # Newell's normal of a planar polygon: its orientation
    return sum(np.cross(x[i], x[(i + 1) % len(x)]) for i in range(len(x)))

def same_set(a, b):
    return len(a) == len(b) and all(np.abs(np.array(b) - p).max(axis=1).min() < 1e-12 for p in a)

def of(k):
    return [x for i, x in cells if i == k]

# Half-planes: the plane's section of the grid box, counter-clockwise about the outward normal.
for k, p, n, want in ((0, (0, 0, 0.1), (0, 0, 1), [(0, 0, .1), (1, 0, .1), (1, .5, .1), (0, .5, .1)]),
                      (1, (1, 0, 0.3), (-1, 0, 1), [(.7, 0, 0), (1, 0, .3), (1, .5, .3), (.7, .5, 0)])):
    (x,) = of(k)
    n = np.array(n, float) / np.linalg.norm(n)
    assert same_set(x, want), (k, x)
    assert np.abs((x - np.array(p)) @ n).max() < 1e-12
    assert np.allclose(normal(x) / np.linalg.norm(normal(x)), n), (k, normal(x))
# The box [0.8, 1.3] x [0.1, 0.4] x [-0.2, 0.2] cut to [0.8, 1] x [0.1, 0.4] x [0, 0.2]: 6 outward faces.
faces = of(2)
centre = np.array([0.9, 0.25, 0.1])
assert len(faces) == 6
for x in faces:
    assert len(x) == 4 and np.dot(normal(x), x.mean(axis=0) - centre) > 0
    assert np.all(np.isin(x[:, 0], [0.8, 1.0]) & np.isin(x[:, 1], [0.1, 0.4]) & np.isin(x[:, 2], [0.0, 0.2])), x
# The height map: 4 x 2 cells, x fastest, 2 triangles each; node (0, 0) (the
# file's last row, first column) lies below z = 0.
z = np.array([[-0.05, 0.04, 0.06, 0.03, 0.02], [0.04, 0.05, 0.08, 0.05, 0.04], [0.05, 0.06, 0.07, 0.06, 0.05]])
tri = of(3)
assert len(tri) == 16, len(tri)
k = 0
for j in range(2):
    for i in range(4):
        for t in (((0, 0), (1, 0), (1, 1)), ((0, 0), (1, 1), (0, 1))):
            want = np.array([[0.25 * (i + a), 0.25 * (j + b), z[j + b, i + a]] for a, b in t])
            x = tri[k]
            k += 1
            if np.all(want[:, 2] >= 0):
                assert x.shape == (3, 3) and np.abs(x - want).max() < 1e-12, (i, j, x, want)   # the triangle itself
            else:                                                          # cut at z = 0, in its plane
                n = np.cross(want[1] - want[0], want[2] - want[0])
                assert len(x) >= 3 and np.abs((x - want[0]) @ n).max() < 1e-12 and np.any(x[:, 2] == 0.0), x
            assert normal(x)[2] > 0                                        # facing up, out of the ground
print("cli ok: 3D obstacle geometry,", len(cells), "cells")
PY

# Grid output (output.grid, docs/output.md#grid-points): the obstacle case
# with the block sliding at 0.5 m/s, serial, restarted, and on two ranks.
# At every output the grid points carry the particles' mass (P2G partition of
# unity) and momentum (t = 0: APIC P2G; later: APIC G2P v_p = sum_i N_ip v_i,
# so sum_p m_p v_p = sum_i m_i v_i^{n+1}), both to round-off; the grid's
# contact forces are those of contacts.pvd. Cases without output.grid (all
# above) write no grid file.
sed -e "s#output: {directory: $work/obs, interval: 0.05, force_window: 0.035}#output: {directory: $work/grid, interval: 0.05, grid: true}#" \
  -e 's#upper: \[0.7, 0.3\]}}#upper: [0.7, 0.3]}, velocity: [0.5, 0.0]}#' obs.yaml > grid.yaml
grep -q 'grid: true' grid.yaml && grep -q 'velocity: \[0.5, 0.0\]' grid.yaml || { echo "FAIL: grid.yaml"; exit 1; }
"$talus" run grid.yaml > grid.log 2>&1 || { echo "FAIL: grid output case"; cat grid.log; exit 1; }
cp -r grid grid_full
"$talus" run grid.yaml --restart grid/checkpoint_000007.h5 > grid_restart.log 2>&1 ||
  { echo "FAIL: grid output restart"; cat grid_restart.log; exit 1; }
for f in grid.pvd grid_000004.pvtu grid_000004_0.vtu particles.pvd; do
  cmp -s "grid/$f" "grid_full/$f" || { echo "FAIL: $f after the restart differs from the run straight through"; exit 1; }
done
sed -e "s#directory: $work/grid#directory: $work/grid2#" grid.yaml > grid2.yaml
mpiexec -n 2 "$talus" run grid2.yaml > grid2.log 2>&1 || { echo "FAIL: grid output on 2 ranks"; cat grid2.log; exit 1; }
for d in out out2 obs obs2 obs3; do
  if ls "$work/$d" | grep -q '^grid'; then echo "FAIL: $d has grid files without output.grid"; exit 1; fi
done
/usr/bin/python3 - "$work" <<'PY'
import glob, os, sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work = sys.argv[1]
def series(path):
    return [(float(e.get("timestep")), e.get("file")) for e in ET.parse(path).getroot().iter("DataSet")]
def read(path):
    r = vtk.vtkXMLPUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()
worst_mass = worst_momentum = 0.0
for run, ranks in (("grid", 1), ("grid2", 2)):
    out = os.path.join(work, run)
    particles, grid, contacts = (series(os.path.join(out, n + ".pvd")) for n in ("particles", "grid", "contacts"))
    assert len(grid) == 5 and [t for t, _ in grid] == [t for t, _ in particles], (grid, particles)
    assert [f for _, f in grid] == [f.replace("particles", "grid") for _, f in particles], grid
    for k, ((t, pf), (_, gf), (_, cf)) in enumerate(zip(particles, grid, contacts)):
        with open(os.path.join(out, gf)) as fh:
            pieces = [e.get("Source") for e in ET.fromstring(fh.read()).iter("Piece")]
        assert pieces == [gf.replace(".pvtu", f"_{r}.vtu") for r in range(ranks)], pieces
        p, g, c = read(os.path.join(out, pf)), read(os.path.join(out, gf)), read(os.path.join(out, cf))
        pd, gd = p.GetPointData(), g.GetPointData()
        mp, vp = vtk_to_numpy(pd.GetArray("mass")), vtk_to_numpy(pd.GetArray("velocity"))
        mg, vg = vtk_to_numpy(gd.GetArray("mass")), vtk_to_numpy(gd.GetArray("velocity"))
        fg, active = vtk_to_numpy(gd.GetArray("contact_force")), vtk_to_numpy(gd.GetArray("active"))
        X = vtk_to_numpy(g.GetPoints().GetData())
        assert vg.shape == (len(mg), 3) and fg.shape == (len(mg), 3) and np.all(vg[:, 2] == 0) and np.all(X[:, 2] == 0)
        assert np.all(mg > 0) and set(np.unique(active)) <= {0, 1} and active.sum() > 0
        assert len(np.unique(X[:, :2], axis=0)) == len(X), "a grid point written twice"
        mass_error = abs(mg.sum() - mp.sum()) / mp.sum()
        scale = (mp[:, None] * np.abs(vp)).sum()
        momentum_error = np.abs((mg[:, None] * vg).sum(axis=0) - (mp[:, None] * vp).sum(axis=0)).max() / scale
        assert mass_error <= 1e-12, (run, t, mass_error)
        assert momentum_error <= 1e-12, (run, t, momentum_error, (mg[:, None] * vg).sum(axis=0), (mp[:, None] * vp).sum(axis=0))
        worst_mass, worst_momentum = max(worst_mass, mass_error), max(worst_momentum, momentum_error)
        fc = vtk_to_numpy(c.GetPointData().GetArray("contact_force"))
        touching = np.any(fg != 0, axis=1)
        assert touching.sum() <= len(fc) and np.abs(fg.sum(axis=0) - fc.sum(axis=0)).max() <= 1e-12 * max(1.0, np.abs(fc).sum())
        if k == 0:
            assert not touching.any()                      # t = 0: the P2G state, no contact yet
        else:
            assert touching.sum() > 0 and np.all(active[touching] == 1), (run, t)
    print(f"cli ok: grid output on {ranks} rank(s): {len(grid)} outputs, {len(mg)} grid points at t = {t}, "
          f"momentum x {(mg * vg[:, 0]).sum():.6g} N s/m")
print(f"cli ok: grid mass = particle mass to {worst_mass:.1e}, grid momentum = particle momentum to {worst_momentum:.1e} (relative)")
PY


# Output times land on step ends (docs/output.md#output-times): the elastic
# column with h = 0.0075 s and an output every 0.025 s to 0.1 s. Each
# interval takes 3 full steps and one shortened to 0.0025 s: 16 steps, the
# outputs at exactly k x 0.025 s, and the step after a shortened one is the
# full 0.0075 s again (the step controller keeps its step). The progress
# lines (not a terminal, a line every 3 steps, no time trigger) come at the
# first step, the multiples of 3, the outputs and the last step, with the
# figures of the state: v_max and the front (max x) of the particles of the
# last output, KE of energy.csv's last row.
sed -e "s#directory: .*#directory: $work/land#" -e 's/end: 0.5/end: 0.1/' -e 's/step: 0.005/step: 0.0075/' \
  -e 's/interval: 0.05/interval: 0.025/' "$repo/inputs/elastic_column.yaml" > land.yaml
"$talus" run land.yaml --progress-steps 3 --progress-seconds 0 > land.log 2>&1 || { echo "FAIL: land"; cat land.log; exit 1; }
/usr/bin/python3 - "$work/land" land.log <<'PY'
import csv, json, re, sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
out, log = sys.argv[1], open(sys.argv[2]).read()
entries = list(ET.parse(out + "/particles.pvd").getroot().iter("DataSet"))
times = [float(e.get("timestep")) for e in entries]
want = [0.025 * k for k in range(5)]
assert len(times) == 5 and all(abs(a - b) <= 1e-12 * max(b, 1e-300) for a, b in zip(times, want)), times
rows = list(csv.reader(open(out + "/energy.csv")))[1:]
t = np.array([float(r[0]) for r in rows])                      # t = 0, then every step
h = np.diff(t)
assert len(h) == 16, len(h)
assert np.abs(h - np.tile([0.0075, 0.0075, 0.0075, 0.0025], 4)).max() < 1e-12, h
summary = json.loads(log.split("talus-summary:", 1)[1].splitlines()[0])
assert summary["steps"] == 16 and summary["outputs"] == 5 and summary["status"] == "completed", summary
assert summary["time"] == 0.1 and summary["end_time"] == 0.1, summary
lines = [l for l in log.splitlines() if l.startswith("step ")]
steps = [int(l.split()[1]) for l in lines]
assert steps == [1, 3, 4, 6, 8, 9, 12, 15, 16], steps
field = lambda line, name: float(re.search(name + r" (\S+)", line).group(1))
for l in lines:
    assert re.search(r"elapsed \d\d:\d\d:\d\d  ETA (\d\d:\d\d:\d\d|--:--:--)  v_max \S+ m/s  KE \S+ J/m  front \S+ m", l), l
last = lines[-1]
assert last.endswith("[output]") and "ETA 00:00:00" in last, last
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(out + "/" + entries[-1].get("file"))
r.Update()
x = vtk_to_numpy(r.GetOutput().GetPoints().GetData())
v = vtk_to_numpy(r.GetOutput().GetPointData().GetArray("velocity"))
speed, front, kinetic = np.linalg.norm(v, axis=1).max(), x[:, 0].max(), float(rows[-1][1])
assert abs(field(last, "v_max") - speed) <= 1e-5 * speed, (last, speed)
assert abs(field(last, "front") - front) <= 1e-5 * front, (last, front)
assert abs(field(last, "KE") - kinetic) <= 1e-5 * kinetic, (last, kinetic)
print(f"cli ok: outputs at {times}, steps {h.round(6).tolist()[:4]}..., progress lines at steps {steps}; "
      f"v_max {speed:.6g} m/s, front {front:.6g} m, KE {kinetic:.6g} J/m")
PY
# No sliver step before an output: with h = 0.012 s and outputs every
# 0.025 s, a second full step would leave 0.001 s (under a quarter step), so
# the rest after the first step is split in two: 0.012, 0.0065, 0.0065 per
# interval (without the split: 0.012, 0.012, 0.001).
sed -e "s#directory: .*#directory: $work/land_split#" -e 's/end: 0.5/end: 0.05/' -e 's/step: 0.005/step: 0.012/' \
  -e 's/interval: 0.05/interval: 0.025/' "$repo/inputs/elastic_column.yaml" > land_split.yaml
"$talus" run land_split.yaml --quiet > land_split.log 2>&1 || { echo "FAIL: land_split"; cat land_split.log; exit 1; }
/usr/bin/python3 - "$work/land_split" <<'PY'
import csv, sys
import numpy as np
t = np.array([float(r[0]) for r in list(csv.reader(open(sys.argv[1] + "/energy.csv")))[1:]])
h = np.diff(t)
assert len(h) == 6 and np.abs(h - np.tile([0.012, 0.0065, 0.0065], 2)).max() < 1e-12, h
print(f"cli ok: no sliver step, steps {h.round(6).tolist()}")
PY
# The explicit integrator lands the same way: the reference column's step
# 1.4925e-4 s (time.cfl x its limit) and outputs every 1e-3 s to 3e-3 s:
# 1e-3 / 1.4925e-4 = 6.7, so 7 steps per output, 21 in all.
sed -e "s#directory: .*#directory: $work/land_explicit#" -e 's/end: 1.0/end: 0.003/' -e 's/interval: 0.05/interval: 0.001/' \
  "$repo/inputs/reference_column_explicit.yaml" > land_explicit.yaml
"$talus" run land_explicit.yaml --quiet > land_explicit.log 2>&1 || { echo "FAIL: land_explicit"; cat land_explicit.log; exit 1; }
/usr/bin/python3 - "$work/land_explicit" land_explicit.log <<'PY'
import json, sys, xml.etree.ElementTree as ET
out, log = sys.argv[1], open(sys.argv[2]).read()
times = [float(e.get("timestep")) for e in ET.parse(out + "/particles.pvd").getroot().iter("DataSet")]
assert len(times) == 4 and all(abs(t - 1e-3 * k) <= 1e-12 * 1e-3 * k for k, t in enumerate(times)), times
summary = json.loads(log.split("talus-summary:", 1)[1].splitlines()[0])
assert summary["steps"] == 21, summary["steps"]
print(f"cli ok: explicit outputs at {times} in {summary['steps']} steps")
PY
# --quiet: no progress line (nor a checkpoint note), the closing lines stay.
# The same directory again: refused without --overwrite (below), here with it.
"$talus" run land.yaml --quiet --overwrite > quiet.log 2>&1 || { echo "FAIL: --quiet"; cat quiet.log; exit 1; }
! grep -q "^step \|checkpoint land\|$(printf '\r')" quiet.log && grep -q '^talus: done in .*: completed at t = 0.1 s of 0.1 s; this run 16 steps' quiet.log &&
  grep -q '^talus-summary: {"status": "completed"' quiet.log || { echo "FAIL: --quiet output"; cat quiet.log; exit 1; }
# On a terminal (a pseudo-terminal from script(1)): the line is rewritten in
# place with carriage returns and ended before the closing lines; messages
# (a cut-back forced by -talus_snes_max_it 1 at the first step, whose Newton
# needs 2 iterations when held to U <= 1e-8 by -talus_balance_time_fraction 0;
# the checkpoint) take lines of their own, the progress line cleared first.
# The cut-back halves 0.0075 s: 17 steps.
if command -v script > /dev/null; then
  # (stty: wide enough that the line is not cut to the terminal's width)
  script -qec "stty cols 200; $talus run land.yaml --overwrite -talus_snes_max_it 1 -talus_balance_time_fraction 0" /dev/null > tty.log 2>&1 ||
    { echo "FAIL: tty run"; cat tty.log; exit 1; }
  /usr/bin/python3 - tty.log "$work/land" <<'PY'
import re, sys
text = open(sys.argv[1], newline="").read().replace("\r\n", "\n")
lines = text.split("\n")
updates = re.findall(r"\rstep (\d+)  t (\S+) s \((\d+)%\)  h \S+  elapsed \S+  ETA \S+  v_max \S+ m/s  KE \S+ J/m  front \S+ m", text)
assert updates and updates[0][0] == "1" and updates[-1][:3] == ("17", "0.1", "100"), updates
assert not any(l.startswith("step ") for l in lines), "a progress line of its own on a terminal"
assert "  Newton failed (DIVERGED_MAX_IT) at t = 0 with h = 0.0075; retrying with h = 0.00375" in lines, lines[:4]
# The checkpoint note after the last step: the drawn line cleared, the note, a new line.
assert f"\r\x1b[K  checkpoint {sys.argv[2]}/checkpoint_000017.h5\n" in text, [l for l in lines if "checkpoint" in l]
done = next(k for k, l in enumerate(lines) if l.startswith("talus: done in"))
assert "\x1b[K" not in lines[done] and "\r" not in lines[done], lines[done]
print(f"cli ok: on a terminal {len(updates)} in-place updates of one line, the cut-back and checkpoint on lines of their own")
PY
fi

# A failed run prints its closing lines too, with the status failed and the
# time reached: the column on a free floor falls out of the grid (exit 3).
# Its bottom row of 20 particles (y0 = 0.0125 m) falls freely, with
# y_n = y0 - g h^2 n (n + 1) / 2 (x^{n+1} = x^n + h v^{n+1}): below 0 first at
# n = 10 (55 x 2.45e-4 m > y0 > 45 x 2.45e-4 m), so the run fails in step 10,
# at t = 0.045 s after 9 steps and the t = 0 output.
sed -e "s#directory: .*#directory: $work/fall#" -e 's/end: 0.5/end: 0.1/' -e 's/y_min: fixed/y_min: free/' \
  "$repo/inputs/elastic_column.yaml" > fall.yaml
set +e
"$talus" run fall.yaml > fall.log 2> fall.err
code=$?
set -e
[ "$code" -eq 3 ] && grep -q "^talus: simulation failed: 20 particles left the grid through a free face at t = 0.045;" fall.err &&
  grep -q "^talus: done in .* s: failed at t = 0.045 s of 0.1 s; this run 9 steps, 0 cut-backs, .* 1 outputs" fall.log &&
  grep -q '^talus-summary: {"status": "failed", "signal": 0, .*"time": 0.045, "end_time": 0.1, "steps": 9,' fall.log ||
  { echo "FAIL: a failed run's closing lines: exit $code"; cat fall.log fall.err; exit 1; }

# Restart counts (RunSummary: this run's steps, and steps_before up to the
# checkpoint): the obstacle case restarted from step 7 in its directory made
# 13 steps, 7 + 13 = the 20 of the run straight through; its Newton
# iterations and those of steps 1 to 7 of that run (its progress lines, one
# per step) add up to the straight run's, as the restart repeats it bit for bit.
/usr/bin/python3 - obs.log obs_restart.log <<'PY'
import json, re, sys
def summary(path):
    text = open(path).read()
    return text, json.loads(text.split("talus-summary:", 1)[1].splitlines()[0])
full_log, full = summary(sys.argv[1])
_, restart = summary(sys.argv[2])
per_step = {int(m.group(1)): int(m.group(2)) for m in re.finditer(r"^step\s+(\d+)\s+t\s+\S+\s+h\s+\S+\s+newton\s+(\d+)", full_log, re.M)}
assert sorted(per_step) == list(range(1, 21)), sorted(per_step)
assert (full["steps"], full["steps_before"], restart["steps"], restart["steps_before"]) == (20, 0, 13, 7), (full, restart)
assert abs(restart["start_time"] - 0.07) < 1e-12 and restart["time"] == 0.2 and full["time"] == 0.2, restart
assert restart["cutbacks_before"] + restart["cutbacks"] == full["cutbacks"] == 0
assert sum(per_step[k] for k in range(1, 8)) + restart["newton_iterations"] == full["newton_iterations"], \
    (per_step, restart["newton_iterations"], full["newton_iterations"])
assert full["outputs"] == 5 and restart["outputs"] == 3    # t = 0.1, 0.15, 0.2 after the restart at 0.07
print(f"cli ok: restart counts: {restart['steps_before']} + {restart['steps']} steps = {full['steps']}, "
      f"Newton {sum(per_step[k] for k in range(1, 8))} + {restart['newton_iterations']} = {full['newton_iterations']}")
PY

# A restart into another directory (a branch, docs/checkpoints.md): from the
# copy obs_full of the straight run (its checkpoint names its directory
# relative to itself, so the copy works) into branch, to 0.3 s. The branch's
# .pvd files list only files that exist and open; the parent's outputs up to
# the checkpoint are hard links; its tables continue the parent's; the
# parent's directory is unchanged. A branch of the branch (on 2 ranks), and a
# checkpoint without its outputs, give series that open as well.
snapshot() { (cd "$1" && find . -type f -print0 | sort -z | xargs -0 md5sum); }
parent_before=$(snapshot obs_full)
sed -e "s#directory: $work/obs#directory: $work/branch#" -e 's/end: 0.2/end: 0.3/' obs.yaml > branch.yaml
"$talus" run branch.yaml --restart obs_full/checkpoint_000007.h5 > branch.log 2>&1 || { echo "FAIL: branch"; cat branch.log; exit 1; }
grep -q "branch of the run in obs_full: 10 files of its 2 outputs up to the checkpoint hard-linked, 3 copied" branch.log ||
  { echo "FAIL: branch note"; cat branch.log; exit 1; }
[ "$(snapshot obs_full)" = "$parent_before" ] || { echo "FAIL: the branch changed its parent's directory"; exit 1; }
sed -e "s#directory: $work/branch#directory: $work/branch2#" -e 's/end: 0.3/end: 0.25/' branch.yaml > branch2.yaml
mpiexec -n 2 "$talus" run branch2.yaml --restart branch/checkpoint_000014.h5 > branch2.log 2>&1 ||
  { echo "FAIL: branch of a branch"; cat branch2.log; exit 1; }
mkdir lonely && cp obs_full/checkpoint_000007.h5 lonely/
sed -e "s#directory: $work/branch#directory: $work/branch3#" branch.yaml > branch3.yaml
"$talus" run branch3.yaml --restart lonely/checkpoint_000007.h5 > branch3.log 2>&1 || { echo "FAIL: lonely"; cat branch3.log; exit 1; }
grep -q "2 of the 2 outputs the checkpoint lists are not in lonely (moved or removed?): the series lists the 0 that are" branch3.log ||
  { echo "FAIL: lonely note"; cat branch3.log; exit 1; }
/usr/bin/python3 - "$work" <<'PY'
import csv, os, sys, xml.etree.ElementTree as ET
import vtk
work = sys.argv[1]
def series(d, name):
    return [(float(e.get("timestep")), e.get("file")) for e in ET.parse(os.path.join(work, d, name + ".pvd")).getroot().iter("DataSet")]
def opened(path):
    reader = vtk.vtkXMLPolyDataReader() if path.endswith(".vtp") else vtk.vtkXMLPUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    return reader.GetOutput()
checked = 0
for d, times in (("branch", [0.05 * k for k in range(7)]), ("branch2", [0.05 * k for k in range(6)]),
                 ("branch3", [0.1, 0.15, 0.2, 0.25, 0.3])):
    for name in ("particles", "contacts", "obstacles"):
        entries = series(d, name)
        assert [round(t, 12) for t, _ in entries] == [round(t, 12) for t in times], (d, name, entries)
        for t, f in entries:
            path = os.path.join(work, d, f)
            assert os.path.isfile(path), path
            g = opened(path)
            assert g.GetNumberOfPoints() == 128 if name == "particles" else g is not None, (path, g.GetNumberOfPoints())
            checked += 1
# branch3 numbers its files after the checkpoint's two outputs: nothing is renumbered.
assert series("branch3", "particles")[0][1] == "particles_000002.pvtu"
# The parent's outputs are shared, not copied; the tables continue it: the
# branch repeats the straight run to 0.2 s, row for row.
for f in ("particles_000001.pvtu", "particles_000001_0.vtu", "contacts_000000_0.vtu", "obstacles_000001.vtp"):
    assert os.stat(os.path.join(work, "branch", f)).st_ino == os.stat(os.path.join(work, "obs_full", f)).st_ino, f
for table in ("obstacle_forces.csv", "energy.csv", "bodies.csv"):
    parent = list(csv.reader(open(os.path.join(work, "obs_full", table))))
    branch = list(csv.reader(open(os.path.join(work, "branch", table))))
    steps = 30 if table == "obstacle_forces.csv" else 31                # energy.csv and bodies.csv have a row for t = 0
    assert len(branch) == steps + 1 and branch[:len(parent)] == parent, (table, len(branch), len(parent))
print(f"cli ok: branches: {checked} files listed in their .pvd series, each opened; parent unchanged, outputs hard-linked")
PY

# Re-running into a directory that holds an older run (the obstacle case's
# 34 files: 3 checkpoints, 3 series of 5 outputs, 3 tables): refused with
# exit 2 naming the key, its line and the directory, and nothing written; with
# --overwrite the older run's files go (a file of the user's stays), so the
# directory holds exactly the new run's files. A branch into a used
# directory is refused the same way.
before=$(snapshot obs_full)
sed -e "s#directory: $work/obs#directory: $work/obs_full#" -e 's/end: 0.2/end: 0.1/' obs.yaml > again.yaml
set +e
"$talus" run again.yaml > again.log 2>&1
code=$?
set -e
[ "$code" -eq 2 ] && grep -q "talus: error: again.yaml:3: output.directory = $work/obs_full: holds the files of an older run: bodies.csv, checkpoint_000007.h5, checkpoint_000014.h5, checkpoint_000020.h5, ... (34 files)" again.log ||
  { echo "FAIL: re-run into a used directory: exit $code"; cat again.log; exit 1; }
[ "$(snapshot obs_full)" = "$before" ] || { echo "FAIL: a refused re-run wrote into the directory"; exit 1; }
set +e
"$talus" run branch.yaml --restart obs_full/checkpoint_000014.h5 > again_branch.log 2>&1
code=$?
set -e
[ "$code" -eq 2 ] && grep -q "output.directory = $work/branch: holds the files of an older run" again_branch.log ||
  { echo "FAIL: branch into a used directory: exit $code"; cat again_branch.log; exit 1; }
echo "keep me" > obs_full/notes.txt
"$talus" run again.yaml --overwrite > overwrite.log 2>&1 || { echo "FAIL: --overwrite"; cat overwrite.log; exit 1; }
/usr/bin/python3 - "$work/obs_full" <<'PY'
import os, sys, xml.etree.ElementTree as ET
out = sys.argv[1]
expected = {"notes.txt", "energy.csv", "obstacle_forces.csv", "bodies.csv", "checkpoint_000007.h5", "checkpoint_000010.h5"}
for name in ("particles", "contacts", "obstacles"):
    expected.add(name + ".pvd")
    for e in ET.parse(os.path.join(out, name + ".pvd")).getroot().iter("DataSet"):
        f = e.get("file")
        expected.add(f)
        if f.endswith(".pvtu"):
            expected.add(f.replace(".pvtu", "_0.vtu"))
found = set(os.listdir(out))
assert found == expected, ("stale:", sorted(found - expected), "missing:", sorted(expected - found))
assert len(open(os.path.join(out, "obstacle_forces.csv")).readlines()) == 11      # header + 10 steps to 0.1 s
assert open(os.path.join(out, "notes.txt")).read() == "keep me\n"
print(f"cli ok: --overwrite left {len(found)} files, all of the new run (3 outputs) and notes.txt")
PY
