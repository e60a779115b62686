"""Serial and parallel runs agree: dofs, iterations, marked sets, η, forces, energy and errors per level,
in 2D and 3D."""
import pytest

from conftest import ROOT, history, run, run_cli

EXACT_KEYS = ("dofs", "cells", "newton_iterations", "marked")
CLOSE_KEYS = ("eta", "eta_1", "eta_2", "eta_3", "eta_4", "zeta", "contact_resultant", "elastic_energy",
              "max_penetration", "max_contact_pressure", "h1_error", "l2_error", "augmented_error",
              "stick_length", "slip_length", "stick_area", "slip_area", "max_slip")

RUNS = {
    "block-adaptive": ["block", "--refine", "adaptive", "--levels", "5"],
    # 3D, a box of Kuhn tetrahedra (equal edges in every face: DOLFINx's Plaza picks among them by global
    # vertex numbers; the meshes parted at level 5 before refinement.py broke the ties by position)
    "box-adaptive": ["box", "--levels", "6"],
    "manufactured-uniform": ["manufactured", "--refine", "uniform", "--levels", "3"],
    # no Γ_D: symmetry planes and the foundation hold the box (its cold start settles it onto the foundation)
    "box-held-by-foundation": ["box", "--levels", "3", "--set", "mesh.dirichlet=[]", "--set", 'mesh.symmetry=["left","front"]',
                               "--set", 'mesh.neumann=["top","right","back"]'],
    # Coulomb friction: the fixed point's passes and the stick zone on adaptive levels (3D and load paths with
    # friction on 1 and 2 ranks: test_friction.py, test_cattaneo.py, test_cattaneo3d.py)
    "block-friction": ["block", "--levels", "4", "--set", "contact.friction=0.3"],
    "manufactured-maximum": ["manufactured", "--refine", "adaptive", "--marking", "maximum", "--levels", "4",
                             "--set", "parameters.m=1"],
}


@pytest.fixture(scope="module", params=sorted(RUNS))
def runs(request, tmp_path_factory):
    out = {}
    for nprocs in (1, 2, 3):
        target = tmp_path_factory.mktemp(f"{request.param}-{nprocs}")
        proc = run_cli(RUNS[request.param] + ["--out", target, "--quiet"], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[nprocs] = history(target)
    return out


@pytest.mark.parametrize("nprocs", [2, 3])
def test_parallel_matches_serial(runs, nprocs):
    serial, parallel = runs[1], runs[nprocs]
    assert len(serial) == len(parallel)
    for s, p in zip(serial, parallel):
        for key in EXACT_KEYS:
            if key == "newton_iterations" and "friction_passes" in s:
                # (with friction the passes' inner solves stop at a loose tolerance, where an AMG-preconditioned
                # step more or less depends on the partition: the box's path took 14 and 15 on 1 and 2 ranks)
                assert abs(s[key] - p[key]) <= 2, (key, s["level"])
                continue
            assert s.get(key) == p.get(key), (key, s["level"])
        for key in CLOSE_KEYS:
            if key in s:
                assert p[key] == pytest.approx(s[key], rel=1e-8, abs=1e-14), (key, s["level"])
        for key in ("contact_force", "friction_force"):
            if key in s:
                assert p[key] == pytest.approx(s[key], rel=1e-8, abs=1e-12), (key, s["level"])
        assert p.get("friction_passes") == s.get("friction_passes")
        scale = sum(abs(x) for x in s["applied_load"])
        for key in [k for k in s if k.startswith("reaction_")] + ["applied_load"]:
            assert p[key] == pytest.approx(s[key], rel=1e-8, abs=1e-10 * scale), (key, s["level"])
        assert s["force_balance"] < 1e-8 and p["force_balance"] < 1e-8


@pytest.mark.parametrize("case,strategy,theta", [("block", "doerfler", 0.5), ("manufactured", "doerfler", 0.3),
                                                 ("corner", "maximum", 0.5)])
def test_marked_sets_are_identical_on_1_2_3_ranks(case, strategy, theta):
    import json
    from conftest import ROOT, run
    script, toml = ROOT / "tests" / "mpi" / "marked_cells.py", ROOT / "nc_dolfinx" / "cases" / f"{case}.toml"
    sets = []
    for nprocs in (1, 2, 3):
        proc = run([script, toml, strategy, theta], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        sets.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    assert len(sets[0]) > 0
    assert sets[1] == sets[0] and sets[2] == sets[0]


@pytest.mark.parametrize("nprocs", [2, 3])
def test_the_same_command_gives_the_same_partition(nprocs):
    """Debian's PT-SCOTCH partitions with several threads unless told otherwise: the same run on 2 ranks
    then got one of several partitions (3 in 5 runs of this script), and with it other AMG hierarchies,
    Newton counts and last digits. nc_dolfinx asks SCOTCH for one thread."""
    script = ROOT / "tests" / "mpi" / "partition_hash.py"
    prints = set()
    for _ in range(4):
        proc = run([script], nprocs)
        assert proc.returncode == 0, proc.stderr[-2000:]
        prints.add(proc.stdout.strip())
    assert len(prints) == 1


SYMMETRIC_TOML = """
title = "a mirror-symmetric gmsh mesh: indicators equal in pairs"
[mesh]
file = "symmetric.msh"
dirichlet = ["left", "right"]
neumann = ["top"]
contact = ["bottom"]
[material]
E = 1.0e3
nu = 0.3
[loads]
g = { top = ["0", "-20"] }
[contact]
c_n = "2.0e3"
m_n = 1.5
[adapt]
refine = "adaptive"
levels = 5
theta = 0.5
"""


@pytest.fixture(scope="module")
def symmetric_runs(tmp_path_factory):
    """A gmsh mesh of [0, 2] x [0, 1] that is its own mirror image in x = 1 (each half transfinite, the
    diagonals of the right half mirroring the left's), loaded and supported symmetrically: on it the
    indicators come in equal pairs up to round-off (level 0 marks 14 cells, 7 pairs), the case where a
    partition-dependent marking would show. (Plaza refinement picks edges by vertex numbers and does not
    keep the mirror symmetry: later levels have fewer exact pairs.)"""
    import gmsh
    folder = tmp_path_factory.mktemp("symmetric")
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    geo = gmsh.model.geo
    points = [geo.addPoint(x, y, 0) for x, y in ((0, 0), (1, 0), (2, 0), (2, 1), (1, 1), (0, 1))]
    lines = [geo.addLine(points[i], points[(i + 1) % 6]) for i in range(6)] + [geo.addLine(points[1], points[4])]
    left = geo.addPlaneSurface([geo.addCurveLoop([lines[0], lines[6], lines[4], lines[5]])])
    right = geo.addPlaneSurface([geo.addCurveLoop([lines[1], lines[2], lines[3], -lines[6]])])
    geo.synchronize()
    for line in lines:
        gmsh.model.mesh.setTransfiniteCurve(line, 9)
    gmsh.model.mesh.setTransfiniteSurface(left, "Left")
    gmsh.model.mesh.setTransfiniteSurface(right, "Right")
    for name, tags in (("bottom", lines[:2]), ("right", [lines[2]]), ("top", lines[3:5]), ("left", [lines[5]])):
        gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, tags), name)
    gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [left, right]), "body")
    gmsh.model.mesh.generate(2)
    gmsh.write(str(folder / "symmetric.msh"))
    gmsh.finalize()
    (folder / "symmetric.toml").write_text(SYMMETRIC_TOML)
    out = {}
    for nprocs in (1, 2, 3):
        target = folder / f"out-{nprocs}"
        proc = run_cli([folder / "symmetric.toml", "--out", target], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[nprocs] = history(target)
    return out


@pytest.mark.parametrize("nprocs", [2, 3])
def test_symmetric_gmsh_mesh_gives_the_same_meshes_on_1_2_3_ranks(symmetric_runs, nprocs):
    """Ties by symmetry at the Dörfler threshold are marked together on every partition: the same marked
    cells and dofs at every level, η to 1e-8, on 2 and 3 ranks (rebalanced after each refinement) as on one."""
    serial, parallel = symmetric_runs[1], symmetric_runs[nprocs]
    assert len(serial) == len(parallel) == 5
    for s, p in zip(serial, parallel):
        assert (s["dofs"], s["cells"], s.get("marked")) == (p["dofs"], p["cells"], p.get("marked")), s["level"]
        assert p["eta"] == pytest.approx(s["eta"], rel=1e-8)
    assert serial[0]["marked"] % 2 == 0 and serial[-1]["dofs"] > 4 * serial[0]["dofs"]
