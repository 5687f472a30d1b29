#!/usr/bin/env bash
# Installs ParaView (Debian 12's paraview 5.11) on a machine that builds talus,
# without breaking the build: the GUI, pvpython and pvbatch with ParaView's own
# Python modules, beside python3-vtk9 and libvtk9-dev.
#
# Why not `apt-get install paraview`: it also installs the recommended
# python3-paraview, which Conflicts: python3-vtk9 (both ship
# /usr/lib/python3/dist-packages/vtkmodules and vtk.py), so apt removes
# python3-vtk9 and libvtk9-dev (which depends on it) and talus no longer
# builds. This script instead
#   1. installs the package paraview (the GUI, pvbatch, ParaView's libraries)
#      with --no-install-recommends, which removes nothing, plus xvfb and xauth
#      (Debian's ParaView renders through GLX only: pvbatch needs an X server,
#      `xvfb-run -a` gives it one on a machine without a display);
#   2. unpacks python3-paraview of the same version with `dpkg -x` into a
#      private prefix, PREFIX (default /opt/talus-paraview), outside dpkg's
#      database, so that it conflicts with nothing;
#   3. makes PREFIX a relocated ParaView: symbolic links to every file of the
#      package paraview under /usr/lib and /usr/share, copies of
#      /usr/bin/paraview and /usr/bin/pvbatch3.X in PREFIX/usr/bin (pvpython
#      comes with python3-paraview). ParaView finds its Python modules from
#      where its libraries were loaded: vtkPythonInterpreter puts the first
#      <dir>/lib/python3/dist-packages holding vtkmodules, <dir> a parent of
#      the library directory, in front of sys.path (before PYTHONPATH). Run
#      from /usr/bin that is /usr/lib/python3/dist-packages, python3-vtk9's
#      VTK 9.1, and pvpython crashes; run from PREFIX/usr/bin (RUNPATH
#      $ORIGIN/../lib/<multiarch>) the libraries load through PREFIX's links
#      and it is PREFIX/usr/lib/python3/dist-packages, ParaView's own;
#   4. writes the commands PREFIX/bin/pvpython, pvbatch and paraview (they
#      check that the package paraview still has PREFIX's version, then run
#      the programs in PREFIX/usr/bin, pvpython and pvbatch with
#      --disable-xdisplay-test, see below) and links them into BINDIR
#      (default /usr/local/bin, before /usr/bin on the PATH) unless a foreign
#      file of that name is there;
#   5. checks the result: pvpython imports paraview.simple with PREFIX's
#      vtkmodules, pvbatch renders a picture under xvfb-run, and no package
#      was removed.
# Before installing it simulates the apt-get command and refuses if apt would
# remove any package. Idempotent: a second run finds everything in place and
# only checks it. After an upgrade of the package paraview, run it again.
#
#   bash scripts/install_paraview.sh [--prefix DIR] [--bindir DIR]
#   bash scripts/install_paraview.sh --uninstall [--prefix DIR] [--bindir DIR]
#
# --uninstall removes PREFIX and the links (not the package paraview: remove
# it with apt-get if you want). Run as root, or as a user with sudo.
# docs/output.md ("Installing ParaView") says what to install where.
set -euo pipefail

PROG=install_paraview
prefix=/opt/talus-paraview
bindir=/usr/local/bin
uninstall=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --prefix) prefix=${2:?--prefix needs a directory}; shift 2 ;;
    --bindir) bindir=${2:?--bindir needs a directory}; shift 2 ;;
    --uninstall) uninstall=1; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "$PROG: error: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ "$prefix" = /* && "$prefix" != / ]] || { echo "$PROG: error: --prefix must be an absolute path other than /" >&2; exit 2; }

commands=(pvpython pvbatch paraview)
marker="talus install_paraview.sh wrapper"   # in every wrapper: tells ours from foreign files

if [[ $(id -u) -eq 0 ]]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "$PROG: error: installing needs root, and sudo is not available: run this script as root." >&2
  exit 1
fi

ours() {  # ours PATH: PATH is one of our wrappers (or a link to one)
  [[ -e "$1" ]] && grep -qF "$marker" "$1" 2>/dev/null
}

if [[ $uninstall -eq 1 ]]; then
  for c in "${commands[@]}"; do
    if [[ -L "$bindir/$c" ]] && ours "$bindir/$c"; then
      "${as_root[@]}" rm -f "$bindir/$c"
      echo "$PROG: removed $bindir/$c"
    fi
  done
  if [[ -f "$prefix/TALUS_PARAVIEW" ]]; then
    "${as_root[@]}" rm -rf "$prefix"
    echo "$PROG: removed $prefix"
  fi
  echo "$PROG: the package paraview stays installed (apt-get remove paraview removes it)"
  exit 0
fi

command -v apt-get >/dev/null 2>&1 && command -v dpkg-query >/dev/null 2>&1 || {
  echo "$PROG: error: apt-get/dpkg not found; this script is for Debian 12 (on another system install ParaView from paraview.org, see docs/output.md)." >&2
  exit 1
}

status() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null || true; }
installed() { [[ "$(status "$1")" == "install ok installed" ]]; }

# python3-paraview installed by dpkg: Debian's own pvpython is there, and
# python3-vtk9 (so libvtk9-dev) cannot be. Say so rather than change anything.
if installed python3-paraview; then
  cat >&2 <<EOF
$PROG: error: the package python3-paraview is installed. It conflicts with
  python3-vtk9, which libvtk9-dev needs, so this machine cannot build talus as
  it is. To have both, replace it by this script's private copy:
      sudo apt-get remove python3-paraview      # keeps the package paraview
      bash scripts/install_dependencies.sh      # puts python3-vtk9 and libvtk9-dev back
      bash scripts/install_paraview.sh          # pvpython/pvbatch beside them
  (If you only view results on this machine and never build talus, keep
  python3-paraview and skip this script.)
EOF
  exit 1
fi

start=$(date +%s)
list_installed() { dpkg-query -W -f='${binary:Package} ${db:Status-Abbrev}\n' | awk '$2 == "ii" {print $1}' | sort; }
before=$(list_installed)
apt_packages=(paraview xvfb xauth)
missing=()
for p in "${apt_packages[@]}"; do installed "$p" || missing+=("$p"); done

if [[ ${#missing[@]} -gt 0 ]]; then
  echo "$PROG: installing ${missing[*]} (--no-install-recommends: without python3-paraview)"
  source "$(dirname "$0")/apt_install_safely.sh"
  apt_install_safely "${missing[@]}"
fi

version=$(dpkg-query -W -f='${Version}' paraview)
pybin=$(dpkg-query -L paraview | sed -n 's#^/usr/bin/\(pvbatch3\.[0-9]*\)$#\1#p' | head -n 1)
[[ -n "$pybin" ]] || { echo "$PROG: error: the package paraview $version has no /usr/bin/pvbatch3.X" >&2; exit 1; }
pyver=${pybin#pvbatch}   # the Python it embeds, e.g. 3.11

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
chmod 755 "$tmp"
if [[ -f "$prefix/TALUS_PARAVIEW" ]] && grep -qxF "paraview $version" "$prefix/TALUS_PARAVIEW"; then
  echo "$PROG: $prefix already holds ParaView $version"
else
  if [[ -e "$prefix" && ! -f "$prefix/TALUS_PARAVIEW" ]]; then
    echo "$PROG: error: $prefix exists and was not made by this script; choose another --prefix" >&2
    exit 1
  fi
  # python3-paraview of the same version (it Depends: paraview (= version)).
  if [[ $(id -u) -eq 0 ]] && id _apt >/dev/null 2>&1; then chown _apt "$tmp"; fi  # apt-get download's sandbox user
  (cd "$tmp" && apt-get download "python3-paraview=$version") || {
    echo "$PROG: error: cannot download python3-paraview=$version (run apt-get update?)" >&2
    exit 1
  }
  deb=$(ls "$tmp"/python3-paraview_*.deb)
  new="$prefix.new"
  echo "$PROG: unpacking $(basename "$deb") into $prefix (dpkg -x: not registered with dpkg)"
  "${as_root[@]}" rm -rf "$new"
  "${as_root[@]}" mkdir -p "$new/bin"
  "${as_root[@]}" dpkg -x "$deb" "$new"
  # The package paraview relocated into PREFIX: links to its files under
  # /usr/lib (libraries, plugins) and /usr/share (proxy XMLs, proj data),
  # copies of the programs (a program's $ORIGIN is its real location).
  dpkg-query -L paraview | grep -E '^/usr/(lib|share)/' | grep -vE '^/usr/share/(doc|man|lintian)/' > "$tmp/files"
  "${as_root[@]}" env new="$new" bash -c '
    while IFS= read -r f; do
      if [[ -d "$f" && ! -L "$f" ]]; then mkdir -p "$new$f"
      elif [[ ! -e "$new$f" ]]; then mkdir -p "$new${f%/*}" && ln -s "$f" "$new$f"
      fi
    done' < "$tmp/files"
  "${as_root[@]}" cp -p /usr/bin/paraview "/usr/bin/$pybin" "$new/usr/bin/"
  # Python's bytecode once, as root (as python3-paraview's postinst does).
  "${as_root[@]}" python3 -m compileall -q "$new/usr/lib/python3/dist-packages" >/dev/null 2>&1 || true

  echo "paraview $version" > "$tmp/TALUS_PARAVIEW"
  "${as_root[@]}" install -m 644 "$tmp/TALUS_PARAVIEW" "$new/TALUS_PARAVIEW"
  "${as_root[@]}" rm -rf "$prefix"
  "${as_root[@]}" mv "$new" "$prefix"
fi

# The commands (written on every run, so that a new version of this script
# updates them).
wrapper() {  # wrapper NAME PROGRAM [OPTION]: the text of PREFIX/bin/NAME
  cat <<EOF
#!/bin/sh
# $1: ParaView $version's $1, run from $prefix ($marker).
# $prefix is the package paraview relocated (links to its libraries) with
# python3-paraview unpacked in it, so that ParaView uses its own Python
# modules, not python3-vtk9's. Made by scripts/install_paraview.sh of talus.
installed=\$(dpkg-query -W -f='\${Version}' paraview 2>/dev/null || true)
if [ "\$installed" != '$version' ]; then
  echo "$1: $prefix holds ParaView $version but the package paraview is '\$installed': run scripts/install_paraview.sh again" >&2
  exit 1
fi
exec '$2' ${3:+$3 }"\$@"
EOF
}
# --disable-xdisplay-test: ParaView's X display test (the rendering
# capabilities, checked when a paraview.simple script creates its first view)
# aborts the program now and then under Xvfb ("bad X server connection": 21
# of 256 runs of a Sphere/Show/SaveScreenshot script, with or without MPI);
# with this option 0 of 210 (pvbatch and pvpython).
wrapper pvpython "$prefix/usr/bin/pvpython$pyver" --disable-xdisplay-test > "$tmp/pvpython"
wrapper pvbatch "$prefix/usr/bin/$pybin" --disable-xdisplay-test > "$tmp/pvbatch"
wrapper paraview "$prefix/usr/bin/paraview" > "$tmp/paraview"
for c in "${commands[@]}"; do
  "${as_root[@]}" install -m 755 "$tmp/$c" "$prefix/bin/$c"
done

# The commands on the PATH (links to the wrappers), unless something else has the name.
"${as_root[@]}" mkdir -p "$bindir"
for c in "${commands[@]}"; do
  if [[ -L "$bindir/$c" ]] && ours "$bindir/$c"; then
    "${as_root[@]}" ln -sfn "$prefix/bin/$c" "$bindir/$c"
  elif [[ -e "$bindir/$c" || -L "$bindir/$c" ]]; then
    echo "$PROG: warning: $bindir/$c exists and is not ours: left alone (use $prefix/bin/$c)" >&2
  else
    "${as_root[@]}" ln -s "$prefix/bin/$c" "$bindir/$c"
  fi
done

# Checks: ParaView's Python with ParaView's vtkmodules, a picture from pvbatch,
# no package removed.
check=$("$prefix/bin/pvpython" -c "
import vtkmodules
from paraview.simple import GetParaViewVersion
v = GetParaViewVersion()
print('%d.%d' % (v.major, v.minor), vtkmodules.__file__)" 2>&1) || {
  echo "$PROG: error: $prefix/bin/pvpython cannot import paraview.simple:" >&2
  echo "$check" | grep -vE '^ *[0-9]+ +0x' | tail -n 5 >&2
  exit 1
}
check=$(echo "$check" | tail -n 1)
case "$check" in
  *" $prefix/"*) ;;
  *) echo "$PROG: error: pvpython uses vtkmodules from outside $prefix: $check" >&2; exit 1 ;;
esac
shot=$(mktemp -d)
cat > "$shot/sphere.py" <<EOF
from paraview.simple import Sphere, Show, Render, SaveScreenshot
Show(Sphere())
Render()
SaveScreenshot("$shot/sphere.png", ImageResolution=[64, 48])
EOF
if ! out=$(cd "$shot" && xvfb-run -a "$prefix/bin/pvbatch" "$shot/sphere.py" 2>&1) || [[ ! -s "$shot/sphere.png" ]]; then
  echo "$PROG: error: pvbatch could not render a picture under xvfb-run:" >&2
  echo "$out" | grep -vE '^ *[0-9]+ +0x' | tail -n 5 >&2
  rm -rf "$shot"
  exit 1
fi
rm -rf "$shot"
lost=$(comm -23 <(echo "$before") <(list_installed))
[[ -z "$lost" ]] || { echo "$PROG: error: these packages are no longer installed: $(echo $lost)" >&2; exit 1; }

size=$(du -sm "$prefix" | cut -f1)
echo "$PROG: ParaView ${check%% *} ready in $(( $(date +%s) - start )) s: $prefix/bin/{pvpython,pvbatch,paraview}, linked from $bindir ($size MB in $prefix)"
echo "  a picture without a display: xvfb-run -a pvbatch SCRIPT.py"
