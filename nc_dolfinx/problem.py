"""Problem definition: the TOML problem file, its validation, and its fields on a mesh.

A :class:`Problem` is the validated, mesh-independent description of the normal compliance problem
(paper §2, (1)–(4)): materials, loads f and g, the contact law parameters c_n, m_n and the optional
initial gap g_0, the boundary groups of Γ_D, Γ_N, Γ_C, and solver settings. :func:`bind` turns it into
:class:`Fields` — the UFL coefficients on one particular mesh — which is redone after every refinement.
"""
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx import fem

from . import meshes
from .errors import InputError
from .expressions import to_float, to_ufl, to_ufl_vector

SECTIONS = {"title", "description", "parameters", "mesh", "material", "loads", "contact", "exact",
            "solver", "adapt", "estimator", "reference"}


@dataclass
class Problem:
    name: str
    source: Path = None
    parameters: dict = field(default_factory=dict)
    mesh: dict = field(default_factory=dict)
    dirichlet: list = field(default_factory=list)
    neumann: list = field(default_factory=list)
    contact: list = field(default_factory=list)
    E: float = 1.0
    nu: float = 0.3
    regions: dict = field(default_factory=dict)  # region name -> (E, nu)
    f: list = field(default_factory=lambda: ["0", "0"])
    g: dict = field(default_factory=dict)  # Neumann group name -> [gx, gy]; "*" for all
    loads_from_exact: bool = False
    c_n: object = "1"
    m_n: float = 1.0
    gap: object = "0"
    exact_u: list = None
    petsc_options: dict = field(default_factory=dict)
    preset: str = "auto"
    preconditioner_matrix: str = "auto"
    load_steps: int = 1
    adapt: dict = field(default_factory=dict)
    estimator: dict = field(default_factory=dict)
    reference: dict = field(default_factory=dict)
    title: str = ""

    @property
    def lame(self):
        """Plane strain Lamé coefficients (λ, μ) of the default material."""
        return lame(self.E, self.nu)


def lame(E, nu):
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


# --- reading ------------------------------------------------------------------------------------

def _parse_value(text):
    """A ``--set`` value: TOML syntax when it parses (numbers, lists, booleans), else a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(data, overrides):
    """Apply ``section.key=value`` overrides (the ``--set`` option) to the raw TOML table."""
    for item in overrides or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--set expects KEY=VALUE, got '{item}'")
        *path, last = key.strip().split(".")
        table = data
        for part in path:
            table = table.setdefault(part, {})
            if not isinstance(table, dict):
                raise InputError(f"--set {key}: '{part}' is not a table")
        table[last] = _parse_value(value.strip())
    return data


def read_toml(path):
    path = Path(path)
    if not path.is_file():
        raise InputError(f"problem file '{path}' not found")
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"malformed TOML in '{path}': {err}") from None


def _table(data, key):
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise InputError(f"[{key}] must be a table")
    return value


def _groups(mesh_table, key):
    value = mesh_table.get(key, [])
    if isinstance(value, (str, int)):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, (str, int)) for v in value):
        raise InputError(f"mesh.{key} must be a list of group names or integer tags, got {value!r}")
    return value


def _parameters(table):
    """[parameters]: numbers or expressions of the parameters defined before them."""
    values = {}
    for name, text in table.items():
        if name in ("x", "y", "pi") or not name.isidentifier():
            raise InputError(f"parameter name '{name}' is not allowed")
        values[name] = to_float(text, values)
    return values


def problem_from_data(data, name, source=None):
    """Validate the raw TOML table and return a :class:`Problem`."""
    unknown = set(data) - SECTIONS
    if unknown:
        raise InputError(f"unknown section(s) {sorted(unknown)} in problem '{name}'")
    params = _parameters(_table(data, "parameters"))
    mesh_t, mat, loads = _table(data, "mesh"), _table(data, "material"), _table(data, "loads")
    contact, exact, solver = _table(data, "contact"), _table(data, "exact"), _table(data, "solver")
    if ("file" in mesh_t) == ("rectangle" in mesh_t):
        raise InputError("[mesh] needs exactly one of 'file' or 'rectangle'")
    if "file" in mesh_t and source is not None:
        mesh_t = dict(mesh_t, file=str((Path(source).parent / mesh_t["file"]).resolve()))
    p = Problem(name=name, source=source, parameters=params, mesh=mesh_t, title=data.get("title", name))
    p.dirichlet, p.neumann, p.contact = (_groups(mesh_t, k) for k in ("dirichlet", "neumann", "contact"))
    roles = {}
    for role in ("dirichlet", "neumann", "contact"):
        for group in getattr(p, role):
            if group in roles:
                raise InputError(f"boundary group '{group}' is in both {roles[group]} and {role}")
            roles[group] = role

    p.E, p.nu = (to_float(mat.get(k, d), params) for k, d in (("E", 1.0), ("nu", 0.3)))
    _check_material("material", p.E, p.nu)
    for region, values in mat.get("regions", {}).items():
        if not isinstance(values, dict):
            raise InputError(f"material.regions.{region} must be a table with E and nu")
        E, nu = (to_float(values.get(k, d), params) for k, d in (("E", p.E), ("nu", p.nu)))
        _check_material(f"material.regions.{region}", E, nu)
        p.regions[region] = (E, nu)

    p.loads_from_exact = bool(loads.get("from_exact", False))
    p.f = loads.get("f", ["0", "0"])
    g = loads.get("g", ["0", "0"])
    p.g = {"*": g} if isinstance(g, list) else dict(g)
    for group in p.g:
        if group != "*" and group not in p.neumann:
            raise InputError(f"loads.g has an entry for '{group}', which is not a neumann group")

    p.m_n = to_float(contact.get("m_n", 1.0), params)
    if p.m_n < 1:
        raise InputError(f"contact.m_n must be >= 1 (paper §2), got {p.m_n}")
    p.c_n, p.gap = contact.get("c_n", 1.0), contact.get("gap", 0.0)
    for key in ("c_n", "gap"):
        value = getattr(p, key)
        if _is_number(value, params) and to_float(value, params) < 0:
            raise InputError(f"contact.{key} must be >= 0, got {value}")

    p.exact_u = exact.get("u")
    if p.loads_from_exact and p.exact_u is None:
        raise InputError("loads.from_exact needs [exact] u")
    p.petsc_options = dict(solver.get("petsc_options", {}))
    p.preset = solver.get("preset", "auto")
    if p.preset not in ("auto", "direct", "iterative"):
        raise InputError(f"solver.preset must be 'auto', 'direct' or 'iterative', got '{p.preset}'")
    p.preconditioner_matrix = solver.get("preconditioner_matrix", "auto")
    if p.preconditioner_matrix not in ("auto", "bulk", "jacobian"):
        raise InputError("solver.preconditioner_matrix must be 'auto', 'bulk' or 'jacobian', "
                         f"got '{p.preconditioner_matrix}'")
    try:
        p.load_steps = int(solver.get("load_steps", 1))
    except (TypeError, ValueError):
        raise InputError(f"solver.load_steps must be an integer, got {solver.get('load_steps')!r}") from None
    if p.load_steps < 1:
        raise InputError(f"solver.load_steps must be >= 1, got {p.load_steps}")
    p.adapt, p.estimator = _table(data, "adapt"), _table(data, "estimator")
    p.reference = _table(data, "reference")
    return p


def _is_number(value, params):
    try:
        to_float(value, params)
        return True
    except InputError:
        return False


def _check_material(where, E, nu):
    if E <= 0:
        raise InputError(f"{where}: E must be > 0, got {E}")
    if not -1 < nu < 0.5:
        raise InputError(f"{where}: nu must lie in (-1, 0.5), got {nu}")


def load_problem(path, overrides=(), name=None):
    path = Path(path)
    data = apply_overrides(read_toml(path), overrides)
    return problem_from_data(data, name or path.stem, source=path)


# --- the problem on a mesh ------------------------------------------------------------------------

def build_domain(problem, comm):
    spec = problem.mesh
    if "rectangle" in spec:
        return meshes.rectangle(comm, spec["rectangle"], spec.get("cells", [16, 8]),
                                spec.get("diagonal", "right"))
    path = Path(spec["file"])
    if not path.is_file():
        raise InputError(f"mesh file '{path}' not found")
    return meshes.from_gmsh(comm, path)


@dataclass
class Fields:
    """UFL data of a problem on one mesh (rebuilt after each refinement)."""
    domain: meshes.Domain
    lmbda: object
    mu: object
    f: object
    g: dict  # group id -> UFL traction (untagged boundary: absent, g = 0)
    c_n: object
    m_n: float
    gap: object
    u_exact: object
    ids: dict  # role -> tuple of group ids
    ds: object

    def ds_of(self, role):
        """Measure over all facets of a role ('dirichlet', 'neumann', 'contact')."""
        return sum((self.ds(i) for i in self.ids[role][1:]), self.ds(self.ids[role][0]))


def _group_id(domain, group, role):
    if isinstance(group, int):
        if group not in domain.facet_groups.values():
            raise InputError(f"{role} group {group} is not a boundary tag of the mesh")
        return group
    if group not in domain.facet_groups:
        raise InputError(f"{role} group '{group}' is not in the mesh (groups: "
                         f"{', '.join(sorted(domain.facet_groups))})")
    return domain.facet_groups[group]


def _material_field(domain, problem, which):
    """DG0 field of E or nu: the default value, overridden on named regions."""
    V0 = domain.region.function_space
    out = fem.Function(V0)
    out.x.array[:] = getattr(problem, which)
    for region, values in problem.regions.items():
        if region not in domain.cell_groups:
            raise InputError(f"material region '{region}' is not a cell group of the mesh "
                             f"(groups: {', '.join(sorted(domain.cell_groups))})")
        mask = np.isclose(domain.region.x.array, domain.cell_groups[region])
        out.x.array[mask] = values[0] if which == "E" else values[1]
    return out


def sigma(u, lmbda, mu):
    """Plane strain Hooke's law σ(u) = 2μ ε(u) + λ tr ε(u) I."""
    eps = ufl.sym(ufl.grad(u))
    return 2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(2)


def bind(problem, domain):
    """The problem's UFL fields on ``domain``; checks groups, Γ_D, Γ_C and the signs of c_n and g_0."""
    msh, params = domain.mesh, problem.parameters
    ids = {role: tuple(sorted({_group_id(domain, g, role) for g in getattr(problem, role)}))
           for role in ("dirichlet", "neumann", "contact")}
    counts = _facet_counts(domain)
    for role, symbol in (("dirichlet", "Γ_D"), ("contact", "Γ_C")):
        if sum(counts.get(i, 0) for i in ids[role]) == 0:
            raise InputError(f"{symbol} ({role}) is empty: no boundary facet in groups {getattr(problem, role)}")
    listed_neumann = ids["neumann"]  # a traction given for all of Γ_N applies to these only
    ids["neumann"] = ids["neumann"] + ((meshes.UNTAGGED,) if counts.get(meshes.UNTAGGED, 0) else ())
    # Groups of the mesh in no role are traction-free Neumann boundary, like untagged facets.
    in_roles = set(sum(ids.values(), ()))
    free = tuple(i for i in domain.facet_groups.values() if i not in in_roles and counts.get(i, 0))
    ids["neumann"] = tuple(sorted(ids["neumann"] + free))

    if problem.regions:
        E, nu = _material_field(domain, problem, "E"), _material_field(domain, problem, "nu")
        lmbda, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    else:
        lmbda, mu = (fem.Constant(msh, PETSc.ScalarType(v)) for v in problem.lame)

    u_exact = to_ufl_vector(problem.exact_u, msh, params, "exact.u") if problem.exact_u else None
    id_of_name = {name: i for name, i in domain.facet_groups.items()}
    if problem.loads_from_exact:
        n = ufl.FacetNormal(msh)
        f = -ufl.div(sigma(u_exact, lmbda, mu))
        g = {i: sigma(u_exact, lmbda, mu) * n for i in ids["neumann"]}
    else:
        f = to_ufl_vector(problem.f, msh, params, "loads.f")
        g = {}
        for group, vec in problem.g.items():
            value = to_ufl_vector(vec, msh, params, f"loads.g[{group}]")
            targets = listed_neumann if group == "*" \
                else [id_of_name.get(group, group)]
            for i in targets:
                g[i] = value
    ds = ufl.Measure("ds", domain=msh, subdomain_data=domain.facet_tags)
    fields = Fields(domain, lmbda, mu, f, g, to_ufl(problem.c_n, msh, params), problem.m_n,
                    to_ufl(problem.gap, msh, params), u_exact, ids, ds)
    _check_nonnegative_on_contact(fields, "c_n", fields.c_n)
    _check_nonnegative_on_contact(fields, "gap", fields.gap)
    return fields


def _facet_counts(domain):
    """Global number of exterior facets per group id."""
    tags = domain.facet_tags
    n_owned = domain.mesh.topology.index_map(1).size_local
    values = tags.values[tags.indices < n_owned]
    local = {int(i): int(np.count_nonzero(values == i)) for i in np.unique(values)}
    merged = {}
    for counts in domain.comm.allgather(local):
        for key, c in counts.items():
            merged[key] = merged.get(key, 0) + c
    return merged


def _check_nonnegative_on_contact(fields, name, expr):
    """c_n and g_0 must be >= 0 on Γ_C: checked at the P1 nodes of the contact facets."""
    domain = fields.domain
    V = fem.FunctionSpace(domain.mesh, ("CG", 1))
    points = V.element.interpolation_points
    points = points() if callable(points) else points
    values = fem.Function(V)
    values.interpolate(fem.Expression(expr, points))
    tags = domain.facet_tags
    facets = tags.indices[np.isin(tags.values, fields.ids["contact"])]
    dofs = fem.locate_dofs_topological(V, 1, facets)
    local_min = values.x.array[dofs].min() if len(dofs) else np.inf
    if domain.comm.allreduce(local_min, MPI.MIN) < 0:
        raise InputError(f"contact.{name} must be >= 0 on Γ_C, but it is negative somewhere on it")
