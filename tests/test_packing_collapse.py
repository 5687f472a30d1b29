#!/usr/bin/env python3
"""The packing correction on column collapses (issue 13 item 3,
docs/transfers.md#packing).

1. The a = 8 column of scripts/study_column_aspect.py (no-slip floor, cell
L0/10, 2 x 2 particles per cell, 3,200 particles, h = 1.25e-3 s, to
t = 1.82 s) is run without (`transfer.packing_correction: 0`) and with the
correction (talus's default, rate 0.25). Measured 2026-11-27: without, the
particles of the deposit's interior sit 1.28 times denser than their
volumes (scripts/particle_packing.py, boxes of two cells) and the deposit
is 1.47 L0 high at the wall; with it 1.04 and 1.81 L0. The test asserts
- without: packing >= 1.2 (the defect the correction removes is there);
- with: packing <= 1.1 (the correction leaves at most its 5 % tolerance and
  the boxes' noise);
- the deposit with it is at least 15 % higher (23 % measured): the
  particles take the space their volumes claim;
- the energy balance closes in both runs to 1e-5 of the column's initial
  potential energy (1.3e-6 measured), the correction's work included, and
  that work is positive (the shift lifts the crowded particles; 17.1 J/m of
  4,520 J/m measured) with the correction and zero without.

2. What it is right about: the a = 2 column (cell L0/20, to t = 1 s) with
2 x 2 particles per cell gives the run-out of 4 x 4 particles per cell
without the correction, whose finer rule between the knots crowds little
(3.373 against 3.372 measured; 3 x 3 gives 3.295, so 4 x 4 itself is
uncertain by a couple of per cent), while 2 x 2 without the correction
falls 8 % short (3.103). Asserted: within 2 % with it, more than 5 % short
without.

usage: test_packing_collapse.py TALUS_BINARY SOURCE_DIR
"""
import atexit
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

talus, source = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
sys.path.insert(0, os.path.join(source, "scripts"))
import study_column_aspect as study  # noqa: E402
from particle_packing import packing  # noqa: E402
from pvd import pvd_series, read_particles  # noqa: E402

# Open MPI 4 creates and removes /tmp/ompi.<host>.<uid> at every singleton
# start, and starts that overlap another test's race on it ("orte_init
# failed", exit code 1; docs/testing.md): this test's talus runs get a
# session directory of their own.
_ompi_sessions = tempfile.mkdtemp(prefix="ompi.")
os.environ["OMPI_MCA_orte_tmpdir_base"] = _ompi_sessions
atexit.register(shutil.rmtree, _ompi_sessions, True)

study.FLOOR = "fixed"
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def run(folder, extra, aspect=8.0, cells=10, ppc=2):
    out = os.path.join(folder, "out")
    case = os.path.join(folder, "case.yaml")
    os.makedirs(folder)
    study.PPC = ppc
    with open(case, "w") as f:
        f.write(study.case_text(aspect, cells, 0.00125, out) + extra)
    p = subprocess.run([talus, "run", case, "--overwrite", "--quiet"], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"talus run {case}: exit {p.returncode}\n{p.stderr[-2000:]}")
    summary = json.loads(p.stdout.split("talus-summary:", 1)[1].splitlines()[0])
    _, path = pvd_series(os.path.join(out, "particles.pvd"))[-1]
    x, (m, vol) = read_particles(path, ["mass", "volume"])
    reference = m / 1800.0
    packed = packing(x, reference, reference, 0.04)[0]
    height = (x[:, 1].max() + 0.5 * study.L0 / cells / ppc) / study.L0
    runout = (study.deposit(os.path.join(out, "particles.pvd"), study.L0 / cells / ppc)[0] - study.L0) / study.L0
    with open(os.path.join(out, "energy.csv")) as f:
        rows = list(csv.reader(f))
    header, first, last = rows[0], rows[1], rows[-1]
    potential = float(first[header.index("gravitational [J/m]")])
    correction = float(last[header.index("correction_work [J/m]")])
    return packed, height, summary["energy_balance_error"], potential, correction, runout


with tempfile.TemporaryDirectory() as tmp:
    without = "transfer: {packing_correction: 0}\n"
    off = run(os.path.join(tmp, "off"), without)
    on = run(os.path.join(tmp, "on"), "")
    a2_off = run(os.path.join(tmp, "a2_off"), without, 2.0, 20)
    a2_on = run(os.path.join(tmp, "a2_on"), "", 2.0, 20)
    a2_fine = run(os.path.join(tmp, "a2_fine"), without, 2.0, 20, 4)

print(f"without: packing {off[0]:.3f}, height {off[1]:.3f} L0, energy balance error {off[2]:.3g} J/m, "
      f"correction work {off[4]:.3g} J/m")
print(f"with:    packing {on[0]:.3f}, height {on[1]:.3f} L0, energy balance error {on[2]:.3g} J/m, "
      f"correction work {on[4]:.3g} J/m")
check(off[0] >= 1.2, "without the correction the deposit is crowded (packing >= 1.2)")
check(on[0] <= 1.1, "with it the packing is within 1.1")
check(on[1] >= 1.15 * off[1], "with it the deposit is at least 15 % higher")
for label, r in (("without", off), ("with", on)):
    check(abs(r[2]) <= 1e-5 * r[3], f"{label}: the energy balance closes to 1e-5 of the initial potential energy")
check(off[4] == 0.0 and on[4] > 0.0, "the correction's work is zero without it and positive with it")
print(f"a = 2, L0/20: run-out {a2_on[5]:.3f} (2 x 2, with it), {a2_off[5]:.3f} (2 x 2, none), "
      f"{a2_fine[5]:.3f} (4 x 4, none)")
check(abs(a2_on[5] - a2_fine[5]) <= 0.02 * a2_fine[5], "a = 2: 2 x 2 with it is within 2 % of 4 x 4 without")
check(a2_off[5] < 0.95 * a2_fine[5], "a = 2: 2 x 2 without it is more than 5 % short of 4 x 4")
if failures:
    sys.exit(f"{len(failures)} check(s) failed")
print("all checks passed")
