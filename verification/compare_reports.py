#!/usr/bin/env python3
"""Compare two full verification reports (e.g. the same commit on two Debian releases), table cell by cell.

    python3 verification/compare_reports.py verification/report.md OTHER/report.md

Every table of the two reports is paired in order (the reports have the same structure when they come from
the same code); a cell that differs is counted under its table's heading and column, with the largest
relative difference where both cells are numbers. Prints one line per (table, column) that differs and
the count of cells that agree; exits 1 if the tables are not the same in number or shape.
"""
import re
import sys
from collections import defaultdict

NUMBER = re.compile(r"^[-+−]?\d+(\.\d+)?([eE][-+]?\d+)?$")


def tables(path):
    """[(heading, header cells, rows of cells)] of a markdown file, in order."""
    found, heading, lines = [], "", open(path, encoding="utf-8").read().splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("#") or (line.startswith("*") and line.endswith("*")):
            heading = line.strip("#* ")
        if line.startswith("|") and i + 1 < len(lines) and set(lines[i + 1].replace("|", "").strip()) <= set("-: "):
            header, rows = cells(line), []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append(cells(lines[i]))
                i += 1
            found.append((heading, header, rows))
            continue
        i += 1
    return found


def cells(line):
    """The cells of a table row (a "\\|" inside a cell, as in |R_ε/R_S − 1|, is text, not a border)."""
    return [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]


def number(text):
    text = text.replace("−", "-").replace(",", "").rstrip("%").strip()
    return float(text) if NUMBER.match(text) else None


def compare(a_path, b_path):
    a, b = tables(a_path), tables(b_path)
    if len(a) != len(b):
        print(f"{len(a)} tables against {len(b)}: not the same report structure")
        return 1
    differences, agree = defaultdict(lambda: [0, 0.0, []]), 0
    for (heading, header, rows_a), (_, _, rows_b) in zip(a, b):
        if len(rows_a) != len(rows_b):
            print(f"'{heading}': {len(rows_a)} rows against {len(rows_b)}")
            return 1
        for row_a, row_b in zip(rows_a, rows_b):
            for column, (x, y) in enumerate(zip(row_a, row_b)):
                if x == y:
                    agree += 1
                    continue
                entry = differences[(heading, header[column] if column < len(header) else str(column))]
                entry[0] += 1
                nx, ny = number(x), number(y)
                if nx is not None and ny is not None:
                    entry[1] = max(entry[1], abs(nx - ny) / max(abs(nx), abs(ny), 1e-300))
                elif len(entry[2]) < 2:
                    entry[2].append(f"{x[:40]!r} / {y[:40]!r}")
    for (heading, column), (count, relative, texts) in differences.items():
        detail = f"max rel. diff {relative:.1e}" if not texts else "; ".join(texts)
        print(f"{heading[:60]} | {column[:30]} | {count} cell(s) differ | {detail}")
    print(f"{agree} cells agree, {sum(d[0] for d in differences.values())} differ")
    return 0


if __name__ == "__main__":
    sys.exit(compare(*sys.argv[1:3]))
