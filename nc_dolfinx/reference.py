"""Closed-form references printed beside computed values (problem file ``[reference]``)."""
import math


def hertz_line_contact(force_per_length, radius, E, nu):
    """2D Hertz contact of a cylinder on a rigid flat (plane strain): half-width a and peak pressure p_0.

    a = sqrt(4 P R / (π E*)), p_0 = 2 P / (π a), E* = E / (1 − ν²).
    """
    E_star = E / (1 - nu ** 2)
    a = math.sqrt(4 * force_per_length * radius / (math.pi * E_star))
    return {"half_width": a, "peak_pressure": 2 * force_per_length / (math.pi * a) if a > 0 else 0.0}


def compare(problem, row):
    """Rows of (quantity, computed, reference) for the problem's [reference] table."""
    ref = problem.reference
    if "hertz_radius" not in ref:
        return []
    hertz = hertz_line_contact(row["contact_resultant"], float(ref["hertz_radius"]), problem.E, problem.nu)
    return [("contact half-width", row["contact_length"] / 2, hertz["half_width"]),
            ("peak contact pressure", row["max_contact_pressure"], hertz["peak_pressure"])]
