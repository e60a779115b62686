"""Built-in cases: problem files shipped in ``nc_dolfinx/cases/``, found by name."""
from pathlib import Path

from ..errors import InputError, brief_text
from .reading import check_file, read_toml

CASES_DIR = Path(__file__).parents[1] / "cases"


def case_titles():
    """The built-in cases as {name: title}, the title being the first line of each problem file."""
    return {p.stem: read_toml(p).get("title", p.stem) for p in sorted(CASES_DIR.glob("*.toml"))}


def case_names():
    """The names of the built-in cases (problem files shipped in ``nc_dolfinx/cases/``), for
    :func:`load_problem`."""
    return sorted(p.stem for p in CASES_DIR.glob("*.toml"))


def case_path(name):
    """The path of a built-in case's problem file (a TOML file to read or copy); :class:`InputError`
    for an unknown name."""
    return resolve(name) if (CASES_DIR / f"{name}.toml").is_file() else _unknown(name)


def resolve(case_or_file):
    """Path of a built-in case name or of a user's problem file."""
    path = Path(case_or_file)
    if path.suffix == ".toml" or len(path.parts) > 1 or _exists(path):
        check_file(path, "problem file")
        return path
    builtin = CASES_DIR / f"{case_or_file}.toml"
    return builtin if builtin.is_file() else _unknown(case_or_file)


def _exists(path):
    try:
        return path.exists()
    except OSError:  # a name too long: it is no case name either
        return True


def _unknown(name):
    import difflib
    close = difflib.get_close_matches(str(name), case_names(), n=1)
    raise InputError(f"unknown case '{brief_text(name)}'" + (f" (did you mean '{close[0]}'?)" if close else "")
                     + f" (built-in cases: {', '.join(case_names())}; or give a .toml problem file)")
