"""What a solution says about each pair of two bodies: the force between them, its contact zone and peak.

The force on the body of a pair's first face is what the residual of (7) carries (its resultant over that
body's dofs): with the rows of :mod:`.coupling`, −Σ w_q p_q ν_A over the first face's points plus
Σ w_q p_q ν_B over the second face's (Σ_i λ_i = 1 at every point), so that reactions, loads and pair forces
balance body by body to the solver's tolerance; the force on the other body is its opposite.
"""
import numpy as np
from mpi4py import MPI


def pair_quantities(u, fields):
    """What a solution of (7) with [[pairs]] says of each pair k (1-based), the law (4) across two bodies:
    ``pair{k}_force`` (the vector the second face's body exerts on the first's),
    ``pair{k}_resultant`` (∫ p over the first face: the normal force, as ``contact_resultant`` for Γ_C),
    ``pair{k}_contact_length`` (2D) or ``_contact_area`` (3D) (the measure of {p > 0} on the first face),
    ``pair{k}_max_pressure`` and ``pair{k}_max_penetration`` (at the integration points of both faces);
    with ``friction``: ``pair{k}_friction_force`` (the tangential part of ``pair{k}_force``: the law's
    traction at the faces' vertices, :mod:`.friction`), ``pair{k}_stick_length``/``_slip_length`` (2D;
    ``_area`` in 3D)."""
    coupling = fields.pair_coupling(u)
    pressure, penetration = coupling.pressure(), np.maximum(coupling.penetration(), 0.0)
    comm, gdim = fields.domain.comm, fields.dim
    out = {}
    for pair in fields.pairs:
        force, measure, resultant, peak, deepest = np.zeros(gdim), 0.0, 0.0, 0.0, 0.0
        for rows, where in coupling.by_rows():
            if rows.pair is not pair:
                continue
            p = pressure[where]
            force += (-1.0 if rows.side == 0 else 1.0) * (rows.w * p) @ rows.direction
            if rows.side == 0:
                measure += float(rows.measure[p > 0].sum())
                resultant += float(rows.measure @ p)
            peak = max(peak, float(p.max(initial=0.0)))
            deepest = max(deepest, float(penetration[where].max(initial=0.0)))
        k = pair.number
        if pair.friction is not None:
            frictional = _friction_quantities(coupling.friction, pair, comm, gdim)
            force += frictional.pop("friction_force")
            out[f"pair{k}_friction_force"] = frictional.pop("friction_force_total")
            out.update({f"pair{k}_{name}": value for name, value in frictional.items()})
        out[f"pair{k}_force"] = [float(f) for f in comm.allreduce(force, op=MPI.SUM)]
        out[f"pair{k}_resultant"] = comm.allreduce(resultant, op=MPI.SUM)
        out[f"pair{k}_contact_{'length' if gdim == 2 else 'area'}"] = comm.allreduce(measure, op=MPI.SUM)
        out[f"pair{k}_max_pressure"] = comm.allreduce(peak, op=MPI.MAX)
        out[f"pair{k}_max_penetration"] = comm.allreduce(deepest, op=MPI.MAX)
    return out


def _friction_quantities(friction, pair, comm, gdim):
    """A frictional pair's ``friction_force`` (this rank's part: Σ w σ_t over the first face's vertices
    minus over the second's, σ_t the traction on each face's own body, :mod:`.friction`), and over all
    ranks ``friction_force`` again (the sum), ``stick_length``/``slip_length`` (2D; ``_area`` in 3D: the
    measure of the first face's vertices in contact that stick, that slip)."""
    force, stick, slip = np.zeros(gdim), 0.0, 0.0
    for rows, where, active, sticking, traction in friction.vertex_states():
        if rows.pair is not pair:
            continue
        force += (1.0 if rows.side == 0 else -1.0) * rows.w @ traction
        if rows.side == 0:
            stick += float(rows.measure[sticking].sum())
            slip += float(rows.measure[active & ~sticking].sum())
    size = "length" if gdim == 2 else "area"
    total = comm.allreduce(force, op=MPI.SUM)
    return {"friction_force": force, "friction_force_total": [float(f) for f in total],
            f"stick_{size}": comm.allreduce(stick, op=MPI.SUM), f"slip_{size}": comm.allreduce(slip, op=MPI.SUM)}


def pair_pressure(u, fields, number=1, side=0):
    """The pressure p = c_n (u_n − g_0)_+^{m_n} of the law (4) across pair ``number`` (1-based) at this rank's
    integration points of its first (``side`` 0) or second face: (points (n, gdim), p (n,)). For plots and checks (the points of each face of each
    rank: gather them to plot one face)."""
    coupling = fields.pair_coupling(u)
    pressure = coupling.pressure()
    for rows, where in coupling.by_rows():
        if rows.pair.number == number and rows.side == side:
            return rows.x, pressure[where].copy()
    raise ValueError(f"no pair {number} (pairs: 1 to {len(fields.pairs)})")
