"""The prose of the friction sections of verification/report.md (studies 14–16; every number is in the tables)."""
from checks_friction import ORDER, TITLES

PROSE = {
    "friction_exact": """A layer [0, 2] × [0, 1] (3D: × [0, 1]) on the foundation (c_n = 100 E, μ = 0.3, ε_r = 1e-3), its
top clamped to a prescribed shear and compression, its sides loaded by the exact tractions (`tests/mpi/sheared_layer.py`):
the linear u is an exact state of the regularised Coulomb law, in stick (pre-slip ε_r d Gγ/(μP) for a shear Gγ = 0.8 μP)
and in slip (Gγ = μP, slip 5 ε_r d), so P1 must hold it to the solver's tolerance and η must vanish — η_3 measures
the residual of the friction law, not σ_t, which equals the friction traction here. In slip the bound holds with
equality, which leaves the slip determined only through the normal law's penetration d: the nodal error there is the
solver's tolerance magnified by that. Last, friction = 0 solves exactly the frictionless problem.
""",
    "friction_manufactured": """The cases `manufactured_friction` (2D) and `manufactured_friction3d`: a smooth exact u whose
tangential slip on Γ_C changes direction, so that Γ_C has a stick zone (2D: a band; 3D: a curved region) and slip zones
beside it; both laws hold exactly through the gap g_0 and a space-dependent bound c_t built from u (checked with sympy in
`tests/test_friction_manufactured.py`, construction in `docs/src/manufactured_friction.md`). Uniform refinement from
8×8 (2D) and 6³ (3D); the friction force against its exact value, the stick zone's measure against the exact 0.2991
(2D: Σ ∫ φ_i over the vertices the law holds stuck, since issue 50 — within a vertex patch of the exact zone). Last, `manufactured_friction_layer` and `manufactured_friction_layer3d`: the same plus a narrow smooth bump
inside the body (from 8×8 and 4³), where adaptive refinement must pay (`docs/src/manufactured_friction_layer.md`).
""",
    "cattaneo": """Cattaneo–Mindlin partial slip (`docs/src/cattaneo.md`, `docs/src/cattaneo3d.md`): a half-disc (2D, the
`hertz` mesh) and a half ball (3D, one symmetry plane) pressed by their clamped tops onto a nearly rigid foundation
(c_n = 1e3 E) without friction, friction μ = 0.3 switched on in a step of its own, then the top moved sideways. P and Q
are the top's normal reaction and the friction force; a is half the contact length (the radius of the half disc of
the contact area), c/a the stuck part of the friction law's contact zone (its vertices, weighted by ∫ φ_i: half a
length, the square root of an area). The differences from the half-space theory: the element size at the zone ends
(c/a within +0.0009 … +0.0055 of CM on meshes refined once or twice, 2D), the rigid base with ν = 0.3 (the
normal–tangential coupling that Mindlin neglects), the penalty, the finite body.
""",
}


def compose_friction(sec, section_md):
    """Markdown of studies 14–16, for those that ran."""
    out = []
    for key in ORDER:
        if key in sec:
            out += [f"## {TITLES[key]}\n", PROSE[key], section_md(sec[key])]
    return "\n".join(out)
