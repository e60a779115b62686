"""One case of the command line: the adaptive loop, with every finished level on disk as it completes.

After each level (``on_level``) the level's files are written (``levels/level_NN.xdmf``, the VTU piece
files and ``levels/level_NN.pvtu``, ``solution.xdmf`` on the last level) and ``history.csv``,
``history.json``, ``solution.pvd`` and ``summary.json`` are rewritten with ``"status": "running"`` and the
levels so far. A run that fails or is interrupted keeps its finished levels, and its summary says where and
why it stopped (``"status": "failed" | "interrupted"``); a completed run's summary says why the loop stopped
(``stop_reason``). The user's PETSc options are checked once level 0 is solved (:mod:`petsc_options`).

On a load path ([[steps]]) each row also gets the path's parameters (``param_NAME``,
:func:`~nc_dolfinx.output.columns.path_parameters`), ``load_path.png`` is drawn beside ``convergence.png``
(:func:`~nc_dolfinx.output.plots.load_path_plot`, against ``output.load_path_x``), and
``output.write_every`` = n (``--write-every``) writes the files of every n-th state only (:meth:`CaseRun.written`).
"""
import dataclasses
import time

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

from ..errors import InputError
from ..output import columns, files, postprocess, provenance, vtu
from ..solver import petsc_options
from . import interrupt

DOUBTFUL_FRACTION = 0.1  # penetration or |u| beyond this part of the body's diameter: warn


class CaseRun:
    """The run of one problem into one result folder."""

    def __init__(self, problem, settings, out, args, cli_options, comm, say):
        self.problem, self.settings, self.args, self.comm, self.say = problem, settings, args, comm, say
        self.cli_options = cli_options
        self.folder = files.ResultFolder(out, comm, overwrite=args.overwrite)
        self.history, self.steps, self.warnings, self.doubtful = [], [], [], set()
        self.petsc = {"problem_file": dict(problem["solver.petsc_options"]), "command_line": dict(cli_options)}
        self.stage_name = "level 0"
        self.stop_reason = self.reason = self.diameter = self.notes = self.kept = None
        self.solution_level = None  # the level whose files solution.xdmf/.h5 are
        self.step_ends = problem._step_ends() if problem["steps"] else None  # (for the param_NAME columns)
        self.write_every = problem["output.write_every"]
        self.versions = provenance.versions()
        self.start = time.perf_counter()

    @property
    def out(self):
        return self.folder.path

    # --- the run ------------------------------------------------------------------------------------
    def run(self):
        """Solve, estimate and refine level by level; returns the adaptive Result."""
        self.folder.open()
        try:
            result = nc.adapt(self.problem, self.settings, comm=self.comm,
                                    petsc_options=self.cli_options, on_level=self.on_level)
            self.stop_reason, self.reason = result.stop_reason, self.stop_text(result)
            if self.problem["reference.hertz"] and not nc.compare_with_reference(self.problem, result.history[-1]):
                self.warn("reference.hertz: the contact force is zero (the body does not touch the foundation): "
                          "there is no Hertz contact to compare with")
            histories = {self.settings.refine: result.history}
            if self.args.compare_uniform:
                self.stage_name = "the uniform refinement for comparison"
                histories["uniform"] = self.compare_uniform(result.history)
            self.stage_name = "writing the results"
            self.history = result.history  # the same rows, now with each level's output time
            self.plot(histories)
            self.write_records("completed")  # last: "completed" means every file is there
            return result
        except BaseException as err:
            self.stopped(err)
            raise

    def on_level(self, level):
        interrupt.check(self.comm)  # a signal that reached only some ranks stops all of them here
        if level.number == 0:
            self.first_level(level)
        level.row["max_displacement"] = max_displacement(level.u)
        level.row.update(columns.path_parameters(self.problem, level.row, self.step_ends))
        self.check_doubtful(level.number, level.row)
        self.write_level(level)
        self.history.append(level.row)
        self.notes = level.fields.notes
        self.stage_name = f"level {level.number + 1}"
        if "step" in level.row:  # on a load path
            self.stage_name += f", after step {level.row['step']} increment {level.row['increment']}"
        self.write_records("running")

    def first_level(self, level):
        """Once level 0 is solved every option the solver reads has been read: refuse unused ones."""
        user = {**self.petsc["problem_file"], **self.cli_options}
        allow = self.args.allow_unused_petsc_options
        for text in files.on_rank0(self.comm, lambda: petsc_options.check_user_options(user, allow), "PETSc"):
            self.warn(text)
        self.petsc["in_effect"] = petsc_options.options_in_effect()
        self.diameter = body_diameter(level.u.function_space.mesh)
        for text in level.fields.warnings:
            self.warn(text)

    def check_doubtful(self, number, row):
        limit = DOUBTFUL_FRACTION * self.diameter
        for key, what in (("max_penetration", "penetration"), ("max_displacement", "|u|")):
            if row.get(key, 0.0) > limit and key not in self.doubtful:
                self.doubtful.add(key)
                self.warn(f"level {number}: max {what} = {row[key]:.4g} is more than a tenth of the body's "
                          f"diameter ({self.diameter:.4g}): a small-deformation model is doubtful here "
                          "(check units, loads and c_n)")

    def warn(self, text):
        self.warnings.append(text)
        self.say(f"nc_dolfinx: warning: {text}")

    def written(self, level):
        """Whether the level's files are written (``output.write_every`` = n): without [[steps]] every n-th
        level and the last; on a load path the increments numbered a multiple of n in their step, and each
        step's last state (every level of it: its load_time is the step's number)."""
        row, n = level.row, self.write_every
        if n == 1 or level.stop_reason:
            return True
        if "step" not in row:
            return level.number % n == 0
        return row["increment"] % n == 0 or row["load_time"] == row["step"]

    def write_level(self, level):
        if not self.written(level):
            return
        u, est = level.u, level.estimate
        msh = u.function_space.mesh
        stress, von_mises, pressure = postprocess.postprocess_fields(u, level.fields)
        frictional = postprocess.friction_fields(u, level.fields)
        paired, body = postprocess.pair_fields(u, level.fields)
        name = f"level_{level.number:02d}"
        n_owned = msh.topology.index_map(msh.topology.dim).size_local
        region = vtu.dg0_values(level.fields.domain.region, n_owned)[:, 0].astype(np.int32)
        with self.folder.staged() as stage:
            files.on_rank0(self.comm, lambda: (stage / "levels").mkdir(), stage / "levels")
            postprocess.write_xdmf(self.comm, stage / "levels" / f"{name}.xdmf", msh, [u, *est.fields.values()])
            vtu.write(self.comm, stage / "levels", name, {"displacement": u, "contact_pressure": pressure,
                                                          **{f.name: f for f in frictional + paired}},
                      {"stress": stress, "von_mises": von_mises, **est.fields},
                      {"region": region, **({"body": body} if body is not None else {})})
            if level.stop_reason:  # the last level: the final solution with every field
                postprocess.write_xdmf(self.comm, stage / "solution.xdmf", msh,
                                       [u, stress, von_mises, pressure, *frictional, *paired, *est.fields.values()])
        if level.stop_reason:
            self.solution_level = level.number
        if "load_time" not in level.row:  # a time step per level, or, on a load path, per state
            self.steps.append((level.number, level.number, f"levels/{name}.pvtu"))
        elif level.last_of_state:
            self.steps.append((level.number, level.row["load_time"], f"levels/{name}.pvtu"))

    def compare_uniform(self, history):
        """Uniform refinement up to the adaptive run's last dofs (history_uniform.*)."""
        uniform = dataclasses.replace(self.settings, refine="uniform",
                                      max_dofs=min(self.settings.max_dofs or history[-1]["dofs"],
                                                   history[-1]["dofs"]))
        if not self.args.quiet:
            self.say("  uniform refinement for comparison:")
        rows = nc.adapt(self.problem, uniform, comm=self.comm, petsc_options=self.cli_options).history
        files.on_rank0(self.comm, lambda: (
            self.folder.replace("history_uniform.json", files.json_writer(rows)),
            self.folder.replace("history_uniform.csv", files.text_writer(files.csv_text(rows)))), self.out)
        return rows

    def plot(self, histories):
        from ..output.plots import convergence_plot, load_path_plot
        title = self.problem.title.split(":")[0]
        files.on_rank0(self.comm, lambda: self.folder.replace(
            "convergence.png", lambda path: convergence_plot(path, {k: final_state(rows) for k, rows in histories.items()},
                                                             title)), self.out / "convergence.png")
        rows = histories[self.settings.refine]
        if rows and "step" in rows[-1]:  # a load path: its forces against the load time or a parameter
            x = self.problem["output.load_path_x"]
            files.on_rank0(self.comm, lambda: self.folder.replace(
                "load_path.png", lambda path: load_path_plot(path, rows, x if x == "load_time" else f"param_{x}",
                                                             title)), self.out / "load_path.png")

    # --- records -------------------------------------------------------------------------------------
    def write_records(self, status):
        """Collective (rank 0 writes): history, the ParaView collection and, last, the summary."""
        files.on_rank0(self.comm, lambda: self.write_records_here(status), self.out)

    def write_records_here(self, status):
        """The records, written by the calling rank alone."""
        folder = self.folder
        folder.replace("history.json", files.json_writer(self.history))
        folder.replace("history.csv", files.text_writer(files.csv_text(self.history)))
        folder.replace("solution.pvd", lambda path: vtu.write_pvd(path, [step[1:] for step in self.steps]))
        folder.replace("summary.json", files.json_writer(self.summary(status)))

    def summary(self, status):
        last = self.history[-1] if self.history else {}
        data = {
            "program": files.PROGRAM, "version": nc.__version__, "status": status,
            "reason": self.reason, "stop_reason": self.stop_reason if status == "completed" else None,
            "stopped_at_level": {"completed": last.get("level"), "running": None}.get(status, len(self.history)),
            "problem": self.problem.name, "title": self.problem.title, "source": str(self.problem.source),
            "ranks": self.comm.size, "refine": self.settings.refine, "levels": len(self.history),
            "m_n": self.problem["contact.m_n"], "notes": self.notes or [], "warnings": self.warnings,
            **last,
            "time_total": time.perf_counter() - self.start,
        }
        if status == "completed":
            data["reference"] = [{"quantity": q, "computed": c, "reference": r}
                                 for q, c, r in nc.compare_with_reference(self.problem, last)]
        data.update({
            "settings": dataclasses.asdict(self.settings), "resolved": self.problem.to_dict(),
            "petsc_options": self.petsc, "versions": self.versions,
            "command": provenance.command_line(self.comm),
            "columns": {key: columns.describe(key) for key in files.csv_columns(self.history)},
            "sign_conventions": columns.SIGN_CONVENTIONS,
        })
        return data

    def stop_text(self, result):
        """Why the loop stopped, in words (printed and in summary.json ``reason``)."""
        row, s = result.history[-1], self.settings
        eta0 = result.history[0]["eta"]
        texts = {"levels": lambda: (f"the last level (levels = {s.levels})" if s.refine != "none"
                                    else "a single level (refine = none)"),
                 "max_dofs": lambda: f"dofs = {row['dofs']} >= max_dofs = {s.max_dofs}",
                 "tol": lambda: f"η = {row['eta']:.4g} <= tol = {s.tol:g}",
                 "rtol": lambda: f"η = {row['eta']:.4g} <= rtol·η_0 = {s.rtol:g}·{eta0:.4g}"}
        if "step" in row:  # (a load path's rows are increments, not levels)
            return f"{texts[result.stop_reason]()} at step {row['step']}, increment {row['increment']} (row {row['level']})"
        return f"{texts[result.stop_reason]()} at level {row['level']}"

    # --- failure and interruption ------------------------------------------------------------------
    def stopped(self, err):
        """Keep the finished levels with a summary saying where and why the run stopped, remove staging
        and temporary files. Not collective: rank 0 does it, or any rank that met an internal error (its
        peers may be waiting in a collective)."""
        interrupted = isinstance(err, KeyboardInterrupt) or interrupt.received()
        internal = not interrupted and not isinstance(err, InputError)
        if self.comm.rank != 0 and not internal:
            return
        status = "interrupted" if interrupted else "failed"
        if interrupted:
            self.reason = f"interrupted ({interrupt.received() or 'signal'}) during {self.stage_name}"
        else:
            self.reason = f"{self.stage_name}: {str(err).splitlines()[0] if str(err) else type(err).__name__}"
            if internal:
                self.reason = f"{self.stage_name}: internal error: {type(err).__name__}: {err}"
        # An interruption may fall between a level's files and its record: drop what is not recorded.
        unrecorded_solution = self.solution_level is None or self.solution_level >= len(self.history)
        self.steps = [step for step in self.steps if step[0] < len(self.history)]
        try:
            self.folder.remove_stage()
            self.folder.remove_levels(len(self.history), solution=unrecorded_solution)
            if self.history:
                self.write_records_here(status)
        except (OSError, TypeError, ValueError):
            pass
        self.folder.clean_up(kept=bool(self.history))
        self.kept = (f"levels 0–{len(self.history) - 1} kept in {self.out} (summary.json: status "
                     f"'{status}')") if self.history else None


def final_state(rows):
    """The levels of a load path's last state (every row when there is no path): the convergence plot's."""
    if not rows or "load_time" not in rows[-1]:
        return rows
    return [row for row in rows if row["load_time"] == rows[-1]["load_time"]]


def max_displacement(u):
    """max over the vertices of |u| (collective)."""
    bs = u.function_space.dofmap.index_map_bs
    n_owned = u.function_space.dofmap.index_map.size_local
    local = np.linalg.norm(u.x.array.reshape(-1, bs)[:n_owned], axis=1)
    return u.function_space.mesh.comm.allreduce(float(local.max(initial=0.0)), MPI.MAX)


def body_diameter(msh):
    """Diagonal of the mesh's bounding box (collective)."""
    x = msh.geometry.x[:, :msh.geometry.dim]
    lo = x.min(axis=0) if len(x) else np.full(msh.geometry.dim, np.inf)
    hi = x.max(axis=0) if len(x) else np.full(msh.geometry.dim, -np.inf)
    glo, ghi = np.empty_like(lo), np.empty_like(hi)
    msh.comm.Allreduce(lo, glo, op=MPI.MIN)
    msh.comm.Allreduce(hi, ghi, op=MPI.MAX)
    return float(np.linalg.norm(ghi - glo))
