"""Helpers shared by the benchmark scripts: table formatting and machine load.

A table is described by `columns`, a list of (key, header, format spec)."""
import json
import math
import os
import subprocess
import sys


def machine_busy_seconds():
    """Busy CPU time of all cores since boot, in seconds (/proc/stat)."""
    try:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
    except (OSError, ValueError):
        return 0.0
    idle = v[3] + (v[4] if len(v) > 4 else 0)
    return (sum(v[:8]) - idle) / os.sysconf("SC_CLK_TCK")


def fmt(value, spec):
    if value is None or value == "" or (isinstance(value, float) and math.isnan(value)):
        return "-"
    try:
        return spec.format(value)
    except (ValueError, TypeError):
        return str(value)


def table_lines(rows, columns):
    """A plain-text table, right-aligned columns."""
    head = [h for _, h, _ in columns]
    body = [[fmt(r.get(k), f) for k, _, f in columns] for r in rows]
    widths = [max(len(head[i]), *(len(b[i]) for b in body)) if body else len(head[i]) for i in range(len(head))]
    lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths)),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(c.rjust(w) for c, w in zip(b, widths)) for b in body]
    return lines


def markdown_lines(rows, columns, text_columns=1):
    """A markdown table; the first `text_columns` columns are left-aligned."""
    head = [h for _, h, _ in columns]
    align = ["---" if i < text_columns else "---:" for i in range(len(head))]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(align) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(fmt(r.get(k), f) for k, _, f in columns) + " |")
    return lines


def run_talus_case(talus, case):
    """`talus run case --overwrite` (a benchmark runs a case into the same
    directory again): (user + sys CPU seconds of the child, its talus-summary
    as a dict); exits with the run's stderr if it fails."""
    before = os.times()
    p = subprocess.run([talus, "run", case, "--overwrite"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    after = os.times()
    if p.returncode != 0:
        sys.exit(f"talus run {case} failed with exit code {p.returncode}:\n{p.stderr[-2000:]}")
    summary = json.loads(p.stdout.split("talus-summary:", 1)[1].splitlines()[0])
    return (after.children_user - before.children_user) + (after.children_system - before.children_system), summary
