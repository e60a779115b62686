"""What a run writes: the VTU files (read back and checked against the XDMF/HDF5 files and against the
stress recomputed from the displacement), the CSV columns, and their documentation.
"""
import base64
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from conftest import history, summary
from test_bad_input import cli

RUN = ["block", "--refine", "adaptive", "--levels", "2", "--set", "mesh.cells=[8,4]", "--quiet"]
E, NU = 1.0e3, 0.3  # block.toml's material


# --- a reader for the files nc_dolfinx.output.vtu writes (independent of the writer) ---------------------------

def decode(element):
    """A DataArray written as base64 with its own base64 UInt64 byte count (the 12 first characters)."""
    dtype = {"Float64": np.float64, "Int64": np.int64, "Int32": np.int32, "UInt8": np.uint8}[element.get("type")]
    text = element.text.strip()
    nbytes = int(np.frombuffer(base64.b64decode(text[:12]), dtype=np.uint64)[0])
    data = np.frombuffer(base64.b64decode(text[12:]), dtype=dtype)
    assert data.nbytes == nbytes
    components = int(element.get("NumberOfComponents", 1))
    return data.reshape(-1, components) if components > 1 else data


def read_pvtu(path):
    """(points, cells, point data, cell data) of every piece of a .pvtu, concatenated."""
    path = Path(path)
    pieces = [path.parent / p.get("Source") for p in ET.parse(path).getroot().iter("Piece")]
    points, cells, pdata, cdata, offset = [], [], {}, {}, 0
    for piece_path in pieces:
        piece = ET.parse(piece_path).getroot().find("UnstructuredGrid/Piece")
        arrays = {a.get("Name"): decode(a) for a in piece.iter("DataArray")}
        x = arrays.pop("Points")
        offsets = arrays.pop("offsets")
        k = int(offsets[0]) if len(offsets) else 3
        points.append(x)
        cells.append(arrays.pop("connectivity").reshape(-1, k) + offset)
        offset += len(x)
        for tag, store in (("PointData", pdata), ("CellData", cdata)):
            for a in piece.find(tag).iter("DataArray"):
                store.setdefault(a.get("Name"), []).append(decode(a))
    join = lambda store: {name: np.concatenate(parts) for name, parts in store.items()}  # noqa: E731
    return np.concatenate(points), np.concatenate(cells), join(pdata), join(cdata)


def read_h5(path):
    import h5py
    with h5py.File(path, "r") as f:
        x = f["Mesh/mesh/geometry"][:]
        cells = f["Mesh/mesh/topology"][:]
        functions = {name: f[f"Function/{name}/0"][:] for name in f["Function"]}
    return x, cells, functions


def keys(x, digits=9):
    return [tuple(row) for row in np.round(x[:, :2], digits)]


# --- the run -------------------------------------------------------------------------------------------

@pytest.fixture(scope="module", params=[1, 3], ids=["1rank", "3ranks"])
def result(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(f"vtu{request.param}") / "out"
    done = cli([*RUN, "--out", out], nprocs=request.param)
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def test_vtu_matches_the_xdmf_files(result):
    """Every level's displacement and indicators, and the final contact pressure and von Mises stress, in
    the VTU pieces are the values of the XDMF/HDF5 files, point by point and cell by cell."""
    steps = [d.get("file") for d in ET.parse(result / "solution.pvd").getroot().iter("DataSet")]
    assert steps == [f"levels/level_{n:02d}.pvtu" for n in range(len(history(result)))]
    for n, step in enumerate(steps):
        x, cells, pdata, cdata = read_pvtu(result / step)
        h5 = read_h5(result / "levels" / f"level_{n:02d}.h5")
        names = ["eta", "eta_1", "eta_4", "zeta"]
        if n == len(steps) - 1:
            h5 = read_h5(result / "solution.h5")
            names += ["von_mises"]
        hx, hcells, functions = h5
        assert len(cells) == len(hcells) == history(result)[n]["cells"]  # the pieces tile the mesh once
        node = dict(zip(keys(hx), range(len(hx))))
        at = np.array([node[k] for k in keys(x)])
        assert np.allclose(pdata["displacement"][:, :2], functions["displacement"][at, :2], rtol=0, atol=1e-12)
        assert np.all(pdata["displacement"][:, 2] == 0)  # 2D, padded for ParaView's warp
        if "contact_pressure" in functions:
            assert np.allclose(pdata["contact_pressure"], functions["contact_pressure"][at, 0], atol=1e-10)
        cell = dict(zip(keys(hx[hcells].mean(axis=1)), range(len(hcells))))
        which = np.array([cell[k] for k in keys(x[cells].mean(axis=1))])
        for name in names:
            assert np.allclose(cdata[name], functions[name][which, 0], rtol=1e-12, atol=1e-14), name


def test_vtu_stress_is_the_plane_strain_stress_of_the_displacement(result):
    """σ from the P1 displacement of each cell (its exact gradient), with σ_zz = λ tr ε; von Mises of it."""
    n = len(history(result)) - 1
    x, cells, pdata, cdata = read_pvtu(result / "levels" / f"level_{n:02d}.pvtu")
    lmbda, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    X, U = x[cells][:, :, :2], pdata["displacement"][cells][:, :, :2]   # (cells, 3 vertices, 2)
    dX, dU = X[:, 1:] - X[:, :1], U[:, 1:] - U[:, :1]
    grad = np.linalg.solve(dX, dU).transpose(0, 2, 1)  # du_i/dx_j: dU = dX grad^T on a P1 cell
    eps = 0.5 * (grad + grad.transpose(0, 2, 1))
    tr = np.trace(eps, axis1=1, axis2=2)
    sigma = np.zeros((len(cells), 3, 3))
    sigma[:, :2, :2] = 2 * mu * eps
    sigma[:, [0, 1, 2], [0, 1, 2]] += lmbda * tr[:, None]
    written = cdata["stress"].reshape(-1, 3, 3)
    scale = np.abs(sigma).max()
    assert np.allclose(written, sigma, rtol=0, atol=1e-9 * scale)
    s = sigma - np.trace(sigma, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
    assert np.allclose(cdata["von_mises"], np.sqrt(1.5 * np.einsum("cij,cij->c", s, s)), atol=1e-9 * scale)
    area = 0.5 * np.abs(np.linalg.det(dX)).sum()
    assert abs(area - 2.0) < 1e-12  # block [0, 2] x [0, 1]: no cell twice, none missing
    assert cdata["region"].dtype == np.int32 and len(cdata["region"]) == len(cells)


def test_csv_splits_the_contact_force(result):
    import csv
    with open(result / "history.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert "contact_force" not in rows[0]
    for row, level in zip(rows, history(result)):
        force = [float(row[f"contact_force_{axis}"]) for axis in "xy"]
        assert force == level["contact_force"] and level["contact_force"][1] > 0  # pushes the body up


def test_every_column_is_documented(tmp_path, result):
    """Every CSV column of a run with an exact solution and of an adaptive run has a meaning."""
    from nc_dolfinx.output import columns
    out = tmp_path / "manufactured"
    done = cli(["manufactured", "--refine", "uniform", "--levels", "2", "--quiet", "--out", out])
    assert done.returncode == 0, done.stdout + done.stderr
    for folder in (out, result):
        header = (folder / "history.csv").read_text().splitlines()[0].split(",")
        assert [c for c in header if columns.describe(c) is None] == []
        assert set(summary(folder)["columns"]) == set(header)


def test_vtu_writer_in_3d(tmp_path):
    """A 3D mesh: a P1 vector u(x) = (x, 2y, 3z) and a DG0 tensor T = outer(c, c) of the cell centroid c,
    read back at the written points and cells."""
    from mpi4py import MPI
    import dolfinx
    from dolfinx import fem
    from nc_dolfinx import dolfinx_versions as versions
    from nc_dolfinx.output import vtu
    msh = dolfinx.mesh.create_unit_cube(MPI.COMM_SELF, 2, 2, 2)
    u = fem.Function(versions.p1_space(msh, (3,)))
    u.interpolate(lambda x: np.stack([x[0], 2 * x[1], 3 * x[2]]))
    T = fem.Function(versions.dg0_space(msh, (3, 3)))
    T.interpolate(lambda x: np.einsum("ip,jp->ijp", x, x).reshape(9, -1))
    vtu.write(MPI.COMM_SELF, tmp_path, "cube", {"displacement": u}, {"T": T})
    x, cells, pdata, cdata = read_pvtu(tmp_path / "cube.pvtu")
    assert cells.shape == (48, 4) and len(x) == 27
    assert np.allclose(pdata["displacement"], x * [1, 2, 3], atol=1e-14)
    c = x[cells].mean(axis=1)
    assert np.allclose(cdata["T"], np.einsum("ci,cj->cij", c, c).reshape(-1, 9), atol=1e-14)
    volume = np.abs(np.linalg.det(x[cells][:, 1:] - x[cells][:, :1])).sum() / 6
    assert abs(volume - 1.0) < 1e-12


def test_clean_up_removes_staging_files_a_signal_left_unrecorded(tmp_path):
    """A Ctrl-C between a temporary file's creation and its record left it behind (seen in CI): the
    clean-up after an interruption removes every file and folder named like ours, and only those."""
    from mpi4py import MPI
    from nc_dolfinx.output.files import ResultFolder
    folder = ResultFolder(tmp_path / "out", MPI.COMM_SELF)
    folder.open()
    (folder.path / "levels").mkdir()
    (folder.path / "history.csv").write_text("kept")
    (folder.path / "levels" / "level_00.xdmf").write_text("kept")
    unrecorded = [folder.path / ".history.0123abcd.tmp.csv", folder.path / "levels" / ".plot.99.tmp.png",
                  folder.path / ".probe-x1y2"]
    for path in unrecorded:
        path.write_text("partial")
    (folder.path / ".partial-abc").mkdir()
    (folder.path / ".partial-abc" / "piece_0.vtu").write_text("partial")
    folder.replace("summary.json", lambda tmp: Path(tmp).write_text("{}"))
    folder.clean_up(kept=True)
    left = sorted(str(p.relative_to(folder.path)) for p in folder.path.rglob("*"))
    assert left == ["history.csv", "levels", "levels/level_00.xdmf", "summary.json"]
