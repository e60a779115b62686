"""The documentation site (issue 29): ``docs/build.py`` builds it with warnings as errors, the demos
executed, every internal link resolving; then headless Chromium opens the built pages through file://
URLs and sees the titles, pictures that really render (not broken images), the demos' output, every
public name on the API page, every problem-file key and output column on the reference pages, the
tutorials first in the navigation with their pictures and no dated log in it.

Needs python3-sphinx, python3-myst-parser, furo, chromium, chromium-driver and python3-selenium
(install.sh): without them the tests fail, they do not skip. No network: Chromium resolves no host name.
"""
import importlib.util
import os
import re
import shutil
import subprocess

import pytest

from conftest import PYTHON, ROOT

import nc_dolfinx as nc

# CI builds the site on one release (pyproject.toml): its demos run on every release in test_demos.py.
pytestmark = pytest.mark.one_release

INSTALL = "run `sh install.sh` as root (it installs the documentation and browser packages)"
BUILD_TIMEOUT = 1200  # seconds: the four demos run at their small size inside the build
DEMO_PAGE = "demos/demo_paper_setting.html"


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """Build the site once into a temporary directory: (html directory, the build's output)."""
    out = tmp_path_factory.mktemp("docs")
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", PYTHONDONTWRITEBYTECODE="1")
    proc = subprocess.run([PYTHON, str(ROOT / "docs" / "build.py"), "--out", str(out)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=BUILD_TIMEOUT)
    if "No module named sphinx" in proc.stderr or "myst_parser" in proc.stderr and "No module" in proc.stderr:
        pytest.fail(f"Sphinx or MyST is missing: {INSTALL}\n{proc.stderr[-2000:]}")
    return out / "html", proc


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """Headless Chromium driven by Debian's chromedriver (no Selenium Manager, no download)."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.fail(f"python3-selenium is missing: {INSTALL}")
    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    if not chromium or not driver:
        pytest.fail(f"chromium or chromium-driver is missing: {INSTALL}")
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for argument in ("--headless", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                     "--host-resolver-rules=MAP * ~NOTFOUND",  # no network: the CDN's MathJax fails at once
                     f"--user-data-dir={tmp_path_factory.mktemp('chromium')}", "--window-size=1280,1024"):
        options.add_argument(argument)
    options.page_load_strategy = "eager"  # DOMContentLoaded: pictures are waited for below, not scripts
    chrome = webdriver.Chrome(service=Service(executable_path=driver), options=options)
    chrome.set_page_load_timeout(60)
    yield chrome
    chrome.quit()


def open_page(browser, html, page):
    """Load ``page`` of the built site and wait until every picture has finished loading (or failed)."""
    from selenium.webdriver.support.ui import WebDriverWait
    browser.get((html / page).as_uri())
    WebDriverWait(browser, 60).until(
        lambda b: b.execute_script("return Array.from(document.images).every(i => i.complete)"))


def images(browser):
    """[(src, complete, naturalWidth)] of every <img> of the page."""
    return browser.execute_script(
        "return Array.from(document.images).map(i => [i.getAttribute('src'), i.complete, i.naturalWidth])")


def assert_pictures_render(browser, at_least):
    pictures = images(browser)
    assert len(pictures) >= at_least, pictures
    broken = [src for src, complete, width in pictures if not complete or width <= 0]
    assert not broken, f"pictures that do not render: {broken}"


def h1(browser):
    from selenium.webdriver.common.by import By
    return browser.find_element(By.TAG_NAME, "h1").text.strip().rstrip("#").strip()


def test_the_site_builds_with_warnings_as_errors_and_no_broken_internal_link(site):
    html, proc = site
    assert proc.returncode == 0, f"docs/build.py failed:\n{proc.stdout[-4000:]}\n{proc.stderr[-6000:]}"
    checked = re.search(r"internal links checked: (\d+), broken: (\d+)", proc.stdout)
    assert checked and int(checked.group(1)) > 0 and int(checked.group(2)) == 0, proc.stdout
    assert (html / "index.html").is_file()


def test_front_page_shows_its_pictures(site, browser):
    html, _ = site
    open_page(browser, html, "index.html")
    assert "nc_dolfinx" in browser.title and h1(browser) == "nc_dolfinx"
    assert_pictures_render(browser, at_least=2)  # docs/block.png and docs/hertz3d.png
    sources = " ".join(src for src, _, _ in images(browser))
    assert "block.png" in sources and "hertz3d.png" in sources, sources


def test_demo_page_shows_the_output_and_pictures_of_its_execution(site, browser):
    from selenium.webdriver.common.by import By
    html, _ = site
    open_page(browser, html, DEMO_PAGE)
    assert "setting step by step: solve, estimate, mark, refine" in h1(browser), h1(browser)
    assert_pictures_render(browser, at_least=1)
    outputs = [e.text for e in browser.find_elements(By.CSS_SELECTOR, ".demo-output")]
    assert outputs and any("checked: " in text for text in outputs), outputs[:3]
    sources = [src for src, _, _ in images(browser)]
    assert any("indicators" in src for src in sources), sources


def test_every_demo_has_a_page(site):
    html, _ = site
    for demo in sorted((ROOT / "demos").glob("demo_*.py")):
        page = html / "demos" / f"{demo.stem}.html"
        assert page.is_file() and "demo-output" in page.read_text(), page


def test_api_page_lists_every_public_name(site, browser):
    from selenium.webdriver.common.by import By
    html, _ = site
    open_page(browser, html, "api.html")
    assert h1(browser) == "API reference"
    missing = [name for name in nc.__all__
               if not browser.find_elements(By.ID, f"nc_dolfinx.{name}")
               and not browser.find_elements(By.ID, f"module-nc_dolfinx.{name}")]
    assert not missing, f"not on the API page: {missing}"
    text = browser.find_element(By.TAG_NAME, "article").text
    assert all(name in text for name in nc.__all__)


def test_verification_page_shows_the_report_and_its_pictures(site, browser):
    html, _ = site
    open_page(browser, html, "verification.html")
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", (ROOT / "verification" / "report.md").read_text())
    assert_pictures_render(browser, at_least=len(pictures))
    assert "Overall:" in browser.page_source  # the report's verdict line


def test_reference_lists_every_problem_file_key_and_output_column(site):
    """The reference pages include the tables docs/build.py generates from the schema and the output columns
    (docs/reference_tables.py): every key on reference/keys.html, every column on reference/output.html."""
    html, _ = site
    spec = importlib.util.spec_from_file_location("reference_tables", ROOT / "docs" / "reference_tables.py")
    tables = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tables)
    for what, table, page in (("keys", tables.key_table(), "reference/keys.html"),
                              ("columns", tables.column_table(), "reference/output.html")):
        text = (html / page).read_text()
        names = re.findall(r"^\| `([^`]+)` \|", table, flags=re.M)
        assert len(names) > 20, names
        missing = [name for name in names if f">{name}<" not in text]
        assert not missing, f"{what} not on {page} (it should include _generated/{what}.md): {missing}"
    without = [row.split("|")[1].strip() for row in tables.key_table().splitlines() if row.rstrip().endswith("– |")]
    assert not without, f"keys without an example (a tutorial, a case or docs/key_examples.toml): {without}"


def test_navigation_puts_the_tutorials_first_and_holds_no_dated_log(site, browser):
    """Issue 49: the tutorials are the first entry of the navigation, every tutorial page is reachable from
    it and shows its pictures; the performance archive (superseded, dated measurements) is not in it."""
    from selenium.webdriver.common.by import By
    html, _ = site
    open_page(browser, html, "index.html")
    captions = [e.get_attribute("textContent").strip().lower()
                for e in browser.find_elements(By.CSS_SELECTOR, ".sidebar-tree p.caption")]
    assert captions and captions[0] == "tutorials", captions
    links = [e.get_attribute("href") for e in browser.find_elements(By.CSS_SELECTOR, ".sidebar-tree a")]
    assert not [link for link in links if "performance-archive" in link], links
    assert (html / "performance-archive.html").is_file()  # kept, linked from the performance page
    for page in sorted((ROOT / "docs" / "src" / "tutorials").glob("*.md")):
        assert any(f"tutorials/{page.stem}.html" in link for link in links), page.name
        if page.stem != "index":
            open_page(browser, html, f"tutorials/{page.stem}.html")
            shown = re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", page.read_text())
            assert_pictures_render(browser, at_least=len(shown))
