"""The same numbers on every DOLFINx: compare the adaptive histories that .ci/run wrote on each release.

    python3 .ci/compare_histories.py RESULTS RELEASE [RELEASE ...]

RESULTS/RELEASE/CASE/history.json for CASE in block (2D, MUMPS) and hertz3d (3D, BoomerAMG-preconditioned
CG). Every level's dofs, cells and marked cells must be identical to the first release's; every float
(η, its parts, ζ, contact force, energy, ...) equal to a relative 1e-8 — the verification report's own
tolerance for "unchanged". Both cases solve Newton to a relative residual of 1e-10 and the Krylov method
tighter than that, so what the DOLFINx, PETSc, hypre and MUMPS versions change lies far below 1e-8
(measured: 3e-14 on block, see the README's DOLFINx versions section). Iteration counts and timings are
not compared (hypre's versions differ). Prints one line per case and release; exit 1 on a difference.
"""
import json
import sys
from pathlib import Path

EXACT = ("level", "dofs", "cells", "marked")
FLOATS = ("eta_1", "eta_2", "eta_3", "eta_4", "eta", "zeta", "max_contact_pressure", "elastic_energy",
          "contact_force", "contact_resultant", "contact_length", "max_penetration", "max_displacement",
          "applied_load")
# The supports' reactions: a component that vanishes in theory is round-off (1e-13 of the load), so they
# are compared relative to the forces on the body, |applied_load| + |contact_force|.
FORCES = "reaction_"
RTOL = 1e-8


def relative(a, b, scale=0.0):
    a, b = (x if isinstance(x, list) else [x] for x in (a, b))
    return max((abs(x - y) / max(abs(x), abs(y), scale, 1e-300) for x, y in zip(a, b)), default=0.0)


def size(vector):
    return sum(x * x for x in vector) ** 0.5


def compare(reference, other):
    """(largest relative difference of the floats, first mismatch as text or None)."""
    if len(reference) != len(other):
        return 0.0, f"{len(other)} levels, expected {len(reference)}"
    worst = 0.0
    for ref, row in zip(reference, other):
        for key in EXACT:
            if key in ref and ref[key] != row.get(key):
                return worst, f"level {ref['level']}: {key} {row.get(key)} != {ref[key]}"
        for key in FLOATS:
            if key in ref:
                worst = max(worst, relative(ref[key], row[key]))
        scale = size(ref.get("applied_load", [])) + size(ref.get("contact_force", []))
        for key in (k for k in ref if k.startswith(FORCES)):
            worst = max(worst, relative(ref[key], row[key], scale))
    return worst, None if worst <= RTOL else f"relative difference {worst:.1e} > {RTOL:g}"


def main(folder, releases):
    folder, failed = Path(folder), False
    for case in ("block", "hertz3d"):
        histories = {}
        for release in releases:
            path = folder / release / case / "history.json"
            if path.exists():
                histories[release] = json.loads(path.read_text())
            else:
                print(f"versions: {case} on {release}: no history ({path})")
                failed = True
        if not histories:
            continue
        first, reference = next(iter(histories.items()))
        for release, history in histories.items():
            if release == first:
                continue
            worst, problem = compare(reference, history)
            print(f"versions: {case}: {release} against {first}: {len(history)} levels, "
                  + (f"FAILED: {problem}" if problem else
                     f"dofs, cells and marked cells identical, floats within {worst:.1e} (relative)"))
            failed |= problem is not None
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2:]))
