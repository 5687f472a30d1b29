#!/usr/bin/env bash
# scripts/install_dependencies.sh and scripts/install_paraview.sh never leave
# a machine that cannot build talus.
#  1. With stand-ins for dpkg-query, apt-get and sudo first on the
#     PATH (no root, no network, nothing installed or removed; the stand-ins
#     answer from a list of "installed" packages and log every apt-get call):
#     a. python3-paraview installed (what `apt-get install paraview` leaves,
#        python3-vtk9 and libvtk9-dev gone): both scripts exit 1 with a
#        message saying what to do, and call no apt-get install;
#     b. the simulation (apt-get install -s) removes a package: both scripts
#        exit 1 naming it, and call no apt-get install -y;
#     c. install_dependencies.sh with a package missing and a clean
#        simulation: apt-get update, the simulation, then apt-get install -y
#        --no-install-recommends of its list, which holds neither paraview nor
#        python3-paraview; exit 0;
#     d. everything installed: exit 0 without any apt-get call; --check lists
#        the missing packages (exit 1) or none (exit 0).
#  2. This machine (skipped without dpkg-query): install_dependencies.sh
#     --check finds the whole build set installed, and talus configures in a
#     fresh build directory (CMake finds PETSc, MPI, Eigen, yaml-cpp, HDF5,
#     VTK, Catch2). If scripts/install_paraview.sh was run, its pvpython uses
#     ParaView's own vtkmodules (tests/test_render_script.sh renders with its
#     pvbatch).
set -euo pipefail
repo=$1
deps="$repo/scripts/install_dependencies.sh"
paraview="$repo/scripts/install_paraview.sh"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

real_dpkg_query=$(command -v dpkg-query || true)

# --- 1. stand-ins ----------------------------------------------------------------
mkdir bin
cat > bin/dpkg-query <<'EOF'
#!/usr/bin/env bash
# dpkg-query -W -f=FORMAT [PACKAGE]: answers from $STUB_STATE (one installed package a line)
fmt=
for a in "$@"; do case "$a" in -f=*) fmt=${a#-f=} ;; -L) echo "stub dpkg-query: -L not expected" >&2; exit 2 ;; esac; done
pkg=${!#}
if [[ "$fmt" == *'${binary:Package}'* ]]; then   # list every installed package
  while read -r p; do echo "$p ii "; done < "$STUB_STATE"
  exit 0
fi
grep -qxF "$pkg" "$STUB_STATE" || { echo "dpkg-query: no packages found matching $pkg" >&2; exit 1; }
case "$fmt" in
  *Status*) printf 'install ok installed' ;;
  *Version*) printf '1.0-stub' ;;
esac
EOF
cat > bin/apt-get <<'EOF'
#!/usr/bin/env bash
# logs its arguments to $STUB_LOG; -s prints $STUB_SIMULATION; install -y marks the packages installed
echo "apt-get $*" >> "$STUB_LOG"
if [[ " $* " == *" -s "* ]]; then cat "$STUB_SIMULATION"; exit 0; fi
if [[ " $* " == *" install "* && " $* " == *" -y "* ]]; then
  for a in "$@"; do [[ "$a" == -* || "$a" == install ]] || echo "$a" >> "$STUB_STATE"; done
fi
exit 0
EOF
cat > bin/sudo <<'EOF'
#!/usr/bin/env bash
exec "$@"
EOF
chmod +x bin/*
for c in dpkg-query apt-get sudo; do   # the stand-ins, never the real programs
  [ "$(PATH="$work/bin:$PATH" command -v "$c")" = "$work/bin/$c" ] || { echo "FAIL: stand-in $c not first on the PATH"; exit 1; }
done
export STUB_STATE="$work/state" STUB_LOG="$work/apt.log" STUB_SIMULATION="$work/simulation"

stub() {  # stub name script args...: run a script with the stand-ins; rc, stdout+stderr in name.out
  local name=$1 script=$2
  shift 2
  : > "$STUB_LOG"
  set +e
  PATH="$work/bin:$PATH" bash "$script" "$@" > "$name.out" 2>&1
  rc=$?
  set -e
}
fail() { echo "FAIL: $*"; [ -f "$name.out" ] && cat "$name.out"; echo "apt-get calls:"; cat "$STUB_LOG"; exit 1; }
expect() {  # expect name rc text...: the last stub run exited rc and printed every text
  name=$1
  local want=$2
  shift 2
  [ "$rc" -eq "$want" ] || fail "$name: exit $rc, expected $want"
  for t in "$@"; do grep -qF -- "$t" "$name.out" || fail "$name: '$t' not in the output"; done
}
no_install() { ! grep -qE '^apt-get install( .*)? -y( |$)' "$STUB_LOG" || fail "$name: apt-get install -y called"; }

# The build set, as install_dependencies.sh --check lists it on an empty machine.
: > state
stub list "$deps" --check
expect list 1 "packages missing:"
build_set=$(sed -n 's/.* packages missing: //p' list.out)
n=$(echo $build_set | wc -w)
[ "$n" -ge 15 ] || fail "list: only $n packages: $build_set"
for p in libvtk9-dev python3-vtk9 petsc-dev xvfb; do echo " $build_set " | grep -qF " $p " || fail "list: no $p"; done
for p in paraview python3-paraview; do ! echo " $build_set " | grep -qF " $p " || fail "list: $p in the build set"; done
echo "build set: $n packages"

# a. python3-paraview installed, python3-vtk9 and libvtk9-dev removed by it
echo $build_set | tr ' ' '\n' | grep -vxE 'python3-vtk9|libvtk9-dev' > state
echo python3-paraview >> state
echo paraview >> state
stub deps_conflict "$deps"
expect deps_conflict 1 "python3-paraview is installed" "sudo apt-get remove python3-paraview" \
  "bash scripts/install_dependencies.sh" "bash scripts/install_paraview.sh" "Nothing changed"
no_install
[ ! -s "$STUB_LOG" ] || fail "deps_conflict: apt-get called"
stub deps_conflict_check "$deps" --check
expect deps_conflict_check 1 "2 of $n packages missing: libvtk9-dev python3-vtk9" "sudo apt-get remove python3-paraview"
stub paraview_conflict "$paraview" --prefix "$work/prefix" --bindir "$work/bindir"
expect paraview_conflict 1 "the package python3-paraview is installed" "sudo apt-get remove python3-paraview" \
  "bash scripts/install_dependencies.sh"
[ ! -s "$STUB_LOG" ] || fail "paraview_conflict: apt-get called"
echo "a. python3-paraview installed: both scripts stop (exit 1) and say what to do, no apt-get call"

# b. the simulation would remove a package
echo $build_set | tr ' ' '\n' | grep -vxF python3-yaml > state
printf 'NOTE: This is only a simulation!\nRemv libvtk9-dev [9.1.0]\nRemv python3-vtk9 [9.1.0]\nInst python3-yaml (6.0 Debian:12)\n' > simulation
stub deps_removal "$deps"
expect deps_removal 1 "would remove: libvtk9-dev python3-vtk9" "Nothing changed"
no_install
grep -q "install -s --no-install-recommends" "$STUB_LOG" || fail "deps_removal: no simulation"
echo $build_set | tr ' ' '\n' > state
printf 'Inst paraview (5.11 Debian:12)\nRemv python3-vtk9 [9.1.0]\n' > simulation
stub paraview_removal "$paraview" --prefix "$work/prefix" --bindir "$work/bindir"
expect paraview_removal 1 "would remove: python3-vtk9" "Nothing changed"
no_install
grep -q "install -s --no-install-recommends paraview" "$STUB_LOG" || fail "paraview_removal: no simulation"
[ ! -e "$work/prefix" ] && [ ! -e "$work/bindir" ] || fail "paraview_removal: files written"
echo "b. a simulation that removes packages: both scripts stop (exit 1) naming them, no apt-get install -y"

# c. one package missing, a clean simulation
echo $build_set | tr ' ' '\n' | grep -vxF python3-yaml > state
printf 'Inst python3-yaml (6.0 Debian:12)\nConf python3-yaml (6.0 Debian:12)\n' > simulation
stub deps_install "$deps"
expect deps_install 0 "installing 1 missing package(s): python3-yaml" "install_paraview.sh"
order=$(cut -d' ' -f2-3 "$STUB_LOG" | tr '\n' ',')
[ "$order" = "update,install -s,install -y," ] || fail "deps_install: apt-get calls $order"
install_line=$(grep -- "install -y" "$STUB_LOG")
[[ "$install_line" == "apt-get install -y --no-install-recommends "* ]] || fail "deps_install: $install_line"
for p in paraview python3-paraview; do ! echo "$install_line " | grep -qF " $p " || fail "deps_install: installs $p"; done
echo "c. one package missing: apt-get update, install -s, install -y --no-install-recommends (no paraview, no python3-paraview)"

# d. all there
echo $build_set | tr ' ' '\n' > state
stub deps_nothing "$deps"
expect deps_nothing 0 "all $n packages are already installed"
[ ! -s "$STUB_LOG" ] || fail "deps_nothing: apt-get called"
stub deps_check "$deps" --check
expect deps_check 0 "all $n packages are already installed"
echo "d. everything installed: nothing done; --check exit 0"

# --- 2. this machine ----------------------------------------------------------------
if [ -z "$real_dpkg_query" ]; then
  echo "install_scripts: part 2 SKIPPED: no dpkg-query (not Debian)"
  echo "install_scripts ok"
  exit 0
fi
bash "$deps" --check || { echo "FAIL: the build set is not installed on this machine (bash scripts/install_dependencies.sh)"; exit 1; }
if [ "$(dpkg-query -W -f='${Status}' python3-paraview 2>/dev/null || true)" = "install ok installed" ]; then
  echo "FAIL: python3-paraview installed beside the build set"; exit 1
fi
start=$(date +%s%N)
cmake -S "$repo" -B "$work/configure" -G Ninja -DCMAKE_BUILD_TYPE=Release > configure.log 2>&1 \
  || { echo "FAIL: talus does not configure"; tail -n 30 configure.log; exit 1; }
grep -q "Build files have been written" configure.log || { echo "FAIL: configure"; tail configure.log; exit 1; }
echo "this machine: build set installed, talus configures ($(( ($(date +%s%N) - start) / 1000000 )) ms)"
if [ -x /opt/talus-paraview/bin/pvpython ]; then
  out=$(/opt/talus-paraview/bin/pvpython -c '
import vtkmodules
from paraview.simple import GetParaViewVersion
print(vtkmodules.__file__)' 2>&1) || { echo "FAIL: /opt/talus-paraview/bin/pvpython"; echo "$out" | tail -n 5; exit 1; }
  case "$(echo "$out" | tail -n 1)" in
    /opt/talus-paraview/*) echo "this machine: /opt/talus-paraview/bin/pvpython uses $(echo "$out" | tail -n 1)" ;;
    *) echo "FAIL: /opt/talus-paraview/bin/pvpython uses $out"; exit 1 ;;
  esac
else
  echo "this machine: no /opt/talus-paraview (scripts/install_paraview.sh not run)"
fi
echo "install_scripts ok"
