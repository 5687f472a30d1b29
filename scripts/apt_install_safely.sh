# Sourced by install_dependencies.sh and install_paraview.sh (needs PROG and
# the as_root command array): install packages with --no-install-recommends
# only if apt would remove nothing. apt-get simulates first; a removal (for
# example libvtk9-dev, which python3-paraview's conflict with python3-vtk9
# would take away) stops with exit 1 before anything changes.
# usage: apt_install_safely PACKAGE...
apt_install_safely() {
  local simulation removals
  "${as_root[@]}" apt-get update
  simulation=$(apt-get install -s --no-install-recommends "$@" 2>&1) || {
    echo "$PROG: error: apt-get cannot install $*:" >&2
    echo "$simulation" | grep -E '^(E:|W:| )' >&2 || echo "$simulation" >&2
    exit 1
  }
  removals=$(echo "$simulation" | sed -n 's/^Remv \([^ ]*\).*/\1/p')
  if [[ -n "$removals" ]]; then
    echo "$PROG: error: installing $* would remove: $(echo $removals). Nothing changed." >&2
    echo "  (apt-get install -s --no-install-recommends $* shows why; remove or keep those" >&2
    echo "  packages yourself, then run this script again.)" >&2
    exit 1
  fi
  "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "$@"
}
