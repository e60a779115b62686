#!/usr/bin/env python3
"""The command line's error contract fuzzed for a time budget (issue 31, item 5; the long profile).

    /usr/bin/python3 benchmarks/fuzz_long.py [--minutes 60] [--every 5] [--save DIR] [--timeout 240]
                                             [--families valid wrong-type ...] [--batch 20]

Random inputs of tests/fuzz_inputs.py (a small valid problem with at most one mutation: wrong types of
schema keys, misspelt keys, hostile expressions, titles, nesting, mesh and problem files, bad command-line
and PETSc options), drawn by Hypothesis with random seeds, each run through ``run_cases.py`` in a fresh
temporary folder: on 1 rank, and every ``--every``-th input on 2 ranks (mpirun). The contract
(fuzz_inputs.contract_breaks): exit 0 with finite results, or exit 1 with one line ``nc_dolfinx: error: …``
naming the key, file or option; never exit 3, a traceback, a hang, a file outside OUT, a command run.

Inputs are drawn in batches of ``--batch`` (one ``@given`` call each, a new seed each) until the time is
up; a mutation met again is skipped. Every input that breaks the contract is saved under ``--save`` (its
files, the output folder, the command, stdout, stderr and the breaks) and the run goes on. The final table
gives the date, commit, machine, command, inputs tried on 1 and 2 ranks, exits 0/1/other, and the breaks
by kind with one example each. Exit status 1 if anything broke the contract, else 0.
"""
import argparse
import datetime
import os
import platform
import shutil
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from hypothesis import Phase, given, settings  # noqa: E402

import fuzz_inputs as fz  # noqa: E402
from common import commit  # noqa: E402  (benchmarks/, the script's folder)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--minutes", type=float, default=60.0, help="time budget (default 60)")
    p.add_argument("--every", type=int, default=5, help="every k-th input on 2 ranks (0: never; default 5)")
    p.add_argument("--save", type=Path, default=None,
                   help="folder for the failing inputs (default: a new folder under the system's temp dir)")
    p.add_argument("--timeout", type=float, default=fz.TIMEOUT, help="seconds before a run is a hang (240)")
    p.add_argument("--families", nargs="+", choices=sorted(fz.FAMILIES), default=None,
                   help="only these families of inputs (default: all)")
    p.add_argument("--batch", type=int, default=20, help="inputs per Hypothesis call (default 20)")
    return p.parse_args(argv)


class Campaign:
    def __init__(self, args):
        self.args = args
        self.save = args.save or Path(tempfile.mkdtemp(prefix="nc_fuzz_long-"))
        self.save.mkdir(parents=True, exist_ok=True)
        self.deadline = time.monotonic() + 60 * args.minutes
        self.seen = set()
        self.drawn = 0
        self.exits = {1: Counter(), 2: Counter()}           # nprocs -> {"0", "1", "other"}
        self.families = defaultdict(Counter)                # family -> {tried, exit 0, exit 1, other, breaks}
        self.failures = []                                   # (outcome, saved folder)
        self.fuzzer_errors = []

    def run_one(self, fi):
        if time.monotonic() > self.deadline:
            return
        key = fz.input_key(fi)
        if key in self.seen:
            return
        self.seen.add(key)
        fz.self_check(fi)
        self.drawn += 1
        every = self.args.every
        nprocs = 2 if every and self.drawn % every == 0 else 1
        o = fz.run_input(fi, nprocs, timeout=self.args.timeout, keep=True)
        try:
            status = "timeout" if o.timed_out else str(o.returncode) if o.returncode in (0, 1) else "other"
            self.exits[nprocs][status] += 1
            row = self.families[fi.family]
            row["tried"] += 1
            row[f"exit {status}" if status in ("0", "1") else "other"] += 1
            if o.breaks:
                row["breaks"] += 1
                folder = self.save / f"{len(self.failures) + 1:03d}-{fi.family}-{nprocs}rank"
                fz.save(o, folder)
                self.failures.append((o, folder))
        finally:
            shutil.rmtree(o.folder, ignore_errors=True)
        mark = "BREAK" if o.breaks else "kept "
        print(f"{self.drawn:5d} {o.seconds:6.1f} s {mark} {fz.describe(o, 140)}", flush=True)

    def explore(self):
        @settings(max_examples=self.args.batch, derandomize=False, database=None, deadline=None,
                  phases=[Phase.generate], suppress_health_check=fz.SUPPRESS)
        @given(fz.fuzz_inputs(self.args.families))
        def batch(fi):
            self.run_one(fi)

        while time.monotonic() < self.deadline:
            try:
                batch()
            except Exception as err:  # a bug of the fuzzer itself (e.g. its self-check): recorded, go on
                self.fuzzer_errors.append(f"{type(err).__name__}: {err}")
                print(f"fuzzer error: {type(err).__name__}: {str(err)[:500]}", flush=True)
                if len(self.fuzzer_errors) > 20:
                    break

    def report(self, started, elapsed):
        kinds = defaultdict(list)
        for o, folder in self.failures:
            kinds[fz.signature(o)].append((o, folder))
        tried = {n: sum(c.values()) for n, c in self.exits.items()}
        lines = ["", "fuzz_long: the command line's error contract (issue 31, item 5)", ""]
        info = [("date", started.strftime("%Y-%m-%d %H:%M")),
                ("commit", commit()),
                ("machine", f"{platform.node()}, {os.cpu_count()} cores"),
                ("command", " ".join([Path(sys.executable).as_posix(), "benchmarks/fuzz_long.py", *sys.argv[1:]])),
                ("time", f"{elapsed / 60:.1f} min (budget {self.args.minutes:g} min)"),
                ("inputs tried", f"{tried[1]} on 1 rank, {tried[2]} on 2 ranks"),
                ("exits, 1 rank", _exits(self.exits[1])),
                ("exits, 2 ranks", _exits(self.exits[2])),
                ("breaks", f"{len(self.failures)} input(s), {len(kinds)} kind(s)"
                 + (f"; saved in {self.save}" if self.failures else "")),
                ("fuzzer errors", str(len(self.fuzzer_errors)))]
        width = max(len(k) for k, _ in info)
        lines += [f"{k.ljust(width)}  {v}" for k, v in info]
        lines += ["", _table(self.families)]
        if kinds:
            lines += ["", "breaks by kind (count; the first example; its saved folder):"]
            for kind, found in sorted(kinds.items(), key=lambda item: -len(item[1])):
                o, folder = found[0]
                lines.append(f"- {kind}: {len(found)}")
                lines.append(f"    {fz.describe(o, 200)}")
                lines.append(f"    saved: {folder}")
        if self.fuzzer_errors:
            lines += ["", "fuzzer errors (bugs of the fuzzer, not of nc_dolfinx):"]
            lines += [f"- {text[:300]}" for text in self.fuzzer_errors[:5]]
        return "\n".join(lines)


def _exits(counter):
    return (f"0: {counter['0']}, 1: {counter['1']}, other: {counter['other']}, "
            f"timeout: {counter['timeout']}")


def _table(families):
    columns = ["family", "tried", "exit 0", "exit 1", "other", "breaks"]
    rows = [[name] + [str(families[name][c]) for c in columns[1:]] for name in sorted(families)]
    widths = [max(len(x) for x in col) for col in zip(columns, *rows)]
    out = ["  ".join(h.ljust(w) if i == 0 else h.rjust(w) for i, (h, w) in enumerate(zip(columns, widths))),
           "  ".join("-" * w for w in widths)]
    out += ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths)))
            for row in rows]
    return "\n".join(out)


def main(argv=None):
    args = parse_args(argv)
    started, start = datetime.datetime.now(), time.monotonic()
    campaign = Campaign(args)
    print(f"fuzzing for {args.minutes:g} min; failing inputs go to {campaign.save}", flush=True)
    try:
        campaign.explore()
    except KeyboardInterrupt:
        print("interrupted: the report covers the inputs run so far", flush=True)
    text = campaign.report(started, time.monotonic() - start)
    print(text, flush=True)
    (campaign.save / "report.txt").write_text(text + "\n")
    return 1 if campaign.failures or campaign.fuzzer_errors else 0


if __name__ == "__main__":
    sys.exit(main())
