#!/usr/bin/env python3
"""Every test the sources define is known to ctest (issue 14).

Catch2's test discovery runs each test binary at build time; when that run
fails (once seen: MPI_Init_thread failing during a parallel build), the
binary's tests are silently missing from ctest and the suite "passes" with
fewer tests. This test counts what the sources define -- one ctest test per
TEST_CASE in tests/*.cpp, one per MPI rank count of talus_test(... MPI n ...),
one per add_test outside the talus_test function, this one included -- and
compares with `ctest -N`.

usage: test_inventory.py SOURCE_DIR BUILD_DIR
"""
import glob
import re
import subprocess
import sys

source, build = sys.argv[1], sys.argv[2]
names = [n for f in glob.glob(source + "/tests/*.cpp") for n in re.findall(r'^TEST_CASE\("([^"]*)"', open(f).read(), re.M)]
cases = len(names)
# ctest's discovery splits a name at ";" (a CMake list separator) into two
# tests that match nothing and so never run.
split = [n for n in names if ";" in n]
if split:
    print("FAIL: test names with ';' never run under ctest:", split)
    sys.exit(1)
cmake = open(source + "/tests/CMakeLists.txt").read()
function_end = cmake.index("endfunction()")
ranks = sum(len(m.group(1).split()) for m in re.finditer(r"^talus_test\(\w+ MPI ([\d ]+)\)", cmake, re.M))
scripts = len(re.findall(r"^add_test\(NAME", cmake[function_end:], re.M))
expected = cases + ranks + scripts
listed = subprocess.run(["ctest", "--test-dir", build, "-N"], capture_output=True, text=True, check=True).stdout
total = int(re.search(r"Total Tests: (\d+)", listed).group(1))
print(f"{cases} test cases + {ranks} MPI runs + {scripts} scripts = {expected}; ctest lists {total}")
if total != expected:
    print("FAIL: ctest does not list every test the sources define (a failed Catch2 discovery?)")
    sys.exit(1)
