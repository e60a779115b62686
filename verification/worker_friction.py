"""The computations of the friction studies (issue 32), run under MPI by verify.py like worker.py:

    mpirun -n N /usr/bin/python3 verification/worker_friction.py STUDY --mode quick|full --out RESULT.json

- ``friction_exact``: the sheared layer of tests/mpi/sheared_layer.py (an exact linear state of the
  regularised Coulomb law, stick and slip, 2D and 3D) and μ = 0 against the frictionless problem;
- ``friction_manufactured``: the manufactured frictional solutions with stick and slip zones
  (cases manufactured_friction and manufactured_friction3d), uniform refinement and Dörfler's, and
  manufactured_friction_layer and ...layer3d (a narrow bump inside the body), where adaptivity must pay;
- ``cattaneo``: Cattaneo–Mindlin partial slip of a cylinder and of a sphere (cases cattaneo, cattaneo3d).
Only the public API; one JSON file (rank 0).
"""
import sys

import numpy as np

from common import ROOT
from worker import COMM, clean_row, main, uniform_settings

import nc_dolfinx as nc

sys.path.insert(0, str(ROOT / "tests"))
from mpi.sheared_layer import exact_state, layer_problem, outcome  # noqa: E402

CONFIG = {
    "quick": {"cattaneo": {}, "friction_exact": {"layers": [[2, "stick", 1.0], [2, "slip", 1.0], [3, "stick", 1.0]]},
              "friction_manufactured": {"levels_2d": 4, "levels_3d": 3, "adaptive_levels_2d": 8, "layer_levels": 5,
                                        "layer3d_levels": 3}},
    "full": {"cattaneo": {}, "friction_exact": {"layers": [[2, "stick", 1.0], [2, "slip", 1.0], [2, "slip", 1.5], [3, "stick", 1.0],
                                           [3, "slip", 1.5]]},
             "friction_manufactured": {"levels_2d": 5, "levels_3d": 3, "adaptive_levels_2d": 12, "layer_levels": 6,
                                       "layer3d_levels": 4}},
}
FRICTION_KEYS = ("friction_force", "stick_length", "slip_length", "stick_area", "slip_area", "max_slip",
                 "friction_passes", "friction_newton")


def row_of(row):
    clean = clean_row(row)
    clean.update({k: row[k] for k in FRICTION_KEYS if k in row})
    return clean


def study_friction_exact(cfg):
    layers = []
    for dim, mode, m_n in cfg["layers"]:
        result = outcome(nc.adapt(layer_problem(dim, mode, m_n)), dim, mode, m_n)
        result.pop("x"), result.pop("u")
        layers.append({"dim": dim, "mode": mode, "m_n": m_n, **result})
    frictional = layer_problem(2, "slip", 1.0, friction=0.0)
    raw = dict(frictional.raw)
    raw["contact"] = {k: v for k, v in raw["contact"].items() if k not in ("friction", "slip_regularisation")}
    u, v = (nc.adapt(p).final.u.x.array for p in (frictional, nc.Problem.from_dict(raw, "frictionless")))
    difference = COMM.allreduce(float(np.abs(u - v).max(initial=0.0)), op=max_op())
    scale = COMM.allreduce(float(np.abs(v).max(initial=0.0)), op=max_op())
    return {"layers": layers, "zero_friction": difference / scale,
            "eps_r": float(layer_problem(2, "stick", 1.0).values["contact"]["slip_regularisation"]),
            "depth": exact_state(2, "stick", 1.0)[3]}


def max_op():
    from mpi4py import MPI
    return MPI.MAX


def study_friction_manufactured(cfg):
    out = {}
    for dim, levels in ((2, cfg["levels_2d"]), (3, cfg["levels_3d"])):
        case = "manufactured_friction" if dim == 2 else "manufactured_friction3d"
        overrides = [] if dim == 2 else ["mesh.cells=[6,6,6]"]
        problem = nc.load_problem(case, overrides)
        out[f"uniform{dim}"] = [row_of(r) for r in nc.adapt(problem, uniform_settings(levels)).history]
        if dim == 2:
            settings = nc.AdaptSettings.from_problem(problem, refine="adaptive", levels=cfg["adaptive_levels_2d"],
                                                     max_dofs=out["uniform2"][-1]["dofs"])
            out["adaptive2"] = [row_of(r) for r in nc.adapt(problem, settings).history]
    for key, case in (("layer", "manufactured_friction_layer"), ("layer3d", "manufactured_friction_layer3d")):
        layer = nc.load_problem(case)
        uniform = [row_of(r) for r in nc.adapt(layer, uniform_settings(cfg[f"{key}_levels"])).history]
        settings = nc.AdaptSettings.from_problem(layer, refine="adaptive", levels=20, max_dofs=uniform[-1]["dofs"])
        out[f"{key}_uniform"], out[f"{key}_adaptive"] = uniform, [row_of(r) for r in nc.adapt(layer, settings).history]
    return out


def study_cattaneo(cfg):
    """Cattaneo–Mindlin partial slip: the cylinder (case cattaneo) and the sphere (cattaneo3d), measured by
    verification/cattaneo.py and cattaneo3d.py."""
    sys.path.insert(0, str(ROOT / "verification"))
    import cattaneo
    import cattaneo3d
    cylinder = cattaneo.measure(cattaneo.case_problem())
    cylinder.pop("profile", None)
    sphere, _, seconds = cattaneo3d.run()
    return {"cylinder": cylinder, "sphere": sphere, "sphere_seconds": seconds}


STUDIES = {"friction_exact": study_friction_exact, "friction_manufactured": study_friction_manufactured,
           "cattaneo": study_cattaneo}

if __name__ == "__main__":
    sys.exit(main(STUDIES, CONFIG, with_output_path=()))
