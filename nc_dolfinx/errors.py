"""The single exception type a user ever sees."""


class InputError(Exception):
    """Bad input or a failed solve, raised on every rank together: its message names the problem in one
    line (the command line prints it as ``nc_dolfinx: error: …`` and exits with status 1)."""


class UnsupportedDolfinx(ImportError):
    """The installed DOLFINx is not one nc_dolfinx runs on (raised by ``import nc_dolfinx``; the message
    names the version found and the supported ones)."""


SHOWN = 80  # characters of a user's value quoted in a message: the message stays one readable line


def brief(value, limit=SHOWN):
    """A user's value for an error message: its repr (control characters escaped), cut to ``limit``
    characters with the size of what was left out."""
    try:
        text = repr(value)
    except (RecursionError, ValueError):  # nested thousands deep; an int of more than 4300 digits
        return f"<a {type(value).__name__} too large to show>"
    return f"{text[:limit - 20]}… ({len(text)} characters)" if len(text) > limit else text


def brief_text(text, limit=SHOWN):
    """A user's text (an expression, a name) for an error message, as written: cut like :func:`brief`,
    control characters escaped."""
    text = str(text)
    shown = text if text.isprintable() else repr(text)[1:-1]
    return f"{shown[:limit - 20]}… ({len(text)} characters)" if len(shown) > limit else shown


def brief_path(path, limit=SHOWN):
    """A file or folder name for an error message: its end (the name) when it is too long to show."""
    text = brief_text(path, limit=10**6)
    return text if len(text) <= limit else f"…{text[-(limit - 20):]} ({len(str(path))} characters)"
