"""A normal compliance problem (paper §2, (1)–(4)), validated and independent of any mesh.

A :class:`Problem` is made from a TOML problem file (:func:`load_problem`), a built-in case, or a dict
with the same keys (:meth:`Problem.from_dict`); :mod:`nc_dolfinx.problem.schema` lists every key. Its values can
be changed with :meth:`Problem.replace` (the API's ``--set``), which validates again. Binding it to a mesh
is :func:`nc_dolfinx.physics.binding.bind`.
"""
import copy
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError, brief_path
from . import schema
from .cases import resolve
from .expressions import to_float, uses_coordinates
from .reading import apply_overrides, read_toml, set_dotted


@dataclass(frozen=True)
class Problem:
    """A validated normal compliance problem (paper §2): the body's material (Hooke's law), the loads f
    and g of (1) and (3), Γ_D of (2) — clamped, or held at a prescribed displacement u = u_D (the paper's
    u = 0 generalised, with components left free on rollers) — and c_n, m_n and the gap g_0 of the law (4) on Γ_C,
    with the adaptive loop's and the solver's settings. It holds no mesh: bind it to one with
    :func:`bind` (or let :func:`solve` / :func:`adapt` do it).

    ``values`` holds every schema key (defaults filled in, numbers as floats, expressions as written);
    ``given`` the dotted keys the problem set explicitly; ``raw`` the table as written (after overrides),
    from which :meth:`replace` revalidates. Every number of a problem reaches the forms as a
    ``fem.Constant`` (inside an expression of x, y, z too), so problems that differ only in numbers
    share their compiled forms.

    >>> problem = load_problem("block")                  # or Problem.from_dict({...}, "mine")
    >>> stiffer = problem.replace({"contact.c_n": 5e4})   # validated again; compiles nothing new
    """
    name: str
    values: dict = field(repr=False)
    given: frozenset = field(repr=False)
    raw: dict = field(repr=False)
    source: Path = None
    overrides: tuple = ()

    @classmethod
    def from_dict(cls, data, name="problem", source=None, overrides=()):
        """Validate a problem table (the keys of a problem file) and return the Problem.

        Relative mesh files are taken relative to ``source`` (the problem file), if given."""
        schema.check_depth(data, source)
        raw = copy.deepcopy(data)
        values, given = schema.validate(raw)
        _check_consistency(values, given)
        mesh = values["mesh"]
        for key in ("file", "cad"):  # relative to the problem file
            if mesh.get(key) is not None and source is not None:
                resolve = lambda name: str((Path(source).parent / name).resolve())  # noqa: E731
                mesh[key] = [resolve(f) for f in mesh[key]] if isinstance(mesh[key], list) else resolve(mesh[key])
        problem = cls(name=name, values=values, given=given, raw=raw,
                      source=Path(source) if source else None, overrides=tuple(overrides))
        problem._step_ends()  # every state a load path reaches is valid before anything runs
        return problem

    def __getitem__(self, dotted):
        """``problem["contact.c_n"]``: a value by its dotted key."""
        value = self.values
        for part in dotted.split("."):
            if not isinstance(value, dict) or part not in value:
                raise KeyError(dotted)
            value = value[part]
        return value

    def replace(self, changes=None, **sections):
        """A new Problem with some values changed, validated again: ``replace({"contact.c_n": 5})``.

        Values use the problem-file syntax (numbers, expression strings, lists, tables)."""
        raw = copy.deepcopy(self.raw)
        for dotted, value in (changes or {}).items():
            set_dotted(raw, dotted, value)
        for section, table in sections.items():
            raw.setdefault(section, {}).update(table)
        items = tuple(f"{k}={v!r}" for k, v in (changes or {}).items())
        return Problem.from_dict(raw, self.name, self.source, self.overrides + items)

    @property
    def title(self):
        """The problem's ``title``, or its name when it has none."""
        return self.values.get("title") or self.name

    @property
    def parameters(self):
        """The ``[parameters]`` table: named numbers usable in every expression."""
        return self.values["parameters"]

    @property
    def frictional(self):
        """Whether the problem has friction: on Γ_C (``contact.friction`` or ``contact.c_t`` given, μ = 0
        included) or between the faces of a pair (``pairs.friction`` given)."""
        return is_frictional(self.values["contact"], self.given) or has_pair_friction(self.values)

    def at_parameters(self, values):
        """This problem with the parameters ``values`` ({name: number}) set, their definitions replaced,
        and without its load path: one state of the path, validated again."""
        raw = copy.deepcopy(self.raw)
        raw.pop("steps", None)
        raw.setdefault("parameters", {}).update(values)
        return Problem.from_dict(raw, self.name, self.source, self.overrides)

    def load_path(self):
        """The states of the load path ([[steps]]), one per increment, in order, as :class:`LoadState` objects
        (a generator; every step's end is validated before the first is given). Each step moves the
        parameters it sets linearly from where the previous step left them, in its number of increments.
        Without steps the path is the problem itself. A step with ``increments = "auto"`` is given as one
        LoadState without an increment (``auto``, ``fraction`` None), whose :meth:`LoadState.at` makes its
        states at the fractions the solver chooses (:func:`~nc_dolfinx.adapt` sizes them)."""
        if not self.values["steps"]:
            return iter([LoadState(self, 0, 1, 1)])
        return self._increments(self.values["steps"], self._step_ends())

    def _step_ends(self):
        """The problem at the end of each step of its load path (each validated)."""
        ends, so_far = [], {}
        for number, step in enumerate(self.values["steps"], 1):
            so_far = {**so_far, **step["set"]}
            try:
                ends.append(self.at_parameters(so_far))
            except InputError as err:
                raise InputError(f"steps[{number}] leads to a bad problem: {err}") from None
        return ends

    def _increments(self, steps, ends):
        start = self.parameters
        for number, (step, end) in enumerate(zip(steps, ends), 1):
            n = step["increments"]
            if n == "auto":
                yield LoadState(end, number, 0, "auto", start={name: start[name] for name in step["set"]}, end=end)
                start = end.parameters
                continue
            for i in range(1, n):
                moved = {name: start[name] + (value - start[name]) * i / n for name, value in step["set"].items()}
                yield LoadState(end.at_parameters(moved), number, i, n)
            yield LoadState(end, number, n, n)
            start = end.parameters

    @property
    def dimension(self):
        """2 or 3 when the mesh is built in (rectangle, box); None for a mesh file."""
        mesh = self.values["mesh"]
        return 2 if mesh["rectangle"] else 3 if mesh["box"] else None

    def to_dict(self):
        """The resolved problem for ``summary.json``: every value (defaults included), the parameters,
        the overrides and the source."""
        return {"name": self.name, "title": self.title, "source": str(self.source) if self.source else None,
                "overrides": list(self.overrides), "values": copy.deepcopy(self.values),
                "given": sorted(self.given)}


@dataclass(frozen=True)
class LoadState:
    """One solve on a load path (:meth:`Problem.load_path`): the ``problem`` at this state's parameters,
    its ``step`` (1, 2, …; 0 when the problem has no [[steps]]) and its ``increment`` of ``increments``.

    On a step with ``increments = "auto"`` (``auto``) the number of increments is not known in advance: the
    state is the one at ``fraction`` of the step (1: its end, the step's parameters exactly), made by
    :meth:`at` from the step's placeholder that :meth:`Problem.load_path` gives (``fraction`` None)."""
    problem: Problem
    step: int
    increment: int
    increments: object            # a number of increments, or "auto"
    fraction: float = None        # auto: the part of the step done at this state
    start: dict = field(default=None, repr=False, compare=False)     # auto: the parameters set, at the start
    end: Problem = field(default=None, repr=False, compare=False)    # auto: the problem at the step's end

    @property
    def auto(self):
        """Whether the step sizes its own increments (``increments = "auto"``)."""
        return self.increments == "auto"

    @property
    def ends_step(self):
        """Whether this is the step's last increment (where adaptive refinement happens)."""
        return self.fraction == 1.0 if self.auto else self.increment == self.increments

    @property
    def time(self):
        """The pseudo-time along the path: step − 1 + increment / increments (the step's number at its end);
        on an auto step step − 1 + fraction."""
        return self.step - 1 + (self.fraction if self.auto else self.increment / self.increments)

    def at(self, fraction, increment):
        """An auto step's state at ``fraction`` of it (0 < fraction <= 1; 1: the step's end problem itself),
        numbered ``increment``: the parameters it sets moved linearly from their values at its start."""
        if fraction >= 1.0:
            return LoadState(self.end, self.step, increment, "auto", 1.0, self.start, self.end)
        end = self.end.parameters
        moved = {name: value + (end[name] - value) * fraction for name, value in self.start.items()}
        return LoadState(self.end.at_parameters(moved), self.step, increment, "auto", fraction, self.start, self.end)


def _check_consistency(values, given):
    """Rules that join several keys."""
    mesh = values["mesh"]
    kinds = [k for k in ("file", "rectangle", "box") if mesh[k] is not None]
    if len(kinds) > 1:
        raise InputError(f"[mesh] takes one of 'file', 'rectangle' or 'box', got {', '.join(kinds)}")
    kind = kinds[0] if kinds else None  # None: the mesh is given as a Domain (API)
    if kind not in ("rectangle", "box") and "mesh.cells" in given:
        raise InputError("mesh.cells is for mesh.rectangle or mesh.box")
    if kind in ("rectangle", "box"):
        dim = 2 if kind == "rectangle" else 3
        if len(mesh[kind][0]) != dim:
            raise InputError(f"mesh.{kind} must have {dim} coordinates per corner, got {mesh[kind]}")
        if mesh["cells"] is None:
            raise InputError(f"mesh.cells is required with mesh.{kind} ({dim} positive integers)")
        if len(mesh["cells"]) != dim:
            raise InputError(f"mesh.cells must be {dim} positive integers for mesh.{kind}, got {mesh['cells']}")
    if "mesh.diagonal" in given and kind != "rectangle":
        raise InputError("mesh.diagonal is for mesh.rectangle only")
    roles = {}
    for role in schema.ROLES:
        for group in mesh[role]:
            if group in roles and roles[group] != role:
                raise InputError(f"boundary group {group!r} is in both {roles[group]} and {role}")
            roles[group] = role

    loads = values["loads"]
    if loads["from_exact"]:
        if values["exact"]["u"] is None:
            raise InputError("loads.from_exact needs [exact] u")
        clash = [k for k in ("f", "g") if loads[k] is not None]
        if clash:
            raise InputError(f"loads.from_exact = true computes f and g from [exact] u: remove loads.{clash[0]}")
    elif loads["f"] is None and loads["g"] is None and not moves_a_support(loads["u_D"], values["parameters"]) \
            and not values["steps"]:  # (on a load path the parameters as written are not solved: its steps are)
        raise InputError("the problem has no load: give loads.f, loads.g, a non-zero loads.u_D or "
                         "loads.from_exact (with no load the solution is u = 0)")
    check_group_table(loads["g"], "loads.g", "neumann", mesh)
    check_group_table(loads["u_D"], "loads.u_D", "dirichlet", mesh)
    dim = 2 if kind == "rectangle" else 3 if kind == "box" else None
    if dim:
        check_vector_sizes(values, dim)

    contact = values["contact"]
    for key in ("c_n", "gap"):
        value = contact[key]
        if not (isinstance(value, str) and uses_coordinates(value)) \
                and to_float(value, values["parameters"]) < 0:
            raise InputError(f"contact.{key} must be >= 0, got {value}")
    if dim == 3:
        check_exponent(contact["m_n"], 3)
    _check_friction(contact, given, values["parameters"], has_pair_friction(values))

    _check_pairs(values, roles, dim, given)

    reference = values["reference"]
    if reference["hertz"] and reference["radius"] is None:
        raise InputError("reference.hertz needs reference.radius")
    check_reference(values, dim)


def _check_pairs(values, roles, dim, given):
    """[[pairs]]: each face in no other role and in one pair; c_n >= 0; something to contact at all."""
    pairs = values["pairs"]
    if "mesh.contact" not in given and not pairs:
        raise InputError("missing required key 'mesh.contact': the boundary groups of Γ_C on the foundation "
                         "(or [[pairs]] of faces of two bodies)")
    seen = {}
    for number, pair in enumerate(pairs, 1):
        for group in pair["faces"]:
            if group in roles:
                raise InputError(f"boundary group {group!r} is in both mesh.{roles[group]} and pairs[{number}].faces")
            if group in seen:
                raise InputError(f"boundary group {group!r} is a face of pairs[{seen[group]}] and pairs[{number}]: "
                                 "a face belongs to one pair")
            seen[group] = number
        for key in ("c_n", "friction"):
            value = pair[key]
            if value is not None and not (isinstance(value, str) and uses_coordinates(value)) \
                    and to_float(value, values["parameters"]) < 0:
                raise InputError(f"pairs[{number}].{key} must be >= 0, got {value}")
        if dim == 3:
            check_exponent(pair["m_n"], 3)


def _check_friction(contact, given, parameters, pairs_frictional=False):
    """Friction is given as Coulomb's μ (``friction``) or as the bound c_t (u_n − g_0)_+^m_t, not both."""
    if "contact.friction" in given and ("contact.c_t" in given or "contact.m_t" in given):
        raise InputError("give contact.friction (Coulomb: c_t = μ c_n, m_t = m_n) or contact.c_t with "
                         "contact.m_t, not both")
    if ("contact.c_t" in given) != ("contact.m_t" in given):
        missing = "m_t" if "contact.c_t" in given else "c_t"
        raise InputError(f"contact.{missing} is missing: the friction bound c_t (u_n − g_0)_+^m_t needs both "
                         "contact.c_t and contact.m_t")
    if "contact.slip_regularisation" in given and not is_frictional(contact, given) and not pairs_frictional:
        raise InputError("contact.slip_regularisation has no effect without friction (contact.friction or "
                         "contact.c_t)")
    for key in ("friction", "c_t"):
        value = contact[key]
        if value is not None and not (isinstance(value, str) and uses_coordinates(value)) \
                and to_float(value, parameters) < 0:
            shown = value if not isinstance(value, str) or value.strip() == f"{to_float(value, parameters):g}" \
                else f"'{value}' = {to_float(value, parameters):g}"
            raise InputError(f"contact.{key} must be >= 0, got {shown}")


def has_pair_friction(values):
    """Whether a [[pairs]] entry gives ``friction`` (μ = 0 included)."""
    return any(pair["friction"] is not None for pair in values.get("pairs", ()))


def is_frictional(contact, given):
    """Whether the problem has friction on Γ_C (``contact.friction`` or ``contact.c_t`` given; μ = 0 included)."""
    return "contact.friction" in given or "contact.c_t" in given


def check_group_table(table, key, role, mesh):
    """A per-group table of loads (``loads.g``, ``loads.u_D``) names groups of its role only; a single
    vector needs at least one group of that role."""
    if isinstance(table, list) and not mesh[role]:
        raise InputError(f"{key} is given but mesh.{role} lists no group")
    for group in table if isinstance(table, dict) else ():
        if group not in [str(g) for g in mesh[role]]:
            other = next((r for r in schema.ROLES if group in [str(g) for g in mesh[r]]), None)
            where = f"it is a {other} group" if other else "it is in no role"
            raise InputError(f"{key} has an entry for '{group}', which is not a {role} group ({where}; "
                             f"{role} = {mesh[role]})")


def moves_a_support(u_D, parameters):
    """Whether a prescribed displacement (``loads.u_D``) may be non-zero: then it loads the body."""
    vectors = u_D.values() if isinstance(u_D, dict) else [u_D] if u_D else []
    components = [c for vector in vectors for c in vector if c != schema.FREE]
    return any(uses_coordinates(c) or to_float(c, parameters) != 0 for c in map(str, components))


def check_reference(values, dim):
    """Hertz's line contact is a 2D reference, the sphere's a 3D one."""
    hertz = values["reference"]["hertz"]
    if hertz == "sphere" and dim == 2 or hertz == "line" and dim == 3:
        raise InputError(f"reference.hertz = '{hertz}' does not fit a {dim}D mesh (line: 2D, sphere: 3D)")


def check_vector_sizes(values, dim):
    """Every vector of the problem has one component per coordinate of the mesh."""
    loads, exact = values["loads"], values["exact"]
    vectors = [("loads.f", loads["f"]), ("exact.u", exact["u"])]
    for key in ("g", "u_D"):
        table = loads[key]
        vectors += [(f"loads.{key}", table)] if isinstance(table, list) else \
            [(f"loads.{key}.{k}", v) for k, v in (table or {}).items()]
    for where, vector in vectors:
        if vector is not None and len(vector) != dim:
            raise InputError(f"{where} has {len(vector)} components but the mesh is {dim}D: "
                             f"give {dim} expressions")


def check_exponent(m_n, dim):
    """In 3D, H^{1/2}(Γ_C) embeds in L⁴ only: the law's operator is defined on H¹ for 1 <= m_n <= 3."""
    if dim == 3 and m_n > 3:
        raise InputError(f"contact.m_n = {m_n:g} > 3 on a 3D mesh: the compliance term (u_n)_+^m_n v_n is "
                         "integrable for every u, v in H¹ only if m_n <= 3 (H^1/2(Γ_C) ⊂ L⁴ in 3D)")


def load_problem(source, overrides=(), name=None):
    """A :class:`Problem` from a built-in case name (:func:`case_names`) or a TOML problem file, with
    ``--set``-style overrides ``"section.key=value"`` (TOML syntax for the value). Raises
    :class:`InputError` naming the key for a bad or unknown entry.

    >>> problem = load_problem("block", ["contact.m_n=2"])
    """
    path = resolve(source)
    data = read_toml(path)
    if not data:
        raise InputError(f"problem file '{brief_path(path)}' is empty: a problem needs at least [mesh] (with "
                         "contact), [material] and [contact]")
    data = apply_overrides(data, overrides)
    return Problem.from_dict(data, name or path.stem, source=path, overrides=tuple(overrides))
