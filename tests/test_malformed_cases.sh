#!/usr/bin/env bash
# Malformed case files (tests/malformed/, docs/case_file.md#validation-errors):
# for each one, `talus check` and `talus run` must both stop with exit code 2,
# an error message on stderr that contains the file's `# expect:` text, no
# crash or PETSc error trace, and no file written in the working directory.
#
# usage: test_malformed_cases.sh TALUS_BINARY SOURCE_DIR
set -uo pipefail
talus=$1
repo=$2
dir="$repo/tests/malformed"
min_cases=25

shopt -s nullglob
files=("$dir"/*.yaml)
if [ "${#files[@]}" -lt "$min_cases" ]; then
  echo "FAIL: $dir holds ${#files[@]} case files, fewer than $min_cases"
  exit 1
fi

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# Text that must never appear: a crash, an uncaught exception, a failed
# assertion, a PETSc or HDF5 error trace, an internal error (exit code 1).
forbidden='Segmentation|terminate|Assertion|PETSC ERROR|HDF5-DIAG|internal error|Aborted|core dumped|Caught signal'

# A talus start costs about half a second of waiting (MPI start-up) and
# little CPU: the cases run a few at a time, each writing its report to
# $scratch/results/KEY, printed in order at the end.
jobs=${TALUS_MALFORMED_JOBS:-4}
mkdir -p "$scratch/results"
count=0

# check_case LABEL FILE EXPECTED [LAUNCHER...]: runs `check` and `run` on FILE
# in a fresh, empty working directory each; prints PASS/FAIL and the details.
check_case() {
  local label=$1 file=$2 expected=$3
  shift 3
  local launcher=("$@")
  local problems="" message="" shown=0
  for command in check run; do
    local work
    work=$(mktemp -d "$scratch/work.XXXXXX")
    local out="$work.stdout" err="$work.stderr"
    # Each start gets an Open MPI session directory of its own: Open MPI 4
    # creates and removes /tmp/ompi.<host>.<uid> for every singleton, and
    # starts that overlap race on it ("A call to mkdir was unable to create
    # the desired directory ... File exists", orte_init failed, exit 1).
    local session
    session=$(mktemp -d "$scratch/ompi.XXXXXX")
    (cd "$work" && OMPI_MCA_orte_tmpdir_base="$session" timeout 120 "${launcher[@]}" "$talus" "$command" "$file" \
      > "$out" 2> "$err")
    local code=$?
    local errors
    errors=$(grep '^talus: error: ' "$err")
    [ -z "$message" ] && message=$errors
    [ "$code" -eq 2 ] || problems+="; $command: exit code $code (want 2)"
    grep -qF -- "$expected" "$err" || problems+="; $command: stderr lacks '$expected'"
    if [ "${#launcher[@]}" -eq 0 ]; then
      # Serial: exactly one line, the error, and nothing on stdout.
      [ "$(wc -l < "$err")" -eq 1 ] || problems+="; $command: stderr is not one line"
      [ ! -s "$out" ] || problems+="; $command: wrote to stdout"
      ! grep -qE "$forbidden" "$out" "$err" || problems+="; $command: crash or error trace in the output"
    else
      # mpiexec adds its own report of the non-zero exit ("terminated normally").
      ! grep -qE "Segmentation|Assertion|PETSC ERROR|HDF5-DIAG|internal error|core dumped" "$out" "$err" ||
        problems+="; $command: crash or error trace in the output"
    fi
    local left
    left=$(cd "$work" && find . -mindepth 1 | head -5 | tr '\n' ' ')
    [ -z "$left" ] || problems+="; $command: left files in the working directory: $left"
    if [ -n "$problems" ] && [ "$shown" -eq 0 ]; then
      shown=1
      sed 's/^/      stdout: /' "$out" | head -20
      sed 's/^/      stderr: /' "$err" | head -20
    fi
    rm -rf "$work" "$out" "$err" "$session"
  done
  if [ -z "$problems" ]; then
    echo "PASS $label: ${message:-}"
  else
    echo "FAIL $label${problems}"
  fi
}

# start LABEL FILE EXPECTED [LAUNCHER...]: check_case in the background.
start() {
  count=$((count + 1))
  local key
  key=$(printf '%04d' "$count")
  while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n; done
  check_case "$@" > "$scratch/results/$key" 2>&1 &
}

for file in "${files[@]}"; do
  name=$(basename "$file")
  if [ ! -s "$file" ]; then
    # An empty file cannot carry a comment: its expectation is fixed here.
    expected="$name: the case file must be a YAML map"
  else
    expected=$(sed -n '1s/^# expect: //p' "$file")
    if [ -z "$expected" ]; then
      count=$((count + 1))
      echo "FAIL $name: the first line is not '# expect: <text>'" > "$scratch/results/$(printf '%04d' "$count")"
      continue
    fi
  fi
  start "$name" "$file" "$expected"
done

# Cases that are not files in tests/malformed/.
start "(missing file)" "$scratch/does_not_exist.yaml" "does_not_exist.yaml: cannot open the case file"
start "(a directory)" "$dir" "malformed: is a directory, not a case file"
if command -v mpiexec > /dev/null; then
  # On two ranks: the same exit code, one message, no output.
  start "19_poisson_ratio_half.yaml on 2 ranks" "$dir/19_poisson_ratio_half.yaml" \
    "19_poisson_ratio_half.yaml:18: materials[0].poisson_ratio = 0.5" mpiexec -n 2
fi

wait

cat "$scratch"/results/*
passed=$(cat "$scratch"/results/* | grep -c '^PASS ')
failed=$(cat "$scratch"/results/* | grep -c '^FAIL ')
total=$((passed + failed))
echo "malformed cases: $passed of $total passed, $failed failed"
[ "$total" -eq "$count" ] || { echo "FAIL: $((count - total)) cases gave no report"; exit 1; }
[ "$failed" -eq 0 ]
