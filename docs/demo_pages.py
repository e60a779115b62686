"""Turn the jupytext percent-format demos (demos/demo_*.py) into MyST pages, executing them.

    /usr/bin/python3 docs/demo_pages.py DEMO.py DEST_DIR     # write DEST_DIR/DEMO.md and DEST_DIR/DEMO_files/

``# %% [markdown]`` cells become markdown; each code cell becomes a ``python`` block followed by what it
printed (a ``text`` block of class ``demo-output``) and the pictures it wrote (images). The cells run in
order in one namespace, in one process of their own (no MPI launcher), at the small size:
``sys.argv = [DEMO, "--small", "--out", DEST_DIR/DEMO_files]`` and that directory as the working directory.
A cell's pictures are the image files that appeared or changed in the output directory while it ran. A
cell that raises fails the page: :class:`DemoError` names the demo and the cell. docs/build.py calls
:func:`write_page` for every demo.
"""
import contextlib
import io
import json
import os
import re
import shutil
import subprocess
import sys
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
IMAGES = {".png", ".svg", ".jpg", ".jpeg", ".gif"}
TIMEOUT = 900  # seconds for one demo


class DemoError(RuntimeError):
    """A demo cell failed (or the demo's process did not end): the message names the demo and the cell."""


def split_cells(text):
    """[(kind, first_line, lines)] of a percent-format script: kind "markdown" or "code", first_line the
    1-based line number of the cell's first line after its ``# %%`` marker. The jupytext header (before
    the first marker) is dropped."""
    cells = []
    for number, line in enumerate(text.splitlines(), start=1):
        marker = re.match(r"# %%(.*)$", line)
        if marker:
            kind = "markdown" if "[markdown]" in marker.group(1) else "code"
            cells.append((kind, number + 1, []))
        elif cells:
            cells[-1][2].append(line)
    return [(kind, first, _trim(lines)) for kind, first, lines in cells]


def _trim(lines):
    while lines and not lines[0].strip():
        lines = lines[1:]
    while lines and not lines[-1].strip():
        lines = lines[:-1]
    return lines


def _cell_source(text, first):
    """The lines of the cell starting at line ``first`` as they are in the file (blank lines kept), so that
    a traceback's line numbers are the script's."""
    lines = text.splitlines()[first - 1:]
    end = next((i for i, line in enumerate(lines) if line.startswith("# %%")), len(lines))
    return "\n" * (first - 1) + "\n".join(lines[:end]) + "\n"


def _snapshot(directory):
    return {p.relative_to(directory).as_posix(): (p.stat().st_mtime_ns, p.stat().st_size)
            for p in directory.rglob("*") if p.is_file()}


def execute(demo, out_dir, result_json):
    """Run the code cells of ``demo`` in order in one namespace (in this process); write
    [{"stdout", "files"}] per code cell to ``result_json``, or {"error": …} at the first failing cell."""
    demo, out_dir = Path(demo).resolve(), Path(out_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    os.chdir(out_dir)
    sys.argv = [str(demo), "--small", "--out", str(out_dir)]
    sys.path.insert(0, str(demo.parent))
    text = demo.read_text()
    namespace = {"__name__": "__main__", "__file__": str(demo), "__builtins__": __builtins__}
    results = []
    cells = split_cells(text)
    for number, (kind, first, _) in enumerate(cells, start=1):
        if kind != "code":
            continue
        before = _snapshot(out_dir)
        buffer = io.StringIO()
        try:
            code = compile(_cell_source(text, first), str(demo), "exec")
            with contextlib.redirect_stdout(buffer):
                exec(code, namespace)
        except BaseException:  # noqa: B036 (SystemExit too: the page needs every cell)
            Path(result_json).write_text(json.dumps({"error": {
                "cell": number, "cells": len(cells), "line": first, "stdout": buffer.getvalue(),
                "traceback": traceback.format_exc()}}))
            return 1
        after = _snapshot(out_dir)
        files = sorted((name for name, stamp in after.items() if before.get(name) != stamp),
                       key=lambda name: (after[name][0], name))
        results.append({"stdout": buffer.getvalue(), "files": files})
    Path(result_json).write_text(json.dumps({"cells": results}))
    return 0


def _fence(content, info):
    """A backtick fence around ``content`` longer than any backtick run inside it."""
    longest = max((len(run) for run in re.findall(r"`+", content)), default=0)
    ticks = "`" * max(3, longest + 1)
    return f"{ticks}{info}\n{content}\n{ticks}"


def render(demo, cells, outputs, files_dir):
    """The MyST page of ``demo`` from its cells and their outputs; pictures referenced in ``files_dir``."""
    relative = demo.relative_to(ROOT).as_posix() if demo.is_relative_to(ROOT) else demo.name
    note = (":::{note}\nThis page is the script `" + relative + "`, executed when the site was built (`--small`, "
            "one process): each code cell is followed by what it printed and the pictures it drew.\n:::")
    parts, code_outputs = [], iter(outputs)
    for kind, _, lines in cells:
        if kind == "markdown":
            parts.append("\n".join(re.sub(r"^# ?", "", line) if line.startswith("#") else line for line in lines))
            if len(parts) == 1:
                parts.append(note)
            continue
        output = next(code_outputs)
        if lines:
            parts.append(_fence("\n".join(lines), "python"))
        stdout = output["stdout"].rstrip()
        if stdout:
            parts.append(_fence(":class: demo-output\n\n" + stdout, "{code-block} text"))
        others = []
        for name in output["files"]:
            if Path(name).suffix.lower() in IMAGES:
                parts.append(f"![{name}]({files_dir}/{name})")
            else:
                others.append(f"`{name}`")
        if others:
            parts.append("*(The cell also wrote " + ", ".join(others) + ".)*")
    return "\n\n".join(part for part in parts if part.strip()) + "\n"


def write_page(demo, dest_dir):
    """Execute ``demo`` in a fresh process and write ``dest_dir/<stem>.md`` and its pictures in
    ``dest_dir/<stem>_files/``. Raises DemoError naming the demo and the cell that failed."""
    demo, dest_dir = Path(demo).resolve(), Path(dest_dir)
    files = dest_dir / f"{demo.stem}_files"
    shutil.rmtree(files, ignore_errors=True)
    files.mkdir(parents=True)
    result = dest_dir / f"{demo.stem}.json"
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1")
    for name in ("NC_DEMO_OUT", "NC_DEMO_SMALL"):
        env.pop(name, None)
    try:
        proc = subprocess.run([sys.executable, __file__, "--execute", str(demo), str(files), str(result)],
                              env=env, cwd=files, capture_output=True, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired as err:
        raise DemoError(f"{demo.name}: did not end within {TIMEOUT} s") from err
    data = json.loads(result.read_text()) if result.is_file() else {}
    result.unlink(missing_ok=True)
    if "error" in data:
        e = data["error"]
        raise DemoError(f"{demo.name}: cell {e['cell']} of {e['cells']} (the cell at line {e['line']}) failed:\n"
                        f"{e['stdout'][-2000:]}{e['traceback']}")
    if proc.returncode != 0 or "cells" not in data:
        raise DemoError(f"{demo.name}: the process running it failed (exit {proc.returncode}):\n"
                        f"{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}")
    for cell in data["cells"]:  # the build directory's path means nothing to a reader
        cell["stdout"] = cell["stdout"].replace(str(files.resolve()), files.name)
    page = render(demo, split_cells(demo.read_text()), data["cells"], files.name)
    (dest_dir / f"{demo.stem}.md").write_text(page)
    return dest_dir / f"{demo.stem}.md"


if __name__ == "__main__":
    if sys.argv[1:2] == ["--execute"]:
        sys.exit(execute(*sys.argv[2:5]))
    try:
        print(write_page(sys.argv[1], sys.argv[2]))
    except DemoError as err:
        sys.exit(f"demo_pages: {err}")
