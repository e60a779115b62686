"""The 3D estimator (Definition 5 on tetrahedra, ζ, symmetry planes) against an independent NumPy computation.

The reference is written here from the definitions, without DOLFINx: our own tetrahedralisation of
[0, 2] × [0, 2] × [0, 1] (unit cubes, each cut into a central tetrahedron and four corner tetrahedra by the
parity of the global vertex numbers, so that neighbouring cubes match; two corner tetrahedra of one cube
share only an edge), written to a gmsh file with one physical surface per box side,
vertices moved off the grid (the faces x = 0 stay in their plane, for the symmetry tests), and matched to
DOLFINx's cells by centroids. u_h is a prescribed P1 field (its vertex values), so σ(u_h) is constant
per cell and computed from the vertex values. Quadrature: collapsed (Duffy) Gauss–Legendre products on
triangles (n²) and tetrahedra (n³); kinked contact faces are clipped along the zero line of
u_hn − g_0 (Sutherland–Hodgman) and the two polygons fan-triangulated — a decomposition different from
the estimator's (nc_dolfinx/estimator/kink.py).
Conventions (module docstring of nc_dolfinx/estimator/indicators.py): h_K = longest edge of K, h_F = longest edge of
F; interior faces carry the full jump [σν], counted for both neighbours with their own h_K; Neumann faces
J = σν − g_F with g_F the mean of g over that face; symmetry faces add h_K ‖σ_t‖²_F to η_2K;
σ_t = σν − σ_n ν; ω_K the cells sharing a vertex with K.
"""
import itertools

import numpy as np
import pytest
import ufl
from mpi4py import MPI

import dolfinx

from conftest import ROOT
from test_estimator import (assert_close, computed_by_cell, prescribe, run_for_result,  # any dimension
                            triangle_rule, write_msh)
from dolfinx import fem, mesh as dmesh
from nc_dolfinx import Problem, bind, build_domain
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.estimator.indicators import NAMES, assemble_cellwise, estimate, patch_sum
from nc_dolfinx.physics.elasticity import lame, sigma

RTOL = 1e-12
N_TRI = 24  # Duffy points per direction on triangles
N_TET = 12  # and on tetrahedra


# --- quadrature and data -------------------------------------------------------------------------


def evaluate(text, P):
    """A problem-file expression evaluated by Python on the points P (n, 3) (constants broadcast)."""
    names = {"x": P[:, 0], "y": P[:, 1], "z": P[:, 2], "pi": np.pi, "sin": np.sin, "cos": np.cos,
             "exp": np.exp, "sqrt": np.sqrt}
    return np.broadcast_to(np.asarray(eval(str(text), {"__builtins__": {}}, names), dtype=float),
                           (len(P),)).copy()


def evaluate_vector(texts, P):
    return np.stack([evaluate(t, P) for t in texts], axis=1)


def tetrahedron_rule(X, n=N_TET):
    """Collapsed Gauss–Legendre points (n³, 3) and weights on the tetrahedron X (4, 3)."""
    s, w = np.polynomial.legendre.leggauss(n)
    a, wa = 0.5 * (s + 1), 0.5 * w
    r, p, q = np.meshgrid(a, a, a, indexing="ij")
    b1, b2, b3 = r, p * (1 - r), q * (1 - r) * (1 - p)  # barycentric weights of X1, X2, X3
    weights = (wa[:, None, None] * wa[None, :, None] * wa[None, None, :] * (1 - r) ** 2 * (1 - p)).ravel()
    volume = abs(np.linalg.det(X[1:] - X[0])) / 6
    points = (X[0] + b1.ravel()[:, None] * (X[1] - X[0]) + b2.ravel()[:, None] * (X[2] - X[0])
              + b3.ravel()[:, None] * (X[3] - X[0]))
    return points, 6 * volume * weights


def clip(polygon, values):
    """The part {value > 0} of a convex polygon (Sutherland–Hodgman with one affine function given at
    the polygon's vertices); returns the vertices of the clipped polygon."""
    out = []
    for i in range(len(polygon)):
        p, q, vp, vq = polygon[i], polygon[(i + 1) % len(polygon)], values[i], values[(i + 1) % len(polygon)]
        if vp > 0:
            out.append(p)
        if (vp > 0) != (vq > 0):
            out.append(p + vp / (vp - vq) * (q - p))
    return out


def polygon_rule(polygon, n=N_TRI):
    """Fan triangulation of a convex polygon, each triangle with the collapsed rule."""
    points, weights = [np.zeros((0, 3))], [np.zeros(0)]
    for i in range(1, len(polygon) - 1):
        P, w = triangle_rule(np.array([polygon[0], polygon[i], polygon[i + 1]]), n)
        points.append(P)
        weights.append(w)
    return np.concatenate(points), np.concatenate(weights)


# --- the mesh ------------------------------------------------------------------------------------

BOX = np.array([2, 2, 1])
SIDES = {"left": (0, 0), "right": (0, 2), "front": (1, 0), "back": (1, 2), "bottom": (2, 0), "top": (2, 1)}


def box_tetrahedra(seed=3, amplitude=0.12):
    """Grid points of the box (unit cubes), moved off the grid, and the tetrahedra of the parity split.

    Returns (points, grid, tets): ``grid`` the unmoved integer positions (to name box sides)."""
    grid = np.array(list(itertools.product(*(range(k + 1) for k in BOX))), dtype=float)
    index = {tuple(p.astype(int)): i for i, p in enumerate(grid)}
    tets = []
    for cube in itertools.product(*(range(k) for k in BOX)):
        corners = [tuple(np.add(cube, d)) for d in itertools.product((0, 1), repeat=3)]
        odd = [c for c in corners if sum(c) % 2]
        even = [c for c in corners if not sum(c) % 2]
        tets.append([index[c] for c in even])
        for c in odd:  # the corner tetrahedron at c: c and its three neighbours in the cube (all even)
            tets.append([index[c]] + [index[e] for e in even if sum(abs(np.subtract(c, e))) == 1])
    rng = np.random.default_rng(seed)
    points = grid + amplitude * rng.uniform(-1, 1, grid.shape)
    points[grid[:, 0] == 0, 0] = 0.0  # the side x = 0 stays in its plane (symmetry tests)
    return points, grid, np.array(tets)


def faces_of(tets):
    """{sorted vertex triple: [cells]}"""
    faces = {}
    for K, tet in enumerate(tets):
        for triple in itertools.combinations(tet, 3):
            faces.setdefault(tuple(sorted(triple)), []).append(K)
    return faces


def side_of(grid, face):
    """The box side a boundary face lies on (by the unmoved grid positions)."""
    for name, (axis, value) in SIDES.items():
        if np.all(grid[list(face), axis] == value):
            return name
    raise AssertionError(f"face {face} is on no side")


# --- the independent computation -----------------------------------------------------------------


def cell_data(points, tets, U, spec):
    """|K|, h_K, σ(u_h)|_K, centroids."""
    lmbda, mu = lame(spec["E"], spec["nu"])
    X = points[tets]
    D = X[:, 1:] - X[:, :1]
    volume = np.abs(np.linalg.det(D)) / 6
    h = np.array([max(np.linalg.norm(x[a] - x[b]) for a, b in itertools.combinations(range(4), 2)) for x in X])
    G = np.linalg.solve(D, U[tets[:, 1:]] - U[tets[:, :1]]).transpose(0, 2, 1)  # G[K, i, j] = ∂u_i/∂x_j
    eps = 0.5 * (G + G.transpose(0, 2, 1))
    sigma = 2 * mu * eps + lmbda * np.trace(eps, axis1=1, axis2=2)[:, None, None] * np.eye(3)
    return volume, h, sigma, X.mean(axis=1)


def outward_normal(points, face, centroid):
    p, q, r = points[list(face)]
    nu = np.cross(q - p, r - p)
    nu /= np.linalg.norm(nu)
    return -nu if nu @ (centroid - p) > 0 else nu


def law_integral(points, face, U, nu, sigma_n, spec, split, n=N_TRI):
    """∫_F (c_n (u_hn − g_0)_+^{m_n} + σ_n)²: on the whole face, or on the two clipped polygons."""
    X = points[list(face)]
    phi_of = lambda P, lam: (lam @ U[list(face)]) @ nu - evaluate(spec["gap"], P)
    if split:
        phi_v = phi_of(X, np.eye(3))
        parts = [p for p in (clip(list(X), phi_v), clip(list(X), -phi_v)) if len(p) >= 3]
        rules = [polygon_rule(p, n) for p in parts]
    else:
        rules = [triangle_rule(X, N_TRI)]
    total = 0.0
    for P, w in rules:
        E = X[1:] - X[0]
        ab = np.linalg.solve(E @ E.T, E @ (P - X[0]).T).T  # P = X0 + a (X1 − X0) + b (X2 − X0)
        lam = np.column_stack([1 - ab.sum(axis=1), ab])
        law = evaluate(spec["c_n"], P) * np.maximum(phi_of(P, lam), 0.0) ** spec["m_n"] + sigma_n
        total += w @ law ** 2
    return total


def hand_estimator(points, grid, tets, spec, U, split=False, n_face=N_TRI):
    """η_1K..η_4K, η_K, ζ_K of every cell, from the definitions; ``spec``: roles, E, nu, f, g, c_n, m_n, gap."""
    n_cells = len(tets)
    volume, h, sigma, centroid = cell_data(points, tets, U, spec)
    sq = {name: np.zeros(n_cells) for name in ("eta_1", "eta_2", "eta_3", "eta_4", "zeta_g")}
    o_f = np.zeros(n_cells)
    for K in range(n_cells):
        P, w = tetrahedron_rule(points[tets[K]])
        F = evaluate_vector(spec["f"], P)
        f_K = w @ F / volume[K]
        sq["eta_1"][K] = h[K] ** 2 * (f_K @ f_K) * volume[K]
        o_f[K] = w @ np.sum((F - f_K) ** 2, axis=1)
    for face, cells in faces_of(tets).items():
        X = points[list(face)]
        area = 0.5 * np.linalg.norm(np.cross(X[1] - X[0], X[2] - X[0]))
        if len(cells) == 2:
            K, L = cells
            jump = (sigma[K] - sigma[L]) @ outward_normal(points, face, centroid[K])
            for M in cells:
                sq["eta_2"][M] += h[M] * (jump @ jump) * area
            continue
        K, = cells
        role, group = spec["roles"].get(side_of(grid, face)), side_of(grid, face)
        nu = outward_normal(points, face, centroid[K])
        traction = sigma[K] @ nu
        sigma_n = traction @ nu
        sigma_t = traction - sigma_n * nu
        if role == "neumann":
            P, w = triangle_rule(X, N_TRI)
            g = evaluate_vector(spec["g"].get(group, ["0", "0", "0"]), P)
            g_F = w @ g / area
            sq["eta_2"][K] += h[K] * np.sum((traction - g_F) ** 2) * area
            h_F = max(np.linalg.norm(X[a] - X[b]) for a, b in ((0, 1), (1, 2), (2, 0)))
            sq["zeta_g"][K] += h_F * (w @ np.sum((g - g_F) ** 2, axis=1))
        elif role == "symmetry":
            sq["eta_2"][K] += h[K] * (sigma_t @ sigma_t) * area
        elif role == "contact":
            sq["eta_3"][K] += h[K] * (sigma_t @ sigma_t) * area
            sq["eta_4"][K] += h[K] * law_integral(points, face, U, nu, sigma_n, spec, split, n_face)
    patches = [set(np.flatnonzero(np.isin(tets, tet).any(axis=1))) for tet in tets]  # ω_K, brute force
    zeta_sq = np.array([h[K] ** 2 * sum(o_f[L] for L in patches[K]) for K in range(n_cells)]) + sq.pop("zeta_g")
    out = {name: np.sqrt(v) for name, v in sq.items()}
    out["eta"] = np.sqrt(sum(sq[k] for k in ("eta_1", "eta_2", "eta_3", "eta_4")))
    out["zeta"] = np.sqrt(zeta_sq)
    return out, centroid, dict(h=h, patches=patches, sigma=sigma)


# --- the problems --------------------------------------------------------------------------------

FREE = ("front", "back", "top")  # one Neumann group over three sides: corner cells with two faces in it
CASE = {
    "mesh": {"dirichlet": ["left"], "neumann": ["free", "right"], "contact": ["bottom"]},
    "material": {"E": 3.0, "nu": 0.25},
    "loads": {"f": ["sin(x) + y*z", "exp(0.3*y) - x", "cos(x*z) + 0.5"],
              "g": {"free": ["1 + x*y", "sin(z) - y", "x - 2*z*z"], "right": ["exp(-y)", "z*y", "0.5 + x*z"]}},
    "contact": {"c_n": "1 + x*x + 0.5*sin(y)", "m_n": 1.5, "gap": "0.01 + 0.02*x"},
}


def u_smooth(x):
    # u_hn − g_0 stays in about [0.06, 0.2] on every contact face: no kink, an analytic integrand.
    return np.stack([0.02 * x[0] * x[1] + 0.01 * x[2], 0.015 * x[0] ** 2 - 0.02 * x[1] * x[2],
                     -0.15 - 0.03 * x[0] + 0.02 * x[1] + 0.1 * x[0] * x[2]])


def u_kink(x):
    # u_hn − g_0 ≈ −u_z − g_0 changes sign along a wave across the bottom: every contact face has its kink
    # inside, four with a triangle and four with a quadrilateral as their positive part.
    return np.stack([0.02 * x[0] * x[1] + 0.01 * x[2], 0.015 * x[0] ** 2 - 0.02 * x[1] * x[2],
                     -0.1 * np.sin(2.5 * x[0] + 1.5 * x[1] - 2.0) - 0.02 + 0.1 * x[0] * x[2]])


def group_name(side):
    return "free" if side in FREE else side


def spec_of(data, grid_roles):
    loads, contact = data["loads"], data["contact"]
    return dict(roles=grid_roles, E=data["material"]["E"], nu=data["material"]["nu"], f=loads["f"],
                g={side: loads["g"][group_name(side)] for side in SIDES if group_name(side) in loads["g"]},
                c_n=contact["c_n"], m_n=contact["m_n"], gap=contact.get("gap", "0"))


def make_case(tmp_path, data=CASE):
    """(fields, V, points, grid, tets, spec) for ``data`` on our tetrahedral mesh."""
    points, grid, tets = box_tetrahedra()
    boundary = {face: side_of(grid, face) for face, cells in faces_of(tets).items() if len(cells) == 1}
    path = tmp_path / "tets.msh"
    write_msh(path, points, tets, {face: group_name(side) for face, side in boundary.items()})
    data = dict(data, mesh=dict(data["mesh"], file=str(path)))
    roles = {side: role for role in ("dirichlet", "neumann", "contact", "symmetry")
             for side in SIDES if group_name(side) in data["mesh"].get(role, [])}
    problem = Problem.from_dict(data, "tetrahedra")
    domain = build_domain(problem, MPI.COMM_WORLD)
    fields = bind(problem, domain)
    V = versions.p1_space(domain.mesh, (domain.mesh.geometry.dim,))
    return fields, V, points, grid, tets, spec_of(data, roles)


def contact_phi(points, grid, tets, spec, U):
    """u_hn − g_0 at the three vertices of every contact face."""
    centroid = points[tets].mean(axis=1)
    out = []
    for face, cells in faces_of(tets).items():
        if len(cells) == 1 and spec["roles"].get(side_of(grid, face)) == "contact":
            nu = outward_normal(points, face, centroid[cells[0]])
            out.append(U[list(face)] @ nu - evaluate(spec["gap"], points[list(face)]))
    return np.array(out)


def neumann_faces_per_cell(grid, tets, spec):
    """{cell: [side, …]} of the cells with more than one Neumann face."""
    count = {}
    for face, cells in faces_of(tets).items():
        if len(cells) == 1 and spec["roles"].get(side_of(grid, face)) == "neumann":
            count.setdefault(cells[0], []).append(side_of(grid, face))
    return {K: sides for K, sides in count.items() if len(sides) > 1}


# --- cell-by-cell checks of Definition 5 on tetrahedra -------------------------------------------


def test_indicators_match_hand_computation(tmp_path):
    """Every indicator of every cell: non-polynomial f, g (two Neumann groups; corner cells with two faces
    in one group and three Neumann faces in two groups), c_n(x), an affine gap, m_n = 1.5, slanted faces.
    With cell_degree = 20 the estimator's quadrature of f and g is converged to round-off; the contact
    integrand is analytic (no kink: u_hn − g_0 > 0 on every contact face)."""
    fields, V, points, grid, tets, spec = make_case(tmp_path)
    U = u_smooth(points.T).T
    phi = contact_phi(points, grid, tets, spec, U)
    assert np.all(phi > 0.03) and np.all(phi.max(axis=1) / phi.min(axis=1) < 2)
    multi = neumann_faces_per_cell(grid, tets, spec)
    groups = [sorted(group_name(s) for s in sides) for sides in multi.values()]
    assert ["free", "free"] in groups and ["free", "free", "right"] in groups, groups

    est = estimate(prescribe(V, u_smooth), fields, cell_degree=20)
    expected, centroids, info = hand_estimator(points, grid, tets, spec, U)
    computed = computed_by_cell(est, fields.domain.mesh, centroids)
    for name in NAMES:
        assert_close(computed[name], expected[name], what=name)
        assert est.totals[name] == pytest.approx(np.sqrt(np.sum(expected[name] ** 2)), rel=RTOL)
    for name in ("eta_1", "eta_2", "zeta"):  # every indicator is exercised
        assert np.all(expected[name] > 0.02 * expected[name].max()), name
    contact_cells = np.count_nonzero(expected["eta_4"])
    assert contact_cells >= 8
    assert np.count_nonzero(expected["eta_3"] > 1e-3 * expected["eta_3"].max()) == contact_cells


def test_neumann_means_are_per_face(tmp_path):
    """The corner cell with three Neumann faces (two in 'free', one in 'right'): one mean of g per group
    instead of per face would change η_2K and ζ_K visibly, so the match above is a test of the per-face
    means."""
    fields, V, points, grid, tets, spec = make_case(tmp_path)
    U = u_smooth(points.T).T
    K, = [K for K, s in neumann_faces_per_cell(grid, tets, spec).items() if set(s) == {"front", "top", "right"}]
    expected, centroids, info = hand_estimator(points, grid, tets, spec, U)
    faces = [f for f, cells in faces_of(tets).items() if cells == [K] and side_of(grid, f) in ("front", "top")]
    rules = [triangle_rule(points[list(f)], N_TRI) for f in faces]
    g = [evaluate_vector(spec["g"][side_of(grid, f)], P) for f, (P, _) in zip(faces, rules)]
    g_union = sum(w @ gi for (_, w), gi in zip(rules, g)) / sum(w.sum() for _, w in rules)
    centroid = points[tets[K]].mean(axis=0)
    wrong_eta, wrong_zeta = expected["eta_2"][K] ** 2, expected["zeta"][K] ** 2
    for f, (P, w), gi in zip(faces, rules, g):
        traction = info["sigma"][K] @ outward_normal(points, f, centroid)
        g_F = w @ gi / w.sum()
        X = points[list(f)]
        h_F = max(np.linalg.norm(X[a] - X[b]) for a, b in ((0, 1), (1, 2), (2, 0)))
        wrong_eta += info["h"][K] * w.sum() * (np.sum((traction - g_union) ** 2) - np.sum((traction - g_F) ** 2))
        wrong_zeta += h_F * (w @ (np.sum((gi - g_union) ** 2, axis=1) - np.sum((gi - g_F) ** 2, axis=1)))
    computed = computed_by_cell(estimate(prescribe(V, u_smooth), fields, cell_degree=20), fields.domain.mesh,
                                centroids)
    for name, wrong in (("eta_2", wrong_eta), ("zeta", wrong_zeta)):
        assert computed[name][K] == pytest.approx(expected[name][K], rel=RTOL)
        assert abs(np.sqrt(wrong) - expected[name][K]) > 1e-3 * expected[name][K], name


# --- the kink of (u_hn − g_0)_+ inside a contact face -------------------------------------------


@pytest.mark.parametrize("m_n, c_n, tol", [(1.0, "1 + x*x + 0.5*y", 1e-12), (1.5, "1 + x*x + 0.5*sin(y)", 1e-6)])
def test_contact_kink_inside_faces(m_n, c_n, tol, tmp_path):
    """η_4K on contact faces cut by the zero line of u_hn − g_0 (affine g_0), against our own clipped
    integration (96² points per triangle of each polygon; its own convergence: 48² differs from 192² by
    3e-15 for m_n = 1 and 3.3e-10 for m_n = 1.5; 48² vs 96² is asserted below tol/100).

    m_n = 1 with a polynomial c_n: on each piece the integrand is a polynomial (degree 6), so split faces
    are exact: measured 4.9e-15 relative. m_n = 1.5 with c_n = 1 + x² + sin(y)/2: (·)^{1.5} vanishes on
    the cut, where Gauss rules converge only algebraically: measured 1.9e-7 with the default degree
    (CONTACT_DEGREE_SPLIT = 16, 55 points per piece), 1.8e-7 with 24, 3.9e-6 with 8. The unsplit face
    (``split_kinks=False``, degree 24, 112 points) is far worse: measured 1.3e-4 (m_n = 1) and 1.7e-4
    (m_n = 1.5); even degree 40 (441 points) gives 2.1e-4 and 1.2e-5.
    """
    data = dict(CASE, contact=dict(CASE["contact"], m_n=m_n, c_n=c_n))
    fields, V, points, grid, tets, spec = make_case(tmp_path, data)
    U = u_kink(points.T).T
    positive_vertices = (contact_phi(points, grid, tets, spec, U) > 0).sum(axis=1)
    assert sorted(set(positive_vertices)) == [1, 2], "a triangle and a quadrilateral as positive parts"
    reference, centroids, _ = hand_estimator(points, grid, tets, spec, U, split=True, n_face=96)
    coarser, _, _ = hand_estimator(points, grid, tets, spec, U, split=True, n_face=48)
    cells = np.flatnonzero(reference["eta_4"])
    assert len(cells) == len(positive_vertices)  # one contact face per cell here
    assert np.max(np.abs(coarser["eta_4"][cells] / reference["eta_4"][cells] - 1)) < tol / 100

    u = prescribe(V, u_kink)
    msh = fields.domain.mesh
    split = computed_by_cell(estimate(u, fields, cell_degree=20), msh, centroids)
    unsplit = computed_by_cell(estimate(u, fields, cell_degree=20, split_kinks=False), msh, centroids)
    for name in ("eta_1", "eta_2", "eta_3", "zeta"):  # unaffected by the kink: exact
        assert_close(split[name], reference[name], what=name)
    err_split = np.abs(split["eta_4"][cells] / reference["eta_4"][cells] - 1)
    err_unsplit = np.abs(unsplit["eta_4"][cells] / reference["eta_4"][cells] - 1)
    print(f"m_n = {m_n}: relative error of eta_4K on kinked faces: split {err_split.max():.2e}, "
          f"unsplit {err_unsplit.max():.2e}")
    assert err_split.max() < tol
    assert err_unsplit.max() > 1e-6, "the kink should be visible to an unsplit rule (else the test is void)"


# --- ζ: the patch sum over ω_K -------------------------------------------------------------------


def test_patch_sum_brute_force(tmp_path):
    """patch_sum against ω_K found by brute force (every cell sharing a vertex with K), with random
    o_K: on this mesh cells meet K in a face, an edge only (corner tetrahedra of one cube) or a vertex
    only, so the 2D formula Σ_x S_x − 2 o_K − Σ_N o_N (which counts an edge-neighbour twice) would fail."""
    fields, V, points, grid, tets, spec = make_case(tmp_path)
    msh = fields.domain.mesh
    Q = versions.dg0_space(msh)
    shared = np.array([[len(set(a) & set(b)) for b in tets] for a in tets])
    assert {1, 2, 3} <= set(shared.ravel()), "vertex-, edge- and face-neighbours"
    centroids = points[tets].mean(axis=1)
    mid = dmesh.compute_midpoints(msh, 3, np.arange(len(tets), dtype=np.int32))
    order = np.argmin(np.linalg.norm(mid[None, :, :] - centroids[:, None, :], axis=2), axis=1)
    o = np.random.default_rng(1).uniform(0.5, 1.5, len(tets))
    o_dolfinx = np.empty_like(o)
    o_dolfinx[order] = o
    computed = patch_sum(o_dolfinx, Q)[order]
    expected = (shared > 0).astype(float) @ o
    assert_close(computed, expected, rtol=1e-14, what="patch sum")
    face_neighbours = (shared == 3).astype(float) @ o
    two_d_formula = (shared * (shared > 0)).astype(float) @ o - 2 * o - face_neighbours
    assert np.max(np.abs(two_d_formula - expected)) > 0.1


# --- symmetry planes ----------------------------------------------------------------------------


def test_symmetry_faces(tmp_path):
    """A symmetry plane (x = 0) adds h_K ‖σ_t(u_h)‖²_F of its faces to η_2K; everything else as before."""
    data = dict(CASE, mesh={"symmetry": ["left"], "dirichlet": ["right"], "neumann": ["free"],
                            "contact": ["bottom"]},
                loads=dict(CASE["loads"], g={"free": CASE["loads"]["g"]["free"]}))
    fields, V, points, grid, tets, spec = make_case(tmp_path, data)
    assert spec["roles"]["left"] == "symmetry" and fields.symmetry_axes
    shear = lambda x: u_smooth(x) + np.stack([0 * x[0], x[0] * x[2] ** 2, 0 * x[0]])  # σ_t ≠ 0 on x = 0
    U = shear(points.T).T
    expected, centroids, _ = hand_estimator(points, grid, tets, spec, U)
    computed = computed_by_cell(estimate(prescribe(V, shear), fields, cell_degree=20), fields.domain.mesh,
                                centroids)
    for name in NAMES:
        assert_close(computed[name], expected[name], what=name)
    without, _, _ = hand_estimator(points, grid, tets, dict(spec, roles=dict(spec["roles"], left=None)), U)
    # the term is visible at the tolerance above in each of the four cells with a face on the plane
    change = np.abs(expected["eta_2"] - without["eta_2"]) / expected["eta_2"]
    assert np.count_nonzero(change > 1e-7) == 4 and change.max() > 0.03


# --- parallel: the same indicators on 1, 2 and 3 ranks ------------------------------------------


def run_parallel(nprocs):
    result = run_for_result(ROOT / "tests" / "mpi" / "estimator_cells.py", nprocs)
    rows = np.array(result["rows"])
    keys = [tuple(k) for k in np.round(rows[:, :3], 8)]
    assert len(set(keys)) == len(keys) == result["cells"]
    return dict(zip(keys, rows[:, 3:])), result


def test_parallel_matches_serial():
    """A 4×4×2 box (192 tetrahedra) with every kind of facet (symmetry plane, two Neumann groups, kinked
    contact faces, Dirichlet), m_n = 1.5, c_n(x): every owned cell's η_K, η_1K..η_4K, ζ_K on 2 and 3 ranks
    equals the serial value (measured: ≤ 7.3e-15 of each indicator's largest value; 70 % of the cells
    bitwise), and so do the totals (≤ 3.3e-16). The faces with varying traction take two layers (each
    assembled on its own, its per-face means formed before the ghost cells' sums go to their owners) on
    every rank count."""
    serial, serial_result = run_parallel(1)
    assert serial_result["kinked_faces"] > 0
    for nprocs in (2, 3):
        parallel, result = run_parallel(nprocs)
        assert result["neumann_layers"] == serial_result["neumann_layers"] == 2
        assert set(parallel) == set(serial)
        a = np.array([parallel[k] for k in sorted(serial)])
        b = np.array([serial[k] for k in sorted(serial)])
        scale = np.max(np.abs(b), axis=0)
        assert np.all(scale > 0)
        assert np.all(np.abs(a - b) <= 1e-12 * np.maximum(np.abs(b), 1e-3 * scale)), \
            f"{nprocs} ranks: max relative difference {np.max(np.abs(a - b) / scale):.2e}"
        for name, value in serial_result["totals"].items():
            assert result["totals"][name] == pytest.approx(value, rel=1e-12), name


# --- the interior-facet jumps without facet permutations ----------------------------------------


def jump_form(msh, degree):
    """Σ_F ∫_F |[σ(u) ν]|² w, for a random P1 field u, assembled against DG0 w on both sides of F."""
    u = fem.Function(versions.p1_space(msh, (msh.geometry.dim,)))
    u.x.array[:] = np.random.default_rng(7).uniform(-1, 1, u.x.array.size)
    w = ufl.TestFunction(versions.dg0_space(msh))
    n, s = ufl.FacetNormal(msh), sigma(u, 1.3, 0.7)
    jump = s("+") * n("+") + s("-") * n("-")
    return ufl.inner(jump, jump) * (w("+") + w("-")) * ufl.dS(metadata={"quadrature_degree": degree})


def perturbed_box():
    """A 3×3×3 box of tetrahedra with its vertices moved off the grid (faces in every orientation)."""
    msh = dmesh.create_box(MPI.COMM_WORLD, [[0, 0, 0], [1, 1, 1]], [3, 3, 3], dmesh.CellType.tetrahedron)
    msh.geometry.x[:] += np.random.default_rng(3).uniform(-0.08, 0.08, msh.geometry.x.shape)
    return msh


def test_one_point_jumps_need_no_facet_permutations():
    """The jump integral of the estimator with its one-point rule, assembled by ``assemble_cellwise``
    (facet permutations switched off: no edges are built), equals DOLFINx's own assembly with the
    permutations (which builds them) to round-off; an interior-facet rule of degree 2 keeps them."""
    msh, reference = perturbed_box(), perturbed_box()
    # DOLFINx's own path first: the switch is kept in the compiled module, which both forms share
    vec = fem.assemble_vector(fem.form(jump_form(reference, 0)))
    vec.scatter_reverse(versions.SCATTER_ADD)
    assert versions.entities_built(reference, 1)  # it builds the edges for the permutations
    values = assemble_cellwise(jump_form(msh, 0), versions.dg0_space(msh))[:, 0]
    assert not versions.entities_built(msh, 1)  # no edges, hence no permutations, were needed
    expected = vec.array[:len(values)]
    assert np.min(expected) > 0
    assert np.max(np.abs(values - expected)) <= 1e-13 * np.max(expected)
    assemble_cellwise(jump_form(msh, 2), versions.dg0_space(msh))
    assert versions.entities_built(msh, 1)  # a rule with several points is permuted as FFCx asks
