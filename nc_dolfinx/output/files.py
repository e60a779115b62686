"""Results on disk: one run per folder, each finished level written as soon as it is complete.

A :class:`ResultFolder` holds exactly one run. An existing folder is refused unless it is empty, or unless
``overwrite`` is given and its ``summary.json`` says nc_dolfinx wrote it (so ``--overwrite`` can never empty
a folder of other files); it is emptied when the new run writes its first level, so a run refused at
level 0 leaves the old results alone. Files every rank writes (XDMF/HDF5, VTU pieces) go to a staging
folder ``.partial-XXXX`` and are moved to their final names once complete (:meth:`ResultFolder.staged`);
small files rank 0 writes (JSON, CSV, PVD) are written to a temporary name and renamed. A reader therefore
never sees a half-written file, and a failed or interrupted run leaves its finished levels and no staging.

Every decision about the file system is taken by rank 0 and broadcast (:func:`on_rank0`), and errors of
files that every rank writes are gathered (:func:`on_every_rank`), so all ranks fail together with the same
one-line error naming the path.
"""
import csv
import io
import json
import os
import re
import secrets
import shutil
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import InputError

PROGRAM = "nc_dolfinx"  # summary.json "program": marks a folder --overwrite may empty
_UMASK = os.umask(0)
os.umask(_UMASK)  # (read once: mkstemp makes files 0600, results are made readable as usual)


# ResultFolder.replace's temporary name for ``NAME.SUF``: ``.NAME.<16 hex digits>.tmp.SUF`` beside it
_TEMPORARY = re.compile(r"\.(.+)\.[0-9a-f]{16}\.tmp(\.\w+)?")


def temporary_path(target):
    """Where :meth:`ResultFolder.replace` writes ``target`` before renaming it (a fresh name each call)."""
    return target.parent / f".{target.stem}.{secrets.token_hex(8)}.tmp{target.suffix}"


def temporary_of(path):
    """The name of the file that ``path`` is :meth:`ResultFolder.replace`'s temporary of, or None (a run
    killed by SIGKILL between writing and renaming a record leaves one)."""
    match = _TEMPORARY.fullmatch(Path(path).name)
    return match.group(1) + (match.group(2) or "") if match else None


def _os_error(err, what):
    reason = err.strerror or str(err)
    return f"cannot write '{what}': {reason}"


def on_rank0(comm, action, what):
    """Run ``action()`` on rank 0 and return its result on every rank; an OSError or InputError there is
    raised on every rank as one InputError (naming ``what``)."""
    result = error = None
    if comm.rank == 0:
        try:
            result = action()
        except InputError as err:
            error = str(err)
        except OSError as err:
            error = _os_error(err, what)
    if comm.size > 1:
        result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise InputError(error)
    return result


def on_every_rank(comm, action, what):
    """Run ``action()`` on every rank; the first rank's OSError is raised on every rank as InputError."""
    error = None
    try:
        action()
    except OSError as err:
        error = _os_error(err, what)
    errors = comm.allgather(error) if comm.size > 1 else [error]
    first = next((e for e in errors if e is not None), None)
    if first is not None:
        raise InputError(first)


def written_by_us(folder):
    """Whether ``folder/summary.json`` says nc_dolfinx wrote the folder."""
    try:
        return json.loads((Path(folder) / "summary.json").read_text()).get("program") == PROGRAM
    except (OSError, ValueError, AttributeError):
        return False


class ResultFolder:
    """The output folder of one run (every method is collective unless it says otherwise)."""

    def __init__(self, path, comm, overwrite=False):
        self.path, self.comm, self.overwrite = Path(path), comm, overwrite
        self.created = []        # folders this run created (removed again if it keeps nothing)
        self.claimed = False     # whether this run has written into the folder
        self.stage = None        # the staging folder while a level is being written
        self.temporary = set()   # rank 0's temporary files while they exist

    # --- before the run ---------------------------------------------------------------------------
    def check(self):
        """Refuse a folder that would mix runs or that --overwrite may not empty (read-only)."""
        on_rank0(self.comm, self._check, self.path)

    def _check(self):
        where = f"--out '{self.path}'"
        if self.path.exists() and not self.path.is_dir():
            raise InputError(f"{where} is a file, not a folder")
        ancestor = next((p for p in self.path.absolute().parents if p.exists()), None)
        if not self.path.exists() and ancestor is not None and not ancestor.is_dir():
            raise InputError(f"cannot create {where}: '{ancestor}' is a file")
        if self.path.is_dir() and any(self.path.iterdir()):
            if not self.overwrite:
                raise InputError(f"{where} is not empty (a result folder holds one run): give --overwrite "
                                 "to replace an earlier nc_dolfinx run, or another --out")
            if not written_by_us(self.path):
                raise InputError(f"{where} is not an nc_dolfinx result folder (no summary.json written by "
                                 "nc_dolfinx): --overwrite empties only those; choose another --out")

    def open(self):
        """Create the folder (and missing parents) and make sure this run can write into it."""
        self.check()
        self.created = on_rank0(self.comm, self._open, self.path)

    def _open(self):
        missing = [p for p in [self.path.absolute(), *self.path.absolute().parents] if not p.exists()]
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise InputError(f"cannot create --out '{self.path}': {err.strerror or err}") from None
        try:
            fd, probe = tempfile.mkstemp(prefix=".probe-", dir=self.path)
        except OSError as err:
            raise InputError(f"cannot write into --out '{self.path}': {err.strerror or err}") from None
        os.close(fd)
        os.unlink(probe)
        return [str(p) for p in missing]

    # --- while the run writes -------------------------------------------------------------------
    def claim(self):
        """Before the first write: empty a folder --overwrite is replacing."""
        if not self.claimed:
            on_rank0(self.comm, self._empty, self.path)
            self.claimed = True

    def _empty(self):
        self._check()  # still one of ours (or empty)
        for entry in self.path.iterdir():
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()

    @contextmanager
    def staged(self):
        """Collective: yields a staging folder (the same on every rank) for files every rank writes; on
        success they are moved to the same relative names in the folder, on failure removed."""
        self.claim()
        self.stage = Path(on_rank0(self.comm, lambda: tempfile.mkdtemp(prefix=".partial-", dir=self.path),
                                   self.path))
        try:
            yield self.stage
            self.comm.barrier()
            on_rank0(self.comm, self._publish, self.path)
        finally:
            if self.comm.rank == 0:
                self.remove_stage()
            self.stage = None

    def _publish(self):
        """Move every staged file to its final name (deepest first, so a file that names others, such as
        an .xdmf or .pvtu beside its folder, comes last)."""
        for src in sorted(self.stage.rglob("*"), key=lambda p: (-len(p.parts), str(p))):
            if src.is_file():
                dst = self.path / src.relative_to(self.stage)
                dst.parent.mkdir(parents=True, exist_ok=True)
                os.replace(src, dst)

    def remove_stage(self):
        """Remove the staging folder (not collective). Another rank may still be finishing a file in it
        when rank 0 is interrupted: try again briefly."""
        for attempt in range(3):
            if self.stage is None or not self.stage.exists():
                return
            shutil.rmtree(self.stage, ignore_errors=True)
            time.sleep(0.05 * attempt)

    def replace(self, name, write):
        """Make ``name`` by ``write(temporary path)`` and a rename (not collective: the caller's rank).
        The temporary name keeps the suffix (matplotlib chooses the format by it)."""
        target = self.path / name
        target.parent.mkdir(parents=True, exist_ok=True)
        # The name is recorded before the file exists: a Ctrl-C at any point leaves nothing untracked
        # (with mkstemp, a signal between its return and the record left the file behind).
        tmp = str(temporary_path(target))
        self.temporary.add(tmp)
        try:
            write(tmp)
            os.chmod(tmp, 0o666 & ~_UMASK)
            os.replace(tmp, target)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
            self.temporary.discard(tmp)

    # --- after a failure or an interruption (not collective) ----------------------------------------
    def remove_levels(self, first, solution):
        """Remove the files of levels ``first`` and later (and ``solution.*`` if ``solution``)."""
        numbered = ((p, re.match(r"level_(\d+)", p.name)) for p in (self.path / "levels").glob("level_*"))
        doomed = [p for p, match in numbered if match and int(match.group(1)) >= first]
        doomed += list(self.path.glob("solution.*")) if solution else []
        for path in doomed:
            if path.name == "solution.pvd":
                continue
            shutil.rmtree(path) if path.is_dir() else path.unlink(missing_ok=True)
        if (self.path / "levels").is_dir() and not any((self.path / "levels").iterdir()):
            (self.path / "levels").rmdir()

    def clean_up(self, kept):
        """Remove staging and temporary files; if the run keeps nothing (``kept`` false), also the folders
        it created. Never raises (the run is already failing)."""
        try:
            self.remove_stage()
            for tmp in list(self.temporary):
                Path(tmp).unlink(missing_ok=True)
            self._sweep_staging_leftovers()
            if not kept:
                for folder in self.created:
                    Path(folder).rmdir()
        except OSError:
            pass

    def _sweep_staging_leftovers(self):
        """A signal can arrive between a staging folder or probe being created and being recorded: remove
        anything under the folder with the names this class gives its staging and temporary files."""
        if not self.path.is_dir():
            return
        for path in [*self.path.glob(".partial-*"), *self.path.glob(".probe-*"), *self.path.rglob(".*.tmp*")]:
            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)


def text_writer(text):
    """A writer for :meth:`ResultFolder.replace`."""
    def write(path):
        with open(path, "w", newline="") as fh:
            fh.write(text)
    return write


def json_writer(data):
    return text_writer(json.dumps(data, indent=2, default=_jsonable) + "\n")


def csv_columns(rows):
    """The CSV header of history rows."""
    return list(dict.fromkeys(k for row in rows for k in _flatten(row)))


def csv_text(rows):
    """CSV of history rows; a list value (the contact force) becomes columns NAME_x, NAME_y[, NAME_z]."""
    flat = [_flatten(row) for row in rows]
    keys = csv_columns(rows)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=keys, lineterminator="\n")
    writer.writeheader()
    writer.writerows(flat)
    return buffer.getvalue()


def _flatten(row):
    flat = {}
    for key, value in row.items():
        if isinstance(value, (list, tuple, np.ndarray)):
            flat.update({f"{key}_{axis}": v for axis, v in zip("xyz", value)})
        else:
            flat[key] = value
    return flat


def _jsonable(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value)}")
