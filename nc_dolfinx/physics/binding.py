"""A problem bound to a mesh: its data as UFL coefficients, its boundary parts as measures and conditions.

:func:`bind` is redone on every mesh of the adaptive loop. Every value written in the problem becomes a
``fem.Constant`` (or a DG0 field for material regions), so the forms built on :class:`Fields` compile
once for all values and all meshes with the same cell type.

Boundary groups are resolved to the mesh's integer ids before any role check, so a group named in one
role and given by its tag in another is caught like two names.
"""
from dataclasses import dataclass, field

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx import fem

from .. import dolfinx_versions as versions
from ..errors import InputError, brief_text
from ..mesh import builtin, gmsh_io, shape
from ..mesh.domain import UNTAGGED, Domain, global_bounds
from ..problem.expressions import to_ufl, to_ufl_vector, values_at
from ..problem.problem import check_exponent, check_reference, check_vector_sizes
from ..problem.reading import check_file
from ..problem.schema import FREE, ROLES
from ..pairs.binding import bind_pairs
from . import elasticity, friction, rigid


NO_GROUP = 2 ** 30 + 1  # a facet tag no facet has (UFL wants ids >= 0): the measure of an empty role


@dataclass
class Fields:
    """A problem's data on one mesh, as UFL coefficients of the forms of (7) (rebuilt after each
    refinement): λ, μ of Hooke's law (Constants, or DG0 fields with material regions), the body force
    f of (1), the tractions g of (3) per Neumann group, c_n, m_n and the gap g_0 of the law (4), the exact
    displacement if given, the group ids of each role and the boundary measure ``ds``; the prescribed
    displacement u_D of (2) per Dirichlet group that has one, and the symmetry planes' axes."""
    domain: Domain
    lmbda: object
    mu: object
    f: object
    g: dict             # facet group id -> UFL traction (untagged boundary: absent, g = 0)
    c_n: object
    m_n: object         # fem.Constant
    gap: object
    u_exact: object
    ids: dict           # role -> tuple of group ids; "neumann" includes traction-free boundary
    ds: object
    symmetry_axes: dict = field(default_factory=dict)  # symmetry group id -> coordinate axis of its normal
    u_D: dict = field(default_factory=dict)  # Dirichlet group id -> UFL u_D per component (None: free); absent: clamped
    boundary_values: list = field(default_factory=list)  # (Function, fem.Expression) of each prescribed condition
    free_motions: tuple = None  # rigid motions only the foundation can hold: (coefficients (k, m), centre, scale)
    friction: object = None  # friction.FrictionLaw on Γ_C, or None: frictionless
    pairs: list = field(default_factory=list)  # [[pairs]] on this mesh (:class:`nc_dolfinx.pairs.coupling.Pair`)
    bodies: object = None   # with pairs: the mesh's bodies (:class:`nc_dolfinx.pairs.binding.Bodies`)
    notes: list = field(default_factory=list)          # remarks for the summary (not errors)
    warnings: list = field(default_factory=list)       # what the user may not have meant (see bind)

    @property
    def dim(self):
        """The geometric dimension of the mesh (2: plane strain, 3)."""
        return self.domain.mesh.geometry.dim

    def friction_on_foundation(self):
        """Whether Γ_C has friction (the law exists also for friction between [[pairs]] only, then with
        c_t = 0 on Γ_C: no friction quantity or field of Γ_C is reported for it)."""
        return self.friction is not None and self.friction.key != "pairs.friction"

    def ds_of(self, role):
        """Measure over all facets of a role ('dirichlet', 'neumann', 'contact', 'symmetry'); a role with no
        group (Γ_C when [[pairs]] are the only contacts) integrates over no facet."""
        return self.ds(self.ids[role] or NO_GROUP)  # a tuple of ids: the union of the groups

    def pair_coupling(self, u):
        """The [[pairs]]' term of (7) for the displacement ``u`` (:class:`~nc_dolfinx.pairs.coupling.PairCoupling`),
        made once per mesh: the projection between the faces is the mesh's, whoever asks (solver, estimator,
        output)."""
        from ..pairs.coupling import PairCoupling  # (pairs import physics: made on demand)
        made = getattr(self, "_pair_coupling", None)
        if made is None or made.u.function_space != u.function_space:
            made = self._pair_coupling = PairCoupling(u, self)
        made.u = u
        return made

    def sigma(self, u):
        """σ(u) = 2μ ε(u) + λ tr ε(u) I with this problem's material (§2)."""
        return elasticity.sigma(u, self.lmbda, self.mu)

    def boundary_conditions(self, V):
        """Dirichlet conditions on the vector P1 space ``V``: (2) u = 0 on Γ_D, generalised to u = u_D on the
        groups of ``loads.u_D`` — one condition for a group that holds every component, one on ``V.sub(i)``
        per held component of a roller — and on each symmetry plane the normal component of u is 0. Where
        groups share a vertex the last condition sets its value: clamped groups, then those of u_D (in
        ``loads.u_D``'s order), then the symmetry planes. The values are P1 interpolants of u_D
        (:meth:`update_boundary_values`)."""
        tags, fdim = self.domain.facet_tags, self.domain.mesh.topology.dim - 1
        self.boundary_values = []
        clamped = tags.indices[np.isin(tags.values, [i for i in self.ids["dirichlet"] if i not in self.u_D])]
        bcs = [fem.dirichletbc(np.zeros(self.dim, dtype=PETSc.ScalarType),
                               fem.locate_dofs_topological(V, fdim, clamped), V)]
        for group, components in self.u_D.items():
            bcs += self._prescribed(V, tags.indices[tags.values == group], components)
        for group, axis in self.symmetry_axes.items():
            facets = tags.indices[tags.values == group]
            dofs = fem.locate_dofs_topological(V.sub(axis), fdim, facets)
            bcs.append(fem.dirichletbc(PETSc.ScalarType(0), dofs, V.sub(axis)))
        self.update_boundary_values()
        return bcs

    def held_components(self, group):
        """The components of u that a Dirichlet group holds: the prescribed ones of u_D, all when clamped."""
        components = self.u_D.get(group)
        if components is None:
            return tuple(range(self.dim))
        return tuple(i for i, c in enumerate(components) if c is not None)

    def _prescribed(self, V, facets, components):
        """u = u_D on ``facets``: one condition on V if every component is held, else one per held component
        on V.sub(i) (its values in the collapsed space)."""
        fdim = self.domain.mesh.topology.dim - 1
        if all(c is not None for c in components):
            return [fem.dirichletbc(self._values(V, ufl.as_vector(components)),
                                    fem.locate_dofs_topological(V, fdim, facets))]
        bcs = []
        for i, component in enumerate(components):
            if component is not None:
                sub = V.sub(i)
                collapsed, _ = sub.collapse()
                dofs = fem.locate_dofs_topological((sub, collapsed), fdim, facets)
                bcs.append(fem.dirichletbc(self._values(collapsed, component), dofs, sub))
        return bcs

    def _values(self, space, expression):
        """A Function of ``space`` that :meth:`update_boundary_values` interpolates ``expression`` into."""
        values = fem.Function(space)
        self.boundary_values.append((values, fem.Expression(expression, versions.interpolation_points(space))))
        return values

    def update_boundary_values(self):
        """Interpolate u_D again into the prescribed values of the conditions (after a parameter's Constant
        changed: the compiled expressions stay). A solver assembles its lifted load from these values when
        it is made, so call this before making it."""
        for values, expression in self.boundary_values:
            values.interpolate(expression)


def bind(problem, domain):
    """The problem's data on ``domain`` as :class:`Fields`: the coefficients of (7) and the measures of
    Γ_D, Γ_N and Γ_C (§2). Checks groups, roles, Γ_D, Γ_C, symmetry planes, finds the rigid motions the
    supports leave free (:mod:`.rigid`; the cold start decides whether the foundation holds them:
    :mod:`nc_dolfinx.solver.settling`), checks the dimension of every vector, m_n in 3D, the
    reference's dimension, and that every expression is finite where it is used (u_D on its group, c_n and
    g_0 also >= 0 on Γ_C); raises :class:`InputError` for each. Boundary groups of the mesh in no
    role are traction-free: ``Fields.warnings`` says so."""
    msh, params, values = domain.mesh, problem.parameters, problem.values
    dim = msh.geometry.dim
    check_vector_sizes(values, dim)
    check_exponent(values["contact"]["m_n"], dim)
    check_reference(values, dim)
    ids = _role_ids(problem, domain)
    counts = _facet_counts(domain)
    for role, symbol in (("dirichlet", "Γ_D"), ("contact", "Γ_C")):
        if not values["mesh"][role] and (role == "dirichlet" or values["pairs"]):
            continue  # no Γ_D: the rigid-motion check decides whether the body is held; no Γ_C: pairs only
        if sum(counts.get(i, 0) for i in ids[role]) == 0:
            raise InputError(f"{symbol} ({role}) is empty: no boundary facet in groups "
                             f"{values['mesh'][role]}")
    listed_neumann = ids["neumann"]  # a traction given for all of Γ_N applies to these only
    # Groups of the mesh in no role, and untagged facets, are traction-free Neumann boundary.
    in_roles = set(sum(ids.values(), ())) | {_group_id(domain, name, f"pairs[{k}].faces")
                                              for k, pair in enumerate(values["pairs"], 1) for name in pair["faces"]}
    free = tuple(i for i in (UNTAGGED, *domain.facet_groups.values())
                 if i not in in_roles and counts.get(i, 0))
    ids["neumann"] = tuple(sorted(set(ids["neumann"] + free)))

    lmbda, mu = _material(problem, domain)
    u_exact = to_ufl_vector(values["exact"]["u"], msh, params, "exact.u") if values["exact"]["u"] else None
    f, g = _loads(problem, domain, listed_neumann, ids["neumann"], u_exact, lmbda, mu)
    contact = values["contact"]
    ds = ufl.Measure("ds", domain=msh, subdomain_data=domain.facet_tags)
    fields = Fields(domain, lmbda, mu, f, g, to_ufl(contact["c_n"], msh, params),
                    fem.Constant(msh, PETSc.ScalarType(contact["m_n"])), to_ufl(contact["gap"], msh, params),
                    u_exact, ids, ds)
    if problem.frictional:
        fields.friction = _friction_law(problem, fields)
    fields.symmetry_axes = {i: _symmetry_axis(domain, i, _name(domain, i)) for i in ids["symmetry"]
                            if counts.get(i, 0)}
    fields.u_D = _prescribed_displacements(problem, domain, ids["dirichlet"])
    if values["pairs"]:
        bind_pairs(problem, domain, fields, _group_id, counts)  # (each body held by its own supports)
    else:
        _check_rigid_motions_held(fields)
    unassigned = [f"'{_name(domain, i)}'" for i in free if i != UNTAGGED]
    if unassigned:
        fields.warnings.append(
            f"boundary group{'s' if len(unassigned) > 1 else ''} {', '.join(unassigned)} of the mesh "
            f"{'are' if len(unassigned) > 1 else 'is'} in no role (mesh.dirichlet, neumann, contact, symmetry): "
            "traction-free, i.e. Γ_N with g = 0 (list {} in mesh.neumann to say so; a cut of a symmetric "
            "model belongs in mesh.symmetry)".format('them' if len(unassigned) > 1 else 'it'))
    _check_finite_on_mesh(problem, domain, ids, listed_neumann)
    shape.resolve(domain, problem)  # once per mesh family: refinement keeps it
    faces = {"pairs": tuple(i for pair in fields.pairs for i in pair.ids)}
    fields.warnings += [text for role in ("contact", "neumann", "pairs") for i in {**ids, **faces}[role]
                        if (text := shape.faceted_warning(domain, i, role))]
    if dim == 3 and contact["m_n"] > 2:
        fields.notes.append(f"m_n = {contact['m_n']:g} > 2 in 3D: σ_n(u) ∈ L²(Γ_C), used by the paper's "
                            "proofs, is guaranteed only for m_n <= 2 (H^1/2(Γ_C) ⊂ L⁴); the law is well "
                            "posed up to m_n = 3")
    return fields


def _friction_law(problem, fields):
    """The friction law of ``contact`` on this mesh (:mod:`.friction`): c_t = μ c_n and m_t = m_n from
    ``friction``, or ``c_t``, ``m_t`` as given; u_prev = 0 and σ_t,prev = 0 (the unloaded body) until the solver sets
    them (:mod:`.slip_state`)."""
    contact, msh, params = problem.values["contact"], fields.domain.mesh, problem.parameters
    V = versions.p1_space(msh, (fields.dim,))
    if contact["friction"] is not None:
        c_t, m_t = to_ufl(contact["friction"], msh, params) * fields.c_n, fields.m_n
    elif contact["c_t"] is None:  # friction between the faces of [[pairs]] only: none on Γ_C
        c_t, m_t = fem.Constant(msh, PETSc.ScalarType(0.0)), fields.m_n
    else:
        c_t, m_t = to_ufl(contact["c_t"], msh, params), fem.Constant(msh, PETSc.ScalarType(contact["m_t"]))
    epsilon = fem.Constant(msh, PETSc.ScalarType(contact["slip_regularisation"]))
    return friction.FrictionLaw(c_t, m_t, epsilon, fem.Function(V, name="previous_displacement"), fem.Function(V),
                                friction.vertex_normal(V, fields.ds_of("contact")), fem.Function(V, name="previous_traction"),
                                "contact.friction" if contact["friction"] is not None else
                                "contact.c_t" if contact["c_t"] is not None else "pairs.friction")


def _name(domain, group_id):
    names = {i: name for name, i in domain.facet_groups.items()}
    return names.get(group_id, str(group_id))


def _role_ids(problem, domain):
    """Group ids of each role; a group (by name or tag) in two roles is an error."""
    ids, role_of = {}, {}
    for role in ROLES:
        resolved = set()
        for group in problem.values["mesh"][role]:
            group_id = _group_id(domain, group, role)
            if group_id in role_of and role_of[group_id] != role:
                raise InputError(f"boundary group '{_name(domain, group_id)}' (tag {group_id}) is in both "
                                 f"{role_of[group_id]} and {role}")
            role_of[group_id] = role
            resolved.add(group_id)
        ids[role] = tuple(sorted(resolved))
    return ids


def _group_id(domain, group, role):
    if isinstance(group, int):
        if group not in domain.facet_groups.values():
            raise InputError(f"{role} group {group} is not a boundary tag of the mesh (tags: "
                             f"{', '.join(map(str, sorted(domain.facet_groups.values())))})")
        return group
    if group not in domain.facet_groups:
        raise InputError(f"{role} group '{group}' is not in the mesh (groups: "
                         f"{', '.join(sorted(domain.facet_groups))})")
    return domain.facet_groups[group]


def _material(problem, domain):
    """λ, μ: Constants, or DG0 fields when regions have their own E and ν."""
    material, msh = problem.values["material"], domain.mesh
    regions = material.get("regions", {})
    if not regions:
        return (fem.Constant(msh, PETSc.ScalarType(v)) for v in elasticity.lame(material["E"], material["nu"]))
    E, nu = (fem.Function(domain.region.function_space) for _ in range(2))
    E.x.array[:], nu.x.array[:] = material["E"], material["nu"]
    for region, values in regions.items():
        if region not in domain.cell_groups:
            raise InputError(f"material region '{region}' is not a cell group of the mesh "
                             f"(groups: {', '.join(sorted(domain.cell_groups))})")
        mask = np.isclose(domain.region.x.array, domain.cell_groups[region])
        E.x.array[mask], nu.x.array[mask] = values["E"], values["nu"]
    return elasticity.lame(E, nu)


def _loads(problem, domain, listed_neumann, neumann, u_exact, lmbda, mu):
    """f and the tractions g per Neumann group id."""
    msh, params, loads = domain.mesh, problem.parameters, problem.values["loads"]
    if loads["from_exact"]:
        n = ufl.FacetNormal(msh)
        s = elasticity.sigma(u_exact, lmbda, mu)
        return -ufl.div(s), {i: s * n for i in neumann}
    zero = ["0"] * msh.geometry.dim
    f = to_ufl_vector(loads["f"] or zero, msh, params, "loads.f")
    g, given = {}, loads["g"]
    if isinstance(given, list):
        value = to_ufl_vector(given, msh, params, "loads.g")
        g = {i: value for i in listed_neumann}
    elif isinstance(given, dict):
        for group, vector in given.items():
            g[_table_group_id(domain, group)] = to_ufl_vector(vector, msh, params, f"loads.g.{group}")
    return f, g


def _table_group_id(domain, group):
    """The id of a group named by a key of a per-group table (a name, or a tag written as a string)."""
    return domain.facet_groups.get(group, int(group) if group.isdigit() else None)


def _u_D_by_group(problem, domain, dirichlet):
    """``loads.u_D`` as {group id: (key, vector as written)}: one vector for every Dirichlet group, or the
    table's groups (the others stay clamped)."""
    given = problem.values["loads"]["u_D"]
    if isinstance(given, list):
        return {i: ("loads.u_D", given) for i in dirichlet}
    return {_table_group_id(domain, group): (f"loads.u_D.{group}", vector) for group, vector in (given or {}).items()}


def _prescribed_displacements(problem, domain, dirichlet):
    """u_D of (2) per Dirichlet group that ``loads.u_D`` names, as UFL per component (None: free)."""
    msh, params = domain.mesh, problem.parameters
    return {group: [None if text == FREE else to_ufl(text, msh, params) for text in vector]
            for group, (_, vector) in _u_D_by_group(problem, domain, dirichlet).items()}


def _check_rigid_motions_held(fields):
    """The rigid motions the supports leave free (:mod:`.rigid`): the prescribed components of the Dirichlet
    groups and the normal components of the symmetry planes hold the others. Only the foundation can hold
    these, once pressed: ``fields.free_motions`` keeps them for the cold start, which decides whether it
    does (:mod:`nc_dolfinx.solver.settling`)."""
    domain = fields.domain
    held = [(_vertices(domain, (i,)), fields.held_components(i)) for i in fields.ids["dirichlet"]]
    held += [(_vertices(domain, (i,)), (axis,)) for i, axis in fields.symmetry_axes.items()]
    centre, scale = _bounding_box(domain)
    free = rigid.free_motions(rigid.gram_matrix(held, centre, scale, domain.comm))
    if free.shape[1]:
        fields.free_motions = (free, centre, scale)
        fields.notes.append(f"no support holds {', '.join(rigid.describe_all(free, centre, scale))}: the foundation "
                            "does (the body settles onto it before Newton, nc_dolfinx.solver.settling)")


def _bounding_box(domain):
    """The centre of the mesh's bounding box and half its largest side (over all ranks)."""
    msh = domain.mesh
    low, high = global_bounds(domain.comm, msh.geometry.x[:, :msh.geometry.dim])
    return 0.5 * (low + high), 0.5 * float(np.max(high - low))


def _facet_counts(domain):
    """Global number of exterior facets per group id."""
    tags = domain.facet_tags
    n_owned = domain.mesh.topology.index_map(domain.mesh.topology.dim - 1).size_local
    values = tags.values[tags.indices < n_owned]
    local = {int(i): int(np.count_nonzero(values == i)) for i in np.unique(values)}
    merged = {}
    for counts in domain.comm.allgather(local):
        for key, c in counts.items():
            merged[key] = merged.get(key, 0) + c
    return merged


def _symmetry_axis(domain, group_id, name):
    """The coordinate axis normal to a symmetry group, which must lie in a plane x_i = const."""
    msh = domain.mesh
    tags = domain.facet_tags
    facets = tags.indices[tags.values == group_id]
    nodes = versions.entities_to_geometry(msh, msh.topology.dim - 1, facets)
    low, high = global_bounds(domain.comm, msh.geometry.x[nodes.ravel(), :msh.geometry.dim])
    extent = domain.comm.allreduce(float(np.ptp(msh.geometry.x, axis=0).max()) if len(msh.geometry.x) else 0.0,
                                   MPI.MAX)
    flat = np.flatnonzero(high - low <= 1e-10 * extent)
    if len(flat) != 1:
        raise InputError(f"symmetry group '{name}' does not lie in a plane normal to a coordinate axis "
                         "(x, y or z = const): only such planes are supported")
    return int(flat[0])


def _check_finite_on_mesh(problem, domain, ids, listed_neumann):
    """Every expression of the problem finite where it is used (c_n and g_0 also >= 0 on Γ_C), at the
    vertices of the mesh — the P1 nodes, where a finite value cannot come from an overflow elsewhere —
    evaluated in double precision by :func:`expressions.values_at` (no form is compiled)."""
    values, params = problem.values, problem.parameters
    loads, contact = values["loads"], values["contact"]
    everywhere = None  # all vertices
    checks = [(f"exact.u[{i}]", text, everywhere) for i, text in enumerate(values["exact"]["u"] or [])]
    checks += [(f"loads.f[{i}]", text, everywhere) for i, text in enumerate(loads["f"] or [])]
    if isinstance(loads["g"], list):
        checks += [(f"loads.g[{i}]", text, listed_neumann) for i, text in enumerate(loads["g"])]
    for group, vector in (loads["g"] or {}).items() if isinstance(loads["g"], dict) else ():
        checks += [(f"loads.g.{group}[{i}]", text, (_table_group_id(domain, group),)) for i, text in enumerate(vector)]
    for group, (key, vector) in _u_D_by_group(problem, domain, ids["dirichlet"]).items():
        checks += [(f"{key}[{i}]", text, (group,)) for i, text in enumerate(vector) if text != FREE]
    checks += [(f"contact.{name}", contact[name], ids["contact"]) for name in ("c_n", "gap", "friction", "c_t")
               if contact[name] is not None]
    for key, text, groups in checks:
        x = _vertices(domain, groups)
        value = values_at(text, x, params)
        bad = np.flatnonzero(~np.isfinite(value) | (value < 0 if key.startswith("contact.") else False))
        where = domain.comm.allgather(None if not len(bad) else (value[bad[0]], x[bad[0]]))
        first = next((w for w in where if w is not None), None)
        if first is not None:
            number, point = first
            at = ", ".join(f"{c:.4g}" for c in point)
            if np.isfinite(number):
                raise InputError(f"{key} must be >= 0 on Γ_C, but '{brief_text(text)}' = {number:.4g} at ({at})")
            raise InputError(f"{key} = '{brief_text(text)}' is not finite on the mesh: {number} at ({at}) (an "
                             "overflow, or a division by zero?)")


def _vertices(domain, groups):
    """Coordinates of the vertices of the owned facets in ``groups`` (None: every vertex of the mesh)."""
    msh = domain.mesh
    gdim = msh.geometry.dim
    if groups is None:
        return msh.geometry.x[:, :gdim]
    tags = domain.facet_tags
    facets = tags.indices[np.isin(tags.values, groups)]
    nodes = versions.entities_to_geometry(msh, msh.topology.dim - 1, facets)
    return msh.geometry.x[np.unique(nodes.ravel()), :gdim]


def build_domain(problem, comm):
    """The level-0 :class:`Domain` of the problem's [mesh] on the communicator ``comm``
    (e.g. ``MPI.COMM_WORLD``): a built-in rectangle or box, or a gmsh file."""
    from pathlib import Path
    spec = problem.values["mesh"]
    if spec["rectangle"]:
        return builtin.rectangle(comm, spec["rectangle"], spec["cells"], spec["diagonal"])
    if spec["box"]:
        return builtin.box(comm, spec["box"], spec["cells"])
    if not spec["file"]:
        raise InputError("the problem names no mesh (mesh.file, mesh.rectangle or mesh.box): build a Domain "
                         "(nc.from_gmsh_model, nc.from_dolfinx, …) and pass it to solve/adapt")
    paths = [Path(f) for f in spec["file"]] if isinstance(spec["file"], list) else [Path(spec["file"])]
    for path in paths:
        check_file(path, "mesh file")
    return gmsh_io.from_gmsh(comm, paths if len(paths) > 1 else paths[0])
