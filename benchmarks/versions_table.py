#!/usr/bin/env python3
"""The benchmark's headline rows on several DOLFINx versions, side by side.

    python3 benchmarks/versions_table.py bookworm=RUN1.csv trixie=RUN2.csv sid=RUN3.csv

Each CSV is what ``benchmarks/run.py --csv`` wrote on one release (the same problems, sizes and rank
counts). Prints one Markdown table: per problem, rank count and release, the dofs, the nonlinear solve from
u = 0 against the linear floor to the same accuracy (``ratio_linear_eq``), the estimate, Dörfler's marking,
nc_dolfinx's refinement against DOLFINx's own as nc_dolfinx calls it, the nested level's solve against its
floor, and the peak memory. Nothing is measured here.
"""
import csv
import sys

COLUMNS = [  # (heading, CSV column, format)
    ("dofs", "dofs", "{:,.0f}"),
    ("solve s", "t_solve", "{:.2f}"),
    ("floor s", "t_linear_eq", "{:.2f}"),
    ("solve/floor", "ratio_linear_eq", "{:.2f}"),
    ("estimate s", "t_estimate", "{:.3f}"),
    ("mark s", "t_mark", "{:.3f}"),
    ("refine s", "t_refine", "{:.2f}"),
    ("DOLFINx refine s", "t_refine_dolfinx", "{:.2f}"),
    ("refine/DOLFINx", "refine_over_dolfinx", "{:.2f}"),
    ("nested solve/floor", "ratio_nested_eq", "{:.2f}"),
    ("peak MB", "mem_peak_MB", "{:,.0f}"),
]


def cell(row, column, fmt):
    value = row.get(column, "")
    try:
        return fmt.format(float(value))
    except (TypeError, ValueError):
        return "–"


def main(args):
    runs = []
    for arg in args:
        release, _, path = arg.partition("=")
        with open(path) as fh:
            runs.append((release, list(csv.DictReader(fh))))
    keys = sorted({(r["problem"], int(r["np"]), float(r["dofs"])) for _, rows in runs for r in rows},
                  key=lambda k: (k[0], k[2], k[1]))
    print("| problem | ranks | release | " + " | ".join(h for h, _, _ in COLUMNS) + " |")
    print("|---|---|---|" + "---|" * len(COLUMNS))
    for problem, nprocs, dofs in keys:
        for release, rows in runs:
            row = next((r for r in rows if r["problem"] == problem and int(r["np"]) == nprocs
                        and float(r["dofs"]) == dofs), None)
            if row is None:
                continue
            print(f"| {problem} | {nprocs} | {release} | "
                  + " | ".join(cell(row, c, f) for _, c, f in COLUMNS) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
