"""The tutorials (docs/src/tutorials/*.md, issue 49) run as a reader runs them, and print what their pages show.

Each page is read as a script, in order, in a scratch folder that stands for the reader's clone of the
repository (``run_cases.py``, ``nc_dolfinx/``, ``meshes/`` and ``demos/`` are links to the repository's):

- a code block with a ``:caption: NAME`` option (```` ```{code-block} toml ```` + ``:caption: plate.toml``)
  is a file the reader writes: it is written to NAME;
- a fenced block of language ``sh`` holds commands the reader types: each line (``\\`` continues a line,
  ``#`` starts a comment) runs in bash, one after another, and any failure fails the page (blocks in
  ``shell`` or ``bash`` are shown, never run: installing, a cluster's job script);
- a ``text`` block right after an ``sh`` block is what those commands print on standard output. Compared
  line by line, blank lines left out: the text must be equal, and every number equal to the page's within
  RTOL (relative; integers exactly). ``…`` stands for anything on its line (a time, an iteration count, a
  path); a line holding ``…`` alone for any number of lines.
- a picture of the page (``![…](NAME.png)``, next to the page) must be one that its commands make: PICTURES
  names the file they write it to, and the test checks it is written and not empty.

Runs on every release CI tests (DOLFINx 0.5.2, 0.9, 0.11): a number the releases print differently beyond
round-off must be printed with fewer digits on the page. Runtimes per page on 2 cores: tutorials/index.md.
"""
import math
import os
import re
import subprocess
import time

import pytest

from conftest import ROOT

TUTORIALS = ROOT / "docs" / "src" / "tutorials"
RTOL = 1e-6
TIMEOUT = 600  # seconds for one page
LINKED = ("run_cases.py", "nc_dolfinx", "meshes", "demos")
# page -> {picture on the page: the file its commands write, relative to the scratch folder}
PICTURES = {
    "first_run.md": {"first_run_convergence.png": "results/block/convergence.png"},
    "own_2d_problem.md": {"own_2d_mesh.png": "plate_mesh.png"},
    "symmetry_3d.md": {"symmetry_3d_pressure.png": "quarter_pressure.png"},
    "friction_load_path.md": {"friction_curve.png": "shear_curve.png"},
    "python_study.md": {"python_study.png": "study.png"},
    "mpi_cluster.md": {"mpi_cluster_ranks.png": "ranks.png"},
}
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def parse(text):
    """[(kind, payload)] of a tutorial page in order: ("file", (name, content)), ("sh", commands),
    ("expect", lines) — the last one only right after an "sh" block."""
    steps, lines, i = [], text.splitlines(), 0
    while i < len(lines):
        opened = re.match(r"^(`{3,})\s*(\{code-block\}\s*)?([\w+-]*)\s*$", lines[i])
        if not opened:
            if lines[i].strip() and steps and steps[-1][0] == "sh":
                steps.append(("prose", None))  # an expected output must follow its commands directly
            i += 1
            continue
        fence, language = opened.group(1), opened.group(3)
        body, i = [], i + 1
        while i < len(lines) and not lines[i].startswith(fence):
            body.append(lines[i])
            i += 1
        i += 1
        options = {}
        if opened.group(2):
            while body and re.match(r"^:\w+:", body[0]):
                key, _, value = body.pop(0)[1:].partition(":")
                options[key] = value.strip()
            while body and not body[0].strip():
                body.pop(0)
        if "caption" in options:
            steps.append(("file", (options["caption"], "\n".join(body) + "\n")))
        elif language == "sh":
            steps.append(("sh", _commands(body)))
        elif language == "text" and steps and steps[-1][0] == "sh":
            steps.append(("expect", [line.rstrip() for line in body if line.strip()]))
    return [step for step in steps if step[0] != "prose"]


def _commands(body):
    commands, current = [], ""
    for line in body:
        if not current and (not line.strip() or line.lstrip().startswith("#")):
            continue
        if line.rstrip().endswith("\\"):
            current += line.rstrip()[:-1] + " "
        else:
            commands.append(current + line)
            current = ""
    if current:
        commands.append(current)
    return commands


def _pattern(expected):
    """A regex of an expected line: its numbers captured, ``…`` anything, runs of spaces any run of spaces."""
    parts = []
    for piece in re.split(rf"(…|{NUMBER}|\s+)", expected.strip()):
        if not piece:
            continue
        if piece == "…":
            parts.append(".*?")
        elif piece.isspace():
            parts.append(r"\s+")
        elif re.fullmatch(NUMBER, piece):
            parts.append(f"({NUMBER})")
        else:
            parts.append(re.escape(piece))
    return re.compile("^" + "".join(parts) + "$")


def _same(expected, actual):
    if re.fullmatch(r"[-+]?\d+", expected):
        return int(expected) == int(float(actual))
    e, a = float(expected), float(actual)
    return math.isclose(a, e, rel_tol=RTOL, abs_tol=1e-300) or (e == 0 and abs(a) < 1e-12)


def compare(expected, actual):
    """Problems (a list of lines) where the output ``actual`` (a list of non-blank lines) departs from the
    page's ``expected`` lines."""
    problems, j = [], 0
    for k, line in enumerate(expected):
        if line.strip() == "…":
            if k + 1 == len(expected):
                return problems
            following = _pattern(expected[k + 1])
            while j < len(actual) and not following.match(actual[j].strip()):
                j += 1
            continue
        if j >= len(actual):
            problems.append(f"missing: {line!r}")
            continue
        pattern, got = _pattern(line), actual[j].strip()
        match = pattern.match(got)
        if not match:
            problems.append(f"page: {line.strip()!r}\n  run:  {got!r}")
        else:
            for e, a in zip(re.findall(NUMBER, line.strip()), match.groups()):
                if not _same(e, a):
                    problems.append(f"number {e} on the page, {a} printed: {got!r}")
        j += 1
    if j < len(actual):
        problems.append("printed beyond the page: " + " | ".join(actual[j:j + 5]))
    return problems


def run_page(page, folder):
    """Run a page's steps in ``folder``; returns [(commands, output, problems)] and the time taken."""
    for name in LINKED:
        (folder / name).symlink_to(ROOT / name)
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONDONTWRITEBYTECODE="1", MPLBACKEND="Agg")
    for name in ("PYTHONPATH", "NC_DEMO_OUT", "NC_DEMO_SMALL"):
        env.pop(name, None)
    report, start, last = [], time.monotonic(), None
    for kind, payload in parse(page.read_text()):
        if kind == "file":
            name, content = payload
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_text(content)
        elif kind == "sh":
            output = ""
            for command in payload:
                if os.geteuid() != 0:
                    command = command.replace(" --allow-run-as-root", "")
                proc = subprocess.run(["bash", "-c", command], cwd=folder, env=env, capture_output=True,
                                      text=True, timeout=TIMEOUT)
                assert proc.returncode == 0, (f"{page.name}: `{command}` failed ({proc.returncode}):\n"
                                              f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
                output += proc.stdout
            last = (payload, output)
        elif kind == "expect":
            commands, output = last
            actual = [line.rstrip() for line in output.splitlines() if line.strip()]
            report.append((commands, output, compare(payload, actual)))
    return report, time.monotonic() - start


def pages():
    return sorted(p.name for p in TUTORIALS.glob("*.md") if p.name != "index.md")


def test_every_tutorial_is_listed_with_its_pictures():
    assert pages() == sorted(PICTURES)
    index = (TUTORIALS / "index.md").read_text()
    for name in pages():
        assert name[:-3] in index, f"tutorials/index.md does not list {name}"
        shown = set(re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", (TUTORIALS / name).read_text()))
        assert shown == set(PICTURES[name]), (name, shown)
        for picture in shown:
            assert (TUTORIALS / picture).is_file(), picture


def test_the_comparison_rule():
    page = ["level  0:  306 dofs, … its, eta = 2.7705e+01", "…", "done 1.5"]
    run = ["level  0:  306 dofs, 5 Newton (20 linear) its, eta = 2.77050001e+01", "x", "y", "done 1.5"]
    assert compare(page, run) == []
    assert compare(page, [run[0].replace("306", "307")] + run[1:])
    assert compare(page, [run[0].replace("2.77050001", "2.7706")] + run[1:])
    assert compare(["a 1"], ["a 1", "b"])  # printed beyond the page


@pytest.mark.long  # 10-60 s a page on 2 cores, 2 minutes for all: collected first (tests/conftest.py)
@pytest.mark.parametrize("name", pages())
def test_tutorial_runs_and_prints_what_its_page_shows(name, tmp_path):
    report, seconds = run_page(TUTORIALS / name, tmp_path)
    print(f"{name}: {seconds:.0f} s")
    assert report, f"{name} shows no output"
    problems = [f"after `{'; '.join(commands)}`:\n  " + "\n  ".join(found) + f"\n--- printed:\n{output}"
                for commands, output, found in report if found]
    assert not problems, f"{name} differs from what it printed:\n" + "\n".join(problems)
    for picture, written in PICTURES[name].items():
        path = tmp_path / written
        assert path.is_file() and path.stat().st_size > 0, f"{name}: {written} (shown as {picture}) not written"


def main(argv):
    """``/usr/bin/python3 tests/test_tutorials.py [PAGE.md …]``: run the pages (all by default) as the test
    does, print their times and any difference, and copy the pictures they made next to the pages."""
    import shutil
    import tempfile
    failed = False
    for name in argv or pages():
        with tempfile.TemporaryDirectory() as scratch:
            report, seconds = run_page(TUTORIALS / name, __import__("pathlib").Path(scratch))
            found = [line for _, _, problems in report for line in problems]
            print(f"{name}: {seconds:.0f} s, {'differs: ' + '; '.join(found) if found else 'as on the page'}")
            failed |= bool(found)
            for picture, written in PICTURES[name].items():
                shutil.copyfile(__import__("pathlib").Path(scratch) / written, TUTORIALS / picture)
    return 1 if failed else 0


if __name__ == "__main__":
    import sys
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
    sys.exit(main(sys.argv[1:]))
