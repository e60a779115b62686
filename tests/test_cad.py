"""The true shape from CAD (nc_dolfinx/mesh/cad.py): a gmsh model's OpenCASCADE geometry, and a .msh with the
BREP it was meshed from (mesh.cad), against the same body with its circle given analytically; 1, 2, 3 ranks;
the CAD files refused with one clear line."""
import json

import pytest

from conftest import ROOT, import_script, run, run_cli

LEVELS = 4


@pytest.fixture(scope="module")
def by_ranks():
    out = {}
    for nprocs in (1, 2, 3):
        proc = run([ROOT / "tests" / "mpi" / "cad_half_disc.py", LEVELS], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[nprocs] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


def test_a_gmsh_model_s_cad_puts_new_vertices_on_the_arc(by_ranks):
    serial = by_ranks[1]
    assert serial["off_circle"] < 1e-12 and len(serial["curved"]) == 2  # 'free' and 'contact' found curved
    assert serial["rows"][-1]["dofs"] > 2 * serial["rows"][0]["dofs"]  # it did refine the arc region
    geometry = [row["eta_geometry"] for row in serial["rows"]]
    assert geometry[-1] < 0.5 * geometry[0]  # the chords' sag falls as the arc is refined


@pytest.mark.parametrize("nprocs", [2, 3])
def test_the_cad_s_refinement_does_not_depend_on_the_ranks(by_ranks, nprocs):
    for serial, parallel in zip(by_ranks[1]["rows"], by_ranks[nprocs]["rows"]):
        assert serial["dofs"] == parallel["dofs"]
        for key, value in serial.items():
            assert parallel[key] == pytest.approx(value, rel=1e-8, abs=1e-12), key


@pytest.fixture(scope="module")
def msh_and_brep(tmp_path_factory):
    """The same half-disc written as .msh and .brep, and a problem file for it."""
    import gmsh
    folder = tmp_path_factory.mktemp("cad")
    script = (ROOT / "tests" / "mpi" / "cad_half_disc.py").read_text()
    namespace = {}
    exec(script[script.index("def half_disc"):script.index("problem = ")], {"np": __import__("numpy"), "H": 0.1},
         namespace)
    gmsh.initialize()
    namespace["half_disc"](gmsh)
    gmsh.write(str(folder / "half_disc.msh"))
    gmsh.write(str(folder / "half_disc.brep"))
    gmsh.finalize()
    return folder


def _problem(folder, extra):
    text = f"""title = "half-disc"
[mesh]
file = "half_disc.msh"
dirichlet = ["top"]
neumann = ["free"]
contact = ["contact"]
{extra}
[material]
E = 1e3
nu = 0.45
[loads]
u_D = ["0", "-0.009773"]
[contact]
c_n = 1e6
m_n = 1
gap = "y"
[adapt]
refine = "adaptive"
levels = {LEVELS}
"""
    path = folder / f"p{abs(hash(extra))}.toml"
    path.write_text(text)
    return path


def test_a_msh_with_its_brep_refines_as_the_circle_given_analytically(msh_and_brep, tmp_path):
    results = {}
    for name, extra in (("cad", 'cad = "half_disc.brep"'),
                        ("circle", "[mesh.shapes.contact.circle]\ncentre = [0, 1]\nradius = 1\n"
                                   "[mesh.shapes.free.circle]\ncentre = [0, 1]\nradius = 1")):
        proc = run_cli([_problem(msh_and_brep, extra), "--out", tmp_path / name, "--quiet"])
        assert proc.returncode == 0, proc.stdout + proc.stderr
        results[name] = json.loads((tmp_path / name / "history.json").read_text())
    for cad, circle in zip(results["cad"], results["circle"]):
        assert cad["dofs"] == circle["dofs"]
        assert cad["max_contact_pressure"] == pytest.approx(circle["max_contact_pressure"], rel=1e-9)


@pytest.mark.parametrize("cad, message", [
    ("half_disc.geo", "a CAD file must be BREP, STEP or IGES"),
    ("missing.brep", "mesh.cad: cannot read"),
])
def test_a_cad_file_that_cannot_serve_is_one_clear_line(msh_and_brep, tmp_path, cad, message):
    (msh_and_brep / "half_disc.geo").write_text('Point(1) = {0, 0, 0};\n')
    proc = run_cli([_problem(msh_and_brep, f'cad = "{cad}"'), "--out", tmp_path / "out", "--quiet"])
    text = proc.stdout + proc.stderr
    errors = [line for line in text.splitlines() if "error" in line]
    assert proc.returncode == 1 and "Traceback" not in text
    assert len(errors) == 1 and message in errors[0], text


def test_a_quarter_ball_s_brep_refines_as_its_sphere(tmp_path):
    """3D: the quarter ball (meshes/quarterball.py, h = R/8) with the BREP it was meshed from, no shape given:
    after 2 adaptive levels the vertices of its spherical groups lie on the sphere — those on the symmetry
    planes on the great circles — and the history is that of the sphere given analytically."""
    import numpy as np
    curved, quarterball = import_script("verification", "curved"), import_script("meshes", "quarterball")
    quarterball.write(tmp_path / "ball.msh", cad=tmp_path / "ball.brep")
    histories = {}
    for name, shaped in (("cad", False), ("sphere", True)):
        problem = curved.write_problem(tmp_path, 3, tmp_path / "ball.msh", shaped, name=f"{name}.toml")
        if name == "cad":
            problem.write_text(problem.read_text().replace("[mesh]\n", '[mesh]\ncad = "ball.brep"\n', 1))
        proc = run_cli([problem, "--refine", "adaptive", "--levels", 3, "--out", tmp_path / name, "--quiet"])
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert "is given no shape" not in proc.stdout + proc.stderr
        histories[name] = json.loads((tmp_path / name / "history.json").read_text())
    for cad, sphere in zip(histories["cad"], histories["sphere"]):
        assert cad["dofs"] == sphere["dofs"]
        for key in ("contact_resultant", "max_contact_pressure", "geometry_sag"):
            assert cad[key] == pytest.approx(sphere[key], rel=1e-8, abs=1e-14), key
    assert np.isfinite(histories["cad"][-1]["eta_geometry"])
