"""One code base on DOLFINx 0.5.2, 0.9 and 0.11: the version differences live in one module, an unsupported
DOLFINx is refused in one line, and the user's own DOLFINx objects go straight into the public API."""
import ast
import re

import numpy as np
import pytest
from mpi4py import MPI

from conftest import ROOT, run
import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions

PRETEND = ("import runpy, sys, dolfinx; dolfinx.__version__ = {version!r}; sys.argv = {argv!r}; "
           "runpy.run_path({script!r}, run_name='__main__')")


@pytest.mark.parametrize("version", ["0.4.1", "0.7.2"])
@pytest.mark.parametrize("nprocs", [1, 2])
def test_unsupported_dolfinx_is_one_line(version, nprocs):
    """An older DOLFINx, or one between the supported ones that nc_dolfinx does not run on: one line naming
    the version found and the supported ones, exit 1, on every rank together."""
    script = str(ROOT / "run_cases.py")
    done = run(["-c", PRETEND.format(version=version, argv=[script, "block"], script=script)], nprocs)
    assert done.returncode == 1, done.stdout + done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("nc_dolfinx: error:")]
    assert len(lines) == nprocs and "Traceback" not in done.stderr, done.stderr
    assert f"DOLFINx {version} is installed" in lines[0] and versions.SUPPORTED_TEXT in lines[0]


def test_unsupported_dolfinx_is_an_import_error_for_scripts():
    done = run(["-c", "import dolfinx; dolfinx.__version__ = '0.6.0'\ntry:\n    import nc_dolfinx\n"
                "except ImportError as err:\n    print('refused:', err)"])
    assert done.returncode == 0 and "refused: DOLFINx 0.6.0 is installed" in done.stdout, done.stderr


def test_no_version_tests_outside_their_module():
    """Only nc_dolfinx/dolfinx_versions.py reads DOLFINx's version or its private spellings."""
    pattern = re.compile(r"dolfinx\.__version__|_cpp_object|\._mesh\b|\bversions\.(V05|V09|V011|NEW|VERSION)\b")
    offenders = []
    for path in sorted((ROOT / "nc_dolfinx").glob("**/*.py")):
        if path.name in ("dolfinx_versions.py",):
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#")[0]
            if pattern.search(code):
                offenders.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not offenders, "\n".join(offenders)


def test_every_branch_is_named():
    """Each function of the versions module has a docstring that says what differs."""
    tree = ast.parse((ROOT / "nc_dolfinx" / "dolfinx_versions.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            assert ast.get_docstring(node), f"dolfinx_versions.{node.name} has no docstring"


def test_users_own_mesh_goes_into_the_api():
    """The block case's rectangle and sides made with the installed DOLFINx's own calls give the built-in
    mesh's solution and indicators, and the API returns that DOLFINx's own objects."""
    from dolfinx import fem, mesh as dmesh
    problem = nc.load_problem("block")
    msh = dmesh.create_rectangle(MPI.COMM_WORLD, [np.array([0.0, 0.0]), np.array([2.0, 1.0])], [16, 8],
                                 ghost_mode=dmesh.GhostMode.shared_facet)
    sides = {1: lambda x: np.isclose(x[0], 0.0), 2: lambda x: np.isclose(x[0], 2.0),
             3: lambda x: np.isclose(x[1], 0.0), 4: lambda x: np.isclose(x[1], 1.0)}
    facets = [dmesh.locate_entities_boundary(msh, 1, where) for where in sides.values()]
    values = np.concatenate([np.full(len(f), side, dtype=np.int32) for side, f in zip(sides, facets)])
    facets = np.concatenate(facets)
    order = np.argsort(facets, kind="stable")
    tags = dmesh.meshtags(msh, 1, facets[order], values[order])
    users = nc.from_dolfinx(msh, tags, {1: "left", 2: "right", 3: "bottom", 4: "top"})
    assert users.mesh is msh and type(users.facet_tags).__name__ == type(tags).__name__  # the version's MeshTags

    results = []
    for domain in (users, nc.build_domain(problem, MPI.COMM_WORLD)):
        solution = nc.solve(problem, domain)
        est = nc.estimate(solution.u, solution.fields)
        results.append((solution.u, est.totals["eta"], domain.num_cells()))
    (u_user, eta_user, cells_user), (u_builtin, eta_builtin, cells_builtin) = results
    assert cells_user == cells_builtin == 2 * 16 * 8
    assert isinstance(u_user, fem.Function) and u_user.function_space.mesh is msh
    assert abs(eta_user - eta_builtin) <= 1e-10 * eta_builtin
    norms = [np.sqrt(MPI.COMM_WORLD.allreduce(float(np.sum(u.x.array ** 2)), MPI.SUM)) for u in (u_user, u_builtin)]
    assert abs(norms[0] - norms[1]) <= 1e-10 * norms[1]

    child = nc.refine(users)
    assert isinstance(child.mesh, dmesh.Mesh) and child.num_cells() == 4 * users.num_cells()
