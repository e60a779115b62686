"""Reading problem files: TOML from disk, and ``--set KEY=VALUE`` overrides applied to the raw table.

Every failure of the file system or of TOML (a missing or unreadable file, malformed or non-UTF-8 TOML,
nesting deeper than tomllib recurses, integers of more digits than Python converts) is one
:class:`~nc_dolfinx.errors.InputError` naming the file or the ``--set`` value.
"""
import tomllib
from pathlib import Path

from ..errors import InputError, brief, brief_path, brief_text

TOO_MANY_DIGITS = "an integer of more digits than any number a problem holds (no float has them)"


def parse_value(text):
    """A ``--set`` value: TOML syntax when it parses (numbers, lists, tables, booleans), else a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise InputError(f"--set value {brief(text)} is nested too deeply") from None
    except ValueError:  # an integer of more digits than Python converts (4300)
        raise InputError(f"--set value {brief(text)}: {TOO_MANY_DIGITS}") from None


def set_dotted(table, dotted, value):
    *path, last = dotted.split(".")
    for part in path:
        table = table.setdefault(part, {})
        if not isinstance(table, dict):
            raise InputError(f"cannot set '{brief_text(dotted)}': '{brief_text(part)}' is not a table")
    table[last] = value


def apply_overrides(data, overrides):
    """Apply ``section.key=value`` overrides (the ``--set`` option) to a raw problem table."""
    for item in overrides or []:
        key, sep, value = item.partition("=")
        if item.startswith("-"):  # e.g. ["--refine", "none"]: the command line's options are not overrides
            raise InputError(f"'{brief_text(item)}' is a command-line option; an override is 'section.key=value' "
                             "(e.g. 'adapt.refine=none'; through the API also adapt(problem, refine='none'))")
        if not sep or not key.strip():
            raise InputError(f"--set expects KEY=VALUE, got '{brief_text(item)}'")
        if "." not in key.strip() and key.strip() not in ("title", "description", "steps", "pairs"):
            raise InputError(f"--set {brief_text(key.strip())}: give section.key, e.g. contact.m_n=2")
        set_dotted(data, key.strip(), parse_value(value.strip()))
    return data


def read_toml(path):
    path = Path(path)
    shown = brief_path(path)
    check_file(path, "problem file")
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"malformed TOML in '{shown}': {err}") from None
    except UnicodeDecodeError:
        raise InputError(f"problem file '{shown}' is not a text (UTF-8) TOML file") from None
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise InputError(f"problem file '{shown}' nests arrays or tables too deeply") from None
    except ValueError:  # an integer of more digits than Python converts (4300)
        raise InputError(f"problem file '{shown}': {TOO_MANY_DIGITS}") from None
    except OSError as err:
        raise InputError(f"cannot read problem file '{shown}': {err.strerror}") from None


def check_file(path, what):
    """Raise InputError unless ``path`` is a readable file (a name too long, a folder, a missing file)."""
    try:
        found = Path(path).is_file()
    except OSError as err:  # ENAMETOOLONG, ELOOP, EACCES on a parent folder
        raise InputError(f"{what} '{brief_path(path)}': {err.strerror}") from None
    if not found:
        raise InputError(f"{what} '{brief_path(path)}' not found")
