#!/usr/bin/env bash
# A read-only file system under output.directory or checkpoint.directory
# (issue 14 item 7): `talus check` and `talus run` stop with exit 2 naming the
# key, the directory and the reason, before anything is written. The file
# system is a tmpfs mounted read-only; where mounting is not allowed (no
# CAP_SYS_ADMIN) the test says so and passes.
# usage: test_read_only.sh TALUS_BINARY SOURCE_DIR
set -u
talus=$(readlink -f "$1")
scratch=$(mktemp -d)
ro="$scratch/ro"
mkdir -p "$ro"
cleanup() { umount "$ro" 2>/dev/null; rm -rf "$scratch"; }
trap cleanup EXIT
if ! mount -t tmpfs -o ro,size=1m tmpfs "$ro" 2>/dev/null; then
  echo "SKIPPED: cannot mount a read-only tmpfs here (needs root with CAP_SYS_ADMIN)"
  exit 0
fi
if touch "$ro/probe" 2>/dev/null; then echo "FAIL: the mount is writable"; exit 1; fi
problems=0
case_file() {  # output directory, checkpoint directory
  cat > "$scratch/case.yaml" <<CASE
grid: {lower: [0.0, 0.0], upper: [1.0, 1.0], cell_size: 0.1}
time: {end: 0.02, step: 0.01}
output: {directory: $1}
checkpoint: {directory: $2}
gravity: [0.0, -9.81]
materials: [{name: soil, model: linear_elastic, density: 2000.0, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]
bodies: [{name: block, material: soil, box: {lower: [0.2, 0.0], upper: [0.6, 0.4]}}]
boundaries: {y_min: fixed}
CASE
}
expect() {  # label, key, expected text; then the command
  local label=$1 key=$2 text=$3
  shift 3
  local err rc
  err=$("$@" 2>&1 >/dev/null)
  rc=$?
  if [ $rc -ne 2 ]; then echo "FAIL $label: exit $rc, expected 2 ($err)"; problems=$((problems + 1)); return; fi
  if ! grep -qF -- "$key" <<<"$err" || ! grep -qF -- "$text" <<<"$err"; then
    echo "FAIL $label: message lacks '$key' or '$text': $err"; problems=$((problems + 1)); return
  fi
  echo "ok $label: $err"
}
cd "$scratch"
case_file "$ro/out" "$scratch/ck"
expect "check, output below a read-only mount" "output.directory = $ro/out" "Read-only file system" "$talus" check case.yaml
expect "run, output below a read-only mount" "output.directory = $ro/out" "Read-only file system" "$talus" run case.yaml
case_file "$ro" "$scratch/ck"
expect "run, output on the read-only mount itself" "output.directory = $ro" "Read-only file system" "$talus" run case.yaml
case_file "$scratch/out" "$ro/ck"
expect "run, checkpoints below a read-only mount" "checkpoint.directory = $ro/ck" "Read-only file system" "$talus" run case.yaml
# Nothing written: neither the writable output directory nor the checkpoints.
if [ -e "$scratch/out" ] || [ -e "$scratch/ck" ]; then
  echo "FAIL: a refused run wrote $(ls -d "$scratch"/out "$scratch"/ck 2>/dev/null)"; problems=$((problems + 1))
fi
exit $((problems > 0))
