"""Built-in cases: problem files shipped in ``nc_dolfinx/cases/``, found by name."""
from pathlib import Path

from .errors import InputError
from .problem import read_toml

CASES_DIR = Path(__file__).parent / "cases"
DEFAULT_CASE = "block"


def available():
    """{name: title} of the built-in cases."""
    return {p.stem: read_toml(p).get("title", p.stem) for p in sorted(CASES_DIR.glob("*.toml"))}


def resolve(case_or_file):
    """Path of a built-in case name or of a user's problem file."""
    path = Path(case_or_file)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise InputError(f"problem file '{case_or_file}' not found")
        return path
    builtin = CASES_DIR / f"{case_or_file}.toml"
    if not builtin.is_file():
        raise InputError(f"unknown case '{case_or_file}' (built-in cases: {', '.join(available())}; "
                         "or give a .toml problem file)")
    return builtin
