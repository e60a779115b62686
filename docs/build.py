"""Build the documentation site: one command, no network.

    /usr/bin/python3 docs/build.py [--out DIR]      # default DIR: docs/_build; the site is DIR/html/index.html

1. copies the sources docs/src/ to DIR/src/ (a staging tree, so a build writes nothing into the repository
   outside DIR) and generates there, under ``_generated/`` (files that pages include, not pages):
   ``keys.md`` and ``columns.md`` (the problem-file keys and the output columns, docs/reference_tables.py;
   the reference pages include them),
   ``verification/`` (verification/report.md, its headings one level down, and its pictures; the
   verification page does ``{include} _generated/verification/report.md`` with ``:relative-images:``) and
   ``figures/`` (the pictures docs/*.png), and the demo pages ``demos/demo_*.md``: every demo executed
   cell by cell at its small size (docs/demo_pages.py);
2. runs ``sphinx-build -W --keep-going -b html`` (a warning fails the build) with docs/src/conf.py;
3. checks every internal link of the built HTML: each local ``href``/``src`` names an existing file, and
   each ``#fragment`` an id of the target page.

Exit 0 when all three succeed, else 1 with what failed. Packages: install.sh (python3-sphinx,
python3-myst-parser, furo).
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
SOURCE = DOCS / "src"
sys.path.insert(0, str(DOCS))

import demo_pages  # noqa: E402
import reference_tables  # noqa: E402


def _copy_if_changed(source, target):
    """Copy keeping the modification time, and only a changed file (Sphinx then rebuilds only what changed)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    if not target.is_file() or target.read_bytes() != source.read_bytes():
        shutil.copy2(source, target)


def _write_if_changed(target, text):
    target.parent.mkdir(parents=True, exist_ok=True)
    if not target.is_file() or target.read_text() != text:
        target.write_text(text)


def stage_sources(staging):
    """Mirror docs/src into ``staging`` (files removed from docs/src go, generated ones stay)."""
    wanted = set()
    for path in SOURCE.rglob("*"):
        if path.is_file() and "__pycache__" not in path.parts and path.name != "conf.py":
            relative = path.relative_to(SOURCE)
            wanted.add(relative)
            _copy_if_changed(path, staging / relative)
    for path in staging.rglob("*.md"):
        relative = path.relative_to(staging)
        if relative not in wanted and relative.parts[0] != "_generated" and not relative.name.startswith("demo_"):
            path.unlink()


def shift_headings(markdown):
    """Every ATX heading one level down (outside fenced code), so that an included page's title sits
    under the including page's."""
    out, fence = [], None
    for line in markdown.splitlines():
        opened = re.match(r"\s*(`{3,}|~{3,})", line)
        if opened and (fence is None or opened.group(1).startswith(fence)):
            fence = None if fence else opened.group(1)
        if fence is None and re.match(r"#{1,5} ", line):
            line = "#" + line
        out.append(line)
    return "\n".join(out) + "\n"


def generate(staging):
    """The generated inputs: key table, verification report, figures (``_generated/``), demo pages."""
    generated = staging / "_generated"
    reference_tables.write(generated)
    report = ROOT / "verification" / "report.md"
    _write_if_changed(generated / "verification" / "report.md", shift_headings(report.read_text()))
    for picture in (ROOT / "verification").glob("*.png"):
        _copy_if_changed(picture, generated / "verification" / picture.name)
    for picture in DOCS.glob("*.png"):
        _copy_if_changed(picture, generated / "figures" / picture.name)
    demos = sorted((ROOT / "demos").glob("demo_*.py"))
    for stale in (staging / "demos").glob("demo_*.md"):  # the page of a demo that is gone
        if not (ROOT / "demos" / f"{stale.stem}.py").is_file():
            stale.unlink()
            shutil.rmtree(stale.with_name(f"{stale.stem}_files"), ignore_errors=True)
    for demo in demos:
        start = time.monotonic()
        demo_pages.write_page(demo, staging / "demos")
        print(f"  executed {demo.relative_to(ROOT)} ({time.monotonic() - start:.0f} s)", flush=True)
    return demos


def sphinx(staging, out):
    """sphinx-build -W --keep-going -b html; returns its exit code."""
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "-c", str(SOURCE),
               "-d", str(out / "doctrees"), str(staging), str(out / "html")]
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run(command, env=env).returncode


class _Links(HTMLParser):
    """The ids of a page and its local links (href/src values)."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.ids, self.links = set(), []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if attrs.get("id"):
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("name"):
            self.ids.add(attrs["name"])
        for attribute in ("href", "src"):
            value = attrs.get(attribute)
            if value is not None:
                self.links.append(value)


def _parse(page, cache):
    if page not in cache:
        parser = _Links()
        parser.feed(page.read_text(errors="replace"))
        cache[page] = parser
    return cache[page]


def check_links(html_dir):
    """(number of local links checked, [broken link descriptions]) over every page of the site."""
    cache, broken, checked = {}, [], 0
    for page in sorted(html_dir.rglob("*.html")):
        for link in _parse(page, cache).links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "javascript:", "data:")):
                continue            # external: not checked (no network)
            if not parts.path and not parts.fragment:
                continue            # href="" or "#"
            checked += 1
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            where = f"{page.relative_to(html_dir)}: {link}"
            if not target.is_file():
                broken.append(f"{where} (no file {target})")
            elif parts.fragment and target.suffix == ".html":
                if unquote(parts.fragment) not in _parse(target, cache).ids:
                    broken.append(f"{where} (no id '{parts.fragment}' in {target.relative_to(html_dir)})")
    return checked, broken


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=DOCS / "_build", help="build directory (default docs/_build)")
    args = parser.parse_args(argv)
    out = args.out.resolve()
    staging = out / "src"
    begin = time.monotonic()

    step = time.monotonic()
    stage_sources(staging)
    try:
        demos = generate(staging)
    except demo_pages.DemoError as err:
        print(f"build: a demo failed: {err}", file=sys.stderr)
        return 1
    print(f"generated the key table, the verification report and {len(demos)} demo pages "
          f"({time.monotonic() - step:.0f} s)", flush=True)

    step = time.monotonic()
    if sphinx(staging, out) != 0:
        print("build: sphinx-build failed (warnings are errors): see above", file=sys.stderr)
        return 1
    print(f"sphinx-build -W: {out / 'html' / 'index.html'} ({time.monotonic() - step:.0f} s)", flush=True)

    checked, broken = check_links(out / "html")
    print(f"internal links checked: {checked}, broken: {len(broken)}")
    for line in broken:
        print(f"  broken: {line}", file=sys.stderr)
    print(f"total {time.monotonic() - begin:.0f} s")
    return 1 if broken or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
