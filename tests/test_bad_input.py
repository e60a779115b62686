"""Bad input through the real command line: one error line, a non-zero exit, no traceback, no results.

The project standard: every bad input (unknown case, missing files, bad groups, bad material or contact
parameters, malformed expressions or TOML, unusable gmsh meshes, a diverging SNES, bad options) ends the
run with exactly ONE line ``nc_dolfinx: error: …`` that names the problem, exit status 1 (mpirun passes
it on), no ``Traceback``, and nothing under ``--out``: no summary.json, no .xdmf/.h5, no ``.partial-*``
staging directory. A representative handful is repeated on 2 ranks, where the line must appear once (not
once per rank) and a rank must not be left waiting for another that failed (a hang fails the test).

The gmsh meshes are written once per module by a small gmsh script in a temporary directory.
"""
import os
import signal
import subprocess
import textwrap
from pathlib import Path

import pytest

from conftest import PYTHON, ROOT, mpirun_prefix

TIMEOUT = 120  # seconds; a hang fails instead of blocking the suite
ERROR = "nc_dolfinx: error:"
FAST = ["--refine", "none", "--set", "mesh.cells=[4,2]", "--quiet"]  # block on 8 cells, one solve
FAST3D = ["--refine", "none", "--set", "mesh.cells=[2,1,1]", "--quiet"]  # box on 12 tetrahedra
INJECTION = "__import__('os').system('touch PWNED')"


def cli(args, nprocs=1, cwd=None, timeout=TIMEOUT):
    """``run_cases.py ARGS`` like conftest.run_cli, but in its own process group so that a hang (a rank
    waiting for one that failed) is killed with all its ranks and reported as a failure."""
    cmd = mpirun_prefix(nprocs) + [PYTHON, str(ROOT / "run_cases.py"), *map(str, args)]
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    proc = subprocess.Popen(cmd, cwd=cwd or ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"no exit within {timeout} s (hang?): {' '.join(cmd)}\n{out}\n{err}")
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def assert_bad_input(result, expected, out, nprocs=1, allowed=()):
    """One error line containing ``expected``, a non-zero exit, no traceback, no results under ``out``."""
    text = result.stdout + result.stderr
    where = f"\n--- command: {' '.join(result.args)}\n--- output:\n{text}"
    errors = [line for line in text.splitlines() if line.startswith(ERROR)]
    assert result.returncode != 0, "bad input exited with status 0" + where
    if nprocs == 1:
        assert result.returncode == 1, f"exit status {result.returncode}, expected 1" + where
    assert len(errors) == 1, f"{len(errors)} lines start with {ERROR!r}, expected 1" + where
    assert expected in errors[0], f"error line does not name the problem ({expected!r})" + where
    assert "Traceback" not in text, "traceback in the output" + where
    assert "internal error" not in text, "an internal error instead of an input error" + where
    left = sorted(str(p.relative_to(out)) for p in Path(out).rglob("*")) if Path(out).exists() else []
    left = [p for p in left if p not in allowed]
    assert not left, f"the failed run left {left} in {out}" + where


# --- gmsh meshes ------------------------------------------------------------------------------------

GMSH_SCRIPT = textwrap.dedent('''
    """Unit-square meshes with groups clamp (left), base (bottom), body (cells), and broken variants."""
    import sys
    import gmsh

    def square(path, kind):
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        geo = gmsh.model.geo
        p = [geo.addPoint(x, y, 0, 0.5) for x, y in [(0, 0), (1, 0), (1, 1), (0, 1)]]
        lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]  # bottom, right, top, left
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        bottom, left = lines[0], lines[3]
        if kind.startswith("interior"):  # a curve inside the body, meshed into it: no exterior facet
            inner = geo.addLine(geo.addPoint(0.25, 0.5, 0, 0.5), geo.addPoint(0.75, 0.5, 0, 0.5))
        if kind.startswith("duplicate"):  # a second curve on top of the bottom side
            twin = geo.addLine(p[0], p[1])
        geo.synchronize()
        if kind.startswith("interior"):
            gmsh.model.mesh.embed(1, [inner], 2, surface)

        def group(dim, tags, name):
            gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, tags), name)

        group(2, [surface], "body")
        group(1, [inner if kind == "interior_clamp" else left], "clamp")
        group(1, [inner if kind == "interior_base" else bottom], "base")
        if kind == "same_curve_twice":
            group(1, [bottom], "support")
        if kind.startswith("duplicate"):
            group(1, [twin], "support")
        if kind != "empty":  # "empty": the geometry and its groups, but no mesh
            gmsh.model.mesh.generate(2)
        if kind == "duplicate_merged":  # the twin's facets now are the bottom facets: same nodes
            gmsh.model.mesh.removeDuplicateNodes()
        gmsh.write(path)
        gmsh.finalize()

    def box(path, hexahedra=False):
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        volume = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, [volume]), "body")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        if hexahedra:
            gmsh.model.mesh.setTransfiniteAutomatic()
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(3)
        gmsh.write(path)
        gmsh.finalize()

    out = sys.argv[1]
    for kind in ("good", "interior_clamp", "interior_base", "same_curve_twice", "duplicate",
                 "duplicate_merged", "empty"):
        square(f"{out}/{kind}.msh", kind)
    box(f"{out}/box.msh")
    box(f"{out}/hex.msh", hexahedra=True)
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)  # quadrilaterals
    square_surface = gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [square_surface]), "body")
    gmsh.model.mesh.generate(2)
    gmsh.write(f"{out}/quad.msh")
    gmsh.finalize()
''')


@pytest.fixture(scope="module")
def msh(tmp_path_factory):
    """Directory holding the .msh files of GMSH_SCRIPT (and a file that is not a mesh)."""
    folder = tmp_path_factory.mktemp("meshes")
    script = folder / "make_meshes.py"
    script.write_text(GMSH_SCRIPT)
    done = subprocess.run([PYTHON, str(script), str(folder)], capture_output=True, text=True, timeout=TIMEOUT)
    assert done.returncode == 0, done.stdout + done.stderr
    (folder / "garbage.msh").write_text("this is not a gmsh file\n")
    (folder / "binary.toml").write_bytes(bytes(range(256)) * 4)
    return folder


def gmsh_problem(folder, mesh, dirichlet="clamp", contact="base"):
    """A problem file next to the meshes (the mesh path is relative to it)."""
    path = folder / f"problem_{mesh}_{dirichlet}_{contact}.toml"
    path.write_text(textwrap.dedent(f"""\
        title = "bad input test on {mesh}.msh"
        [mesh]
        file = "{mesh}.msh"
        dirichlet = ["{dirichlet}"]
        contact = ["{contact}"]
        [material]
        E = 100.0
        nu = 0.3
        [loads]
        f = ["0", "-1"]
        [contact]
        c_n = 100.0
        m_n = 1.0
        """))
    return path


def block_with(tmp_path, extra):
    """The block case's problem file with some text appended."""
    path = tmp_path / "block_edited.toml"
    path.write_text((ROOT / "nc_dolfinx/cases/block.toml").read_text() + extra)
    return path


# --- the bad inputs: (id, arguments (a function of the mesh folder and tmp_path), expected text) ----------

CASES = [
    # problem and mesh files
    ("unknown_case", lambda m, t: ["no_such_case"], "unknown case 'no_such_case'"),
    ("missing_problem_file", lambda m, t: [t / "missing.toml"], "not found"),
    ("missing_mesh_file", lambda m, t: [gmsh_problem(m, "missing")], "missing.msh' not found"),
    ("malformed_toml", lambda m, t: [block_with(t, "\n[contact\nm_n = 2\n")], "malformed TOML"),
    ("unknown_section", lambda m, t: [block_with(t, "\n[contacts]\nm_n = 2\n")], "unknown section '[contacts]' (did you mean '[contact]'?)"),
    ("unknown_section_set", lambda m, t: ["block", *FAST, "--set", "solverr.x=1"], "unknown section '[solverr]' (did you mean '[solver]'?)"),
    ("not_a_mesh_file", lambda m, t: [gmsh_problem(m, "garbage")],
     "garbage.msh' is not a gmsh .msh file (it does not start with $MeshFormat)"),
    ("binary_problem_file", lambda m, t: [m / "binary.toml"], "is not a text (UTF-8) TOML file"),
    ("mesh_file_not_a_string", lambda m, t: ["block", *FAST, "--set", "mesh.file=3"],
     "mesh.file must be a string, got 3"),
    ("quad_mesh", lambda m, t: [gmsh_problem(m, "quad")], "Quadrilateral"),
    # boundary groups
    ("unknown_group_rectangle", lambda m, t: ["block", *FAST, "--set", 'mesh.dirichlet=["nosuch"]'],
     "dirichlet group 'nosuch' is not in the mesh"),
    ("unknown_group_gmsh", lambda m, t: [gmsh_problem(m, "good", contact="nosuch")],
     "contact group 'nosuch' is not in the mesh"),
    ("unknown_group_tag", lambda m, t: ["block", *FAST, "--set", "mesh.contact=[7]"],
     "contact group 7 is not a boundary tag"),
    ("empty_gamma_d_gmsh", lambda m, t: [gmsh_problem(m, "interior_clamp")], "Γ_D (dirichlet) is empty"),
    ("no_gamma_d_block_slides", lambda m, t: ["block", *FAST, "--set", "mesh.dirichlet=[]"],
     "the body is free to move: translation along x; the foundation does not move under it"),
    ("no_gamma_d_block_without_friction", lambda m, t: ["block", *FAST, "--set", "mesh.dirichlet=[]",
                                                        "--set", "contact.friction=0"],
     "the body is free to move: translation along x; its friction does not hold it (contact.friction = 0 where"),
    ("no_gamma_d_block_sheared_off", lambda m, t: ["block", *FAST, "--set", "mesh.dirichlet=[]", "--set",
                                                    "contact.friction=0.3", "--set", 'loads.g={top=["8","-10"]}'],
     # 16 along x against μ = 0.3 times 40 down (the weight 10 · 2 and the top's 10 · 2): 1.33; the law's bound
     # lumped at the vertices of this 4 × 2 mesh's base reads 1.31
     "the body is free to move: translation along x; the loads pull it along the foundation with 1.3"),
    ("empty_gamma_c_gmsh", lambda m, t: [gmsh_problem(m, "interior_base")], "Γ_C (contact) is empty"),
    ("empty_gamma_c_rectangle", lambda m, t: ["block", *FAST, "--set", "mesh.contact=[]"],
     "Γ_C (contact) is empty"),
    ("group_in_two_roles", lambda m, t: ["block", *FAST, "--set", 'mesh.neumann=["top", "bottom"]'],
     "'bottom' is in both neumann and contact"),
    # gmsh meshes
    ("mesh_3d", lambda m, t: [gmsh_problem(m, "box")], "is 3D"),
    ("hexahedral_mesh", lambda m, t: [gmsh_problem(m, "hex")], "group 'body' has Hexahedron 8 elements"),
    ("curve_in_two_groups", lambda m, t: [gmsh_problem(m, "same_curve_twice")], "is in two groups"),
    ("facet_in_two_groups", lambda m, t: [gmsh_problem(m, "duplicate_merged")],
     "a boundary facet is in two groups, 'base' and 'support'"),
    ("duplicate_detached_curve", lambda m, t: [gmsh_problem(m, "duplicate")], "not edges of the cells"),
    ("empty_mesh", lambda m, t: [gmsh_problem(m, "empty")], "no mesh elements"),
    ("rectangle_cells_not_a_list", lambda m, t: ["block", *FAST, "--set", "mesh.cells=3"],
     "mesh.cells must be 2 (rectangle) or 3 (box) positive integers"),
    ("rectangle_corners_malformed", lambda m, t: ["block", *FAST, "--set", "mesh.rectangle=5"],
     "mesh.rectangle must be"),
    # 3D (issue 10, item 11)
    ("load_2_components_on_3d", lambda m, t: ["box", *FAST3D, "--set", 'loads.f=["0","-10"]'],
     "loads.f has 2 components but the mesh is 3D"),
    ("traction_2_components_on_3d", lambda m, t: ["box", *FAST3D, "--set", 'loads.g={top=["0","-20*x"]}'],
     "loads.g.top has 2 components but the mesh is 3D"),
    ("load_3_components_on_2d", lambda m, t: ["block", *FAST, "--set", 'loads.f=["0","0","-10"]'],
     "loads.f has 3 components but the mesh is 2D"),
    ("m_n_above_3_in_3d", lambda m, t: ["box", *FAST3D, "--set", "contact.m_n=3.5"],
     "contact.m_n = 3.5 > 3 on a 3D mesh"),
    ("symmetry_not_planar", lambda m, t: ["hertz3d", "--refine", "none", "--quiet", "--set",
                                          'mesh.symmetry=["symm_x","free"]', "--set", "mesh.neumann=[]"],
     "symmetry group 'free' does not lie in a plane"),
    ("empty_gamma_c_box", lambda m, t: ["box", *FAST3D, "--set", "mesh.contact=[]"], "Γ_C (contact) is empty"),
    # prescribed displacements (loads.u_D)
    ("u_D_wrong_length", lambda m, t: ["block", *FAST, "--set", 'loads.u_D=["0"]'],
     "loads.u_D must be a list of 2 (2D) or 3 (3D) expressions"),
    ("u_D_3_components_on_2d", lambda m, t: ["block", *FAST, "--set", 'loads.u_D={left=["0","0","0"]}'],
     "loads.u_D.left has 3 components but the mesh is 2D"),
    ("u_D_on_a_neumann_group", lambda m, t: ["block", *FAST, "--set", 'loads.u_D={top=["0","0"]}'],
     "loads.u_D has an entry for 'top', which is not a dirichlet group (it is a neumann group"),
    ("u_D_on_an_unknown_group", lambda m, t: ["block", *FAST, "--set", 'loads.u_D={nosuch=["0","0"]}'],
     "loads.u_D has an entry for 'nosuch', which is not a dirichlet group"),
    ("u_D_not_finite", lambda m, t: ["block", *FAST, "--set", 'loads.u_D=["1/x","0"]'],
     "loads.u_D[0] = '1/x' is not finite on the mesh"),
    ("u_D_all_free", lambda m, t: ["block", *FAST, "--set", 'loads.u_D={left=["free","free"]}'],
     "loads.u_D.left: every component is \"free\", so the group holds nothing: list it in mesh.neumann"),
    ("u_D_free_misspelt", lambda m, t: ["block", *FAST, "--set", 'loads.u_D={left=["fre","0"]}'],
     "loads.u_D.left[0]: unknown name 'fre' in expression 'fre' (did you mean \"free\"?)"),
    ("u_D_roller_and_loads_pull_off", lambda m, t: ["block", *FAST, "--set", 'loads.u_D={left=["0","free"]}',
                                                    "--set", 'loads.f=["0","10"]', "--set", 'loads.g={top=["0","20*x"]}'],
     "the body is free to move: translation along y; the loads pull it off the foundation: hold it with"),
    ("u_D_3d_roller_and_loads_pull_off", lambda m, t: ["box", *FAST3D, "--set", 'loads.u_D={left=["0","0","free"]}',
                                                       "--set", 'loads.f=["0","0","10"]', "--set", 'loads.g={top=["0","0","1"]}'],
     "the body is free to move: translation along z; the loads pull it off the foundation"),
    ("nothing_presses_onto_the_foundation", lambda m, t: ["block", *FAST, "--set", "mesh.dirichlet=[]",
                                                          "--set", 'mesh.symmetry=["left"]', "--set", 'loads.f=["0","0"]',
                                                          "--set", 'loads.g={top=["1","0"]}'],
     "the body is free to move: translation along y; nothing presses the body onto the foundation"),
    # contact law
    ("m_n_below_1", lambda m, t: ["block", *FAST, "--set", "contact.m_n=0.5"], "contact.m_n must be >= 1"),
    ("c_n_negative", lambda m, t: ["block", *FAST, "--set", "contact.c_n=-1"], "contact.c_n must be >= 0"),
    ("c_n_negative_on_gamma_c", lambda m, t: ["block", *FAST, "--set", 'contact.c_n="x - 1"'],
     "contact.c_n must be >= 0 on Γ_C"),
    ("gap_negative", lambda m, t: ["block", *FAST, "--set", "contact.gap=-0.1"], "contact.gap must be >= 0"),
    ("gap_negative_on_gamma_c", lambda m, t: ["block", *FAST, "--set", 'contact.gap="x - 1"'],
     "contact.gap must be >= 0 on Γ_C"),
    # material
    ("nu_one_half", lambda m, t: ["block", *FAST, "--set", "material.nu=0.5"], "nu must lie in (-1, 0.5)"),
    ("nu_above_one_half", lambda m, t: ["block", *FAST, "--set", "material.nu=0.7"], "nu must lie in"),
    ("E_zero", lambda m, t: ["block", *FAST, "--set", "material.E=0"], "E must be > 0"),
    ("E_negative", lambda m, t: ["block", *FAST, "--set", "material.E=-5"], "E must be > 0"),
    ("E_nan", lambda m, t: ["block", *FAST, "--set", "material.E=nan"], "material.E must be a finite number"),
    ("c_n_inf", lambda m, t: ["block", *FAST, "--set", "contact.c_n=inf"], "contact.c_n must be a finite number"),
    # expressions
    ("malformed_expression", lambda m, t: ["block", *FAST, "--set", 'contact.c_n="x +* 2"'],
     "malformed expression 'x +* 2'"),
    ("malformed_expression_load", lambda m, t: ["block", *FAST, "--set", 'loads.f=["0", "x +* 2"]'],
     "malformed expression 'x +* 2'"),
    ("unknown_name_expression", lambda m, t: ["block", *FAST, "--set", 'contact.c_n="z + 1"'],
     "unknown name 'z'"),
    ("python_in_expression", lambda m, t: ["block", *FAST, "--set", f'contact.c_n="{INJECTION}"'],
     "is not allowed"),
    ("python_in_constant", lambda m, t: ["block", *FAST, "--set", f'material.E="{INJECTION}"'],
     "is not allowed"),
    # solver
    ("snes_divergence", lambda m, t: ["block", *FAST, "-snes_max_it", "1"], "SNES diverged"),
    ("snes_divergence_basic_linesearch",
     lambda m, t: ["block", *FAST, "-snes_max_it", "1", "-snes_linesearch_type", "basic"], "SNES diverged"),
    ("mumps_ordering_not_built", lambda m, t: ["block", *FAST, "-mat_mumps_icntl_28", "2", "-mat_mumps_icntl_29", "2"],
     "the MUMPS factorisation failed with INFOG(1) = -38"),  # (Debian's MUMPS has no ParMETIS)
    ("unused_petsc_option", lambda m, t: ["block", *FAST, "-snes_tyep", "foo"],
     "PETSc option -snes_tyep was not used by any solver (misspelt?); --allow-unused-petsc-options accepts it"),
    ("unused_petsc_options_in_file", lambda m, t: ["block", *FAST, "--set", "solver.petsc_options.ksp_typo=1",
                                                   "-pc_tipe", "lu"], "PETSc options -ksp_typo, -pc_tipe were not used"),
    ("own_solver_option_not_a_number", lambda m, t: ["block", *FAST, "-atol_of_load", "abc"],
     "solver option atol_of_load must be a number >= 0, got 'abc'"),
    ("own_solver_option_negative_in_file", lambda m, t: ["block", *FAST, "--set",
                                                         "solver.petsc_options.pc_refresh_misfit=-1"],
     "solver option pc_refresh_misfit must be a number >= 0, got '-1'"),
    ("own_solver_option_infinite", lambda m, t: ["block", *FAST, "-atol_of_load", "inf"],  # (was u = 0, exit 0)
     "solver option atol_of_load must be a number >= 0, got 'inf'"),
    ("own_solver_flag_not_a_flag", lambda m, t: ["block", *FAST, "-fallbacks", "maybe"],
     "solver option fallbacks must be true or false, got 'maybe'"),
    ("load_steps_not_integer", lambda m, t: ["block", *FAST, "--set", 'solver.load_steps="x"'],
     "solver.load_steps must be an integer"),
    # PETSc option values (issue 31, item 4): refused before the solve, naming the option and its value
    ("ksp_type_unknown", lambda m, t: ["block", *FAST, "-ksp_type", "bogus"],
     "PETSc option -ksp_type bogus: unknown KSP type (known: bcgs, "),
    ("snes_type_unknown", lambda m, t: ["block", *FAST, "-snes_type", "newtontr2"],
     "PETSc option -snes_type newtontr2: unknown SNES type (did you mean newtontr? known: "),
    ("pc_type_unknown", lambda m, t: ["block", *FAST, "-pc_type", "nosuch"], "PETSc option -pc_type nosuch: unknown PC type"),
    ("linesearch_type_unknown", lambda m, t: ["block", *FAST, "-snes_linesearch_type", "nosuch"],
     "PETSc option -snes_linesearch_type nosuch: unknown line search type (known: basic, "),
    ("ksp_norm_type_unknown", lambda m, t: ["block", *FAST, "-ksp_norm_type", "nosuch"],
     "PETSc option -ksp_norm_type nosuch: unknown norm type (known: none, preconditioned, unpreconditioned, natural)"),
    ("mat_solver_type_unknown", lambda m, t: ["block", *FAST, "-pc_factor_mat_solver_type", "nosuch"],
     "PETSc option -pc_factor_mat_solver_type nosuch: unknown solver type of a factorisation (known: "),
    ("mat_solver_type_not_built", lambda m, t: ["block", *FAST, "-pc_factor_mat_solver_type", "pastix"],
     "PETSc option -pc_factor_mat_solver_type pastix: PETSc refused it: Could not locate solver type pastix"),
    ("hypre_type_unknown", lambda m, t: ["block", *FAST, "-pc_hypre_type", "nosuch"],
     "PETSc option -pc_hypre_type nosuch: unknown hypre type (known: ads, ams, boomeramg, "),
    ("hypre_type_unknown_in_force", lambda m, t: ["block", *FAST, "-pc_type", "hypre", "-pc_hypre_type", "nosuch"],
     "PETSc option -pc_hypre_type nosuch: unknown hypre type"),
    ("level_ksp_type_unknown", lambda m, t: ["block", *FAST, "-pc_type", "gamg", "-mg_levels_ksp_type", "bogus"],
     "PETSc option -mg_levels_ksp_type bogus: unknown KSP type"),
    ("snes_rtol_not_a_number", lambda m, t: ["block", *FAST, "-snes_rtol", "abc"],
     "PETSc option -snes_rtol abc: not a number (expected a number >= 0 and < 1)"),
    ("snes_max_it_negative", lambda m, t: ["block", *FAST, "-snes_max_it", "-5"],
     "PETSc option -snes_max_it -5: must be a whole number >= 0"),
    ("mumps_control_not_a_number", lambda m, t: ["block", *FAST, "-mat_mumps_icntl_7", "abc"],
     "PETSc option -mat_mumps_icntl_7 abc: not a number (expected a whole number)"),
    ("petsc_flag_not_a_flag", lambda m, t: ["block", *FAST, "-snes_ksp_ew", "maybe"],
     "PETSc option -snes_ksp_ew maybe: not true or false"),
    ("ksp_type_unknown_in_file", lambda m, t: ["block", *FAST, "--set", 'solver.petsc_options={ksp_type="bogus"}'],
     "PETSc option -ksp_type bogus: unknown KSP type"),
    ("snes_rtol_not_a_number_in_file", lambda m, t: ["block", *FAST, "--set", 'solver.petsc_options.snes_rtol="abc"'],
     "PETSc option -snes_rtol abc: not a number"),
    ("snes_max_it_flag_in_file", lambda m, t: ["block", *FAST, "--set", "solver.petsc_options.snes_max_it=true"],
     "PETSc option -snes_max_it true: not a number (expected a whole number >= 0)"),
    ("snes_max_it_fraction_in_file", lambda m, t: ["block", *FAST, "--set", "solver.petsc_options.snes_max_it=2.5"],
     "PETSc option -snes_max_it 2.5: must be a whole number >= 0"),
    # command line
    ("set_without_equals", lambda m, t: ["block", *FAST, "--set", "contact.m_n"], "--set expects KEY=VALUE"),
    ("set_without_key", lambda m, t: ["block", *FAST, "--set", "=2"], "--set expects KEY=VALUE"),
    ("set_into_a_value", lambda m, t: ["block", *FAST, "--set", "mesh.rectangle.x=1"],
     "'rectangle' is not a table"),
    ("unknown_cli_argument", lambda m, t: ["block", *FAST, "--no-such-option"],
     "unknown option '--no-such-option'"),
    ("single_dash_option", lambda m, t: ["block", *FAST, "-levels", "3"],
     "unknown option '-levels' (did you mean --levels?)"),
    ("bad_option_value", lambda m, t: ["block", *FAST, "--levels", "many"], "argument --levels"),
    ("fractional_count", lambda m, t: ["block", *FAST, "--max-dofs", "12.5"],
     "argument --max-dofs: expected a whole number (e.g. 400000 or 4e5), got '12.5'"),
    ("bad_option_choice", lambda m, t: ["block", "--refine", "sideways"], "argument --refine"),
    ("bad_load_steps_option", lambda m, t: ["block", *FAST, "--load-steps", "0"], "solver.load_steps must be >= 1"),
    # load paths
    ("step_sets_unknown_parameter", lambda m, t: ["block", *FAST, "--set", "parameters.p=1",
                                                  "--set", "steps=[{set = {q = 2}}]"],
     "steps[1].set.q: no such parameter in [parameters] (known: p)"),
    ("steps_not_tables", lambda m, t: ["block", *FAST, "--set", "steps=[1, 2]"],
     "steps must be an array of tables ([[steps]] in TOML)"),
    ("step_without_set", lambda m, t: ["block", *FAST, "--set", "steps=[{increments = 2}]"],
     "steps[1].set must be a table naming at least one parameter"),
    ("step_zero_increments", lambda m, t: ["block", *FAST, "--set", "parameters.p=1",
                                           "--set", "steps=[{set = {p = 2}, increments = 0}]"],
     "steps[1].increments must be >= 1"),
    ("step_reaches_bad_material", lambda m, t: ["block", *FAST, "--set", "parameters.E0=1000",
                                                "--set", 'material.E="E0"', "--set", "steps=[{set = {E0 = -1}}]"],
     "steps[1] leads to a bad problem: material.E must be > 0"),
]


@pytest.mark.parametrize("make_args, expected", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input(msh, tmp_path, make_args, expected):
    out = tmp_path / "out"
    result = cli([*make_args(msh, tmp_path), "--out", out], cwd=tmp_path)
    assert_bad_input(result, expected, out)
    assert not (tmp_path / "PWNED").exists() and not (ROOT / "PWNED").exists(), "an expression ran Python"


# Representative cases on 2 ranks: one error line (not one per rank), non-zero exit, no results, no hang.
MPI_CASES = ["unknown_group_rectangle", "m_n_below_1", "snes_divergence", "mesh_3d", "empty_mesh",
             "facet_in_two_groups", "c_n_negative_on_gamma_c", "bad_option_value", "unused_petsc_option",
             "quad_mesh", "m_n_above_3_in_3d", "symmetry_not_planar", "hexahedral_mesh", "empty_gamma_c_box",
             "ksp_type_unknown", "snes_rtol_not_a_number", "mat_solver_type_not_built", "u_D_not_finite",
             "u_D_3d_roller_and_loads_pull_off", "no_gamma_d_block_slides", "step_reaches_bad_material",
             "no_gamma_d_block_sheared_off"]


@pytest.mark.parametrize("name", MPI_CASES)
def test_bad_input_two_ranks(msh, tmp_path, name):
    _, make_args, expected = next(c for c in CASES if c[0] == name)
    out = tmp_path / "out"
    result = cli([*make_args(msh, tmp_path), "--out", out], nprocs=2, cwd=tmp_path)
    assert_bad_input(result, expected, out, nprocs=2)


@pytest.mark.parametrize("bad", [["-ksp_type", "bogus"], ["-snes_max_it", "-5"], ["-pc_factor_mat_solver_type", "pastix"]],
                         ids=["type", "number", "set_up"])
def test_bad_petsc_value_stops_before_the_solve(tmp_path, bad):
    """A bad PETSc option value ends the run before SNES evaluates a residual (-snes_monitor stays silent),
    also one that PETSc would meet only at the first preconditioner set-up, inside the first Newton step."""
    out = tmp_path / "out"
    result = cli(["block", *FAST, "-snes_monitor", *bad, "--out", out], cwd=tmp_path)
    assert_bad_input(result, f"PETSc option {' '.join(bad)}: ", out)
    assert "SNES Function norm" not in result.stdout + result.stderr


# mesh.file is read as a mesh only (issue 31, item 1): gmsh runs anything else as a script, whose SystemCall
# runs a command; so is an options file <mesh>.msh.opt beside a good mesh.
HOSTILE = 'SystemCall "touch CANARY";\n'
MESH_FILES = [
    ("script_named_msh", "x.msh", HOSTILE, "x.msh' is not a gmsh .msh file (it does not start with $MeshFormat)"),
    ("script_named_geo", "x.geo", HOSTILE, "x.geo' is not a gmsh .msh file (its name does not end in .msh)"),
    ("empty", "x.msh", "", "x.msh' is not a gmsh .msh file (it is empty)"),
    ("header_not_first", "x.msh", "\n$MeshFormat\n" + HOSTILE, "x.msh' is not a gmsh .msh file (it does not start"),
]


@pytest.mark.parametrize("nprocs", [1, 2])
@pytest.mark.parametrize("name, text, expected", [c[1:] for c in MESH_FILES], ids=[c[0] for c in MESH_FILES])
def test_mesh_file_is_read_as_a_mesh_only(tmp_path, name, text, expected, nprocs):
    (tmp_path / name).write_text(text)
    problem = gmsh_problem(tmp_path, "x")
    problem.write_text(problem.read_text().replace('"x.msh"', f'"{name}"'))
    out = tmp_path / "out"
    result = cli([problem, "--refine", "none", "--quiet", "--out", out], nprocs=nprocs, cwd=tmp_path)
    assert_bad_input(result, expected, out, nprocs=nprocs)
    assert not (tmp_path / "CANARY").exists(), "gmsh ran the file as a script"


def test_options_file_beside_the_mesh_is_not_run(msh, tmp_path):
    """gmsh merges <file>.opt after <file> as a script: it must not see the user's one."""
    (tmp_path / "good.msh").write_bytes((msh / "good.msh").read_bytes())
    (tmp_path / "good.msh.opt").write_text(HOSTILE)
    out = tmp_path / "out"
    result = cli([gmsh_problem(tmp_path, "good"), "--refine", "none", "--quiet", "--out", out], cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert not (tmp_path / "CANARY").exists(), "gmsh ran good.msh.opt as a script"


@pytest.mark.parametrize("overwrite", [False, True], ids=["plain", "overwrite"])
def test_foreign_folder_is_left_alone(tmp_path, overwrite):
    """An --out holding files nc_dolfinx did not write is refused, with or without --overwrite, untouched."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("not ours\n")
    result = cli(["block", *FAST, "--out", out] + (["--overwrite"] if overwrite else []), cwd=tmp_path)
    expected = "is not an nc_dolfinx result folder" if overwrite else "is not empty"
    assert_bad_input(result, expected, out, allowed=("keep.txt",))
    assert (out / "keep.txt").read_text() == "not ours\n"


# --out places that cannot be a result folder, on 1, 2 and 3 ranks: one line from every rank together, no
# rank left waiting (rank 0 decides about the file system and tells the others).
OUT_CASES = [
    ("out_is_a_file", lambda t: t / "F", "is a file, not a folder"),
    ("out_under_a_file", lambda t: t / "F" / "sub", "is a file"),
    ("out_cannot_be_created", lambda t: Path("/proc/nc_dolfinx_out"), "cannot create --out '/proc/nc_dolfinx_out'"),
    ("out_not_empty", lambda t: t / "full", "is not empty (a result folder holds one run)"),
]


@pytest.mark.parametrize("nprocs", [1, 2, 3])
@pytest.mark.parametrize("make_out, expected", [c[1:] for c in OUT_CASES], ids=[c[0] for c in OUT_CASES])
def test_unusable_out(tmp_path, make_out, expected, nprocs):
    (tmp_path / "F").write_text("a file\n")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("someone's notes\n")
    out = make_out(tmp_path)
    result = cli(["block", *FAST, "--out", out], nprocs=nprocs, cwd=tmp_path)
    assert_bad_input(result, expected, out if out.is_dir() else tmp_path / "nothing", nprocs=nprocs,
                     allowed=("notes.txt",))
    assert (tmp_path / "F").read_text() == "a file\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["F", "full"]


# The positive controls: the same templates without the fault do run (so the failures above are the faults).

def test_control_block_runs(tmp_path):
    out = tmp_path / "out"
    result = cli(["block", *FAST, "--out", out], cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (out / "summary.json").is_file() and not list(out.glob(".partial-*"))


def test_control_gmsh_problem_runs(msh, tmp_path):
    out = tmp_path / "out"
    result = cli([gmsh_problem(msh, "good"), "--refine", "none", "--quiet", "--out", out], cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (out / "summary.json").is_file() and not list(out.glob(".partial-*"))


# Arithmetic errors in problem-file expressions and non-numeric [adapt] values.
EVALUATION = [
    ("division_by_zero_expression", ["--set", 'contact.c_n="1/0"'], "1/0"),
    ("complex_expression", ["--set", 'contact.c_n="sqrt(-1)"'], "sqrt(-1)"),
    ("log_of_zero_expression", ["--set", 'loads.f=["0", "log(0)"]'], "log(0)"),
    ("overflow_expression", ["--set", 'contact.c_n="10.0**1000"'], "10.0**1000"),
    ("division_by_zero_with_x", ["--set", 'contact.c_n="x + 1/0"'], "1/0"),
    ("adapt_levels_not_integer", ["--set", 'adapt.levels="x"', "--refine", "uniform"], "levels"),
]


@pytest.mark.parametrize("extra, expected", [k[1:] for k in EVALUATION], ids=[k[0] for k in EVALUATION])
def test_bad_expression_values(tmp_path, extra, expected):
    out = tmp_path / "out"
    result = cli(["block", *FAST, *extra, "--out", out], cwd=tmp_path)
    assert_bad_input(result, expected, out)
