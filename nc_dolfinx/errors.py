"""The single exception type a user ever sees."""


class InputError(Exception):
    """Bad input or a failed solve: the CLI prints ``str(err)`` as one line and exits non-zero."""
