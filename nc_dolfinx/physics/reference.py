"""Closed-form references printed beside computed values (problem file ``[reference]``)."""
import math


def hertz_line_contact(force_per_length, radius, E, nu):
    """2D Hertz contact of a cylinder on a rigid flat (plane strain): half-width a and peak pressure p_0.

    a = sqrt(4 P R / (π E*)), p_0 = 2 P / (π a), E* = E / (1 − ν²).
    """
    E_star = E / (1 - nu ** 2)
    a = math.sqrt(4 * force_per_length * radius / (math.pi * E_star))
    return {"half_width": a, "peak_pressure": 2 * force_per_length / (math.pi * a) if a > 0 else 0.0}


def hertz_sphere_contact(force, radius, E, nu):
    """3D Hertz contact of a sphere on a rigid flat: contact radius a and peak pressure p_0.

    a = (3 F R / (4 E*))^{1/3}, p_0 = 3 F / (2 π a²), E* = E / (1 − ν²).
    """
    E_star = E / (1 - nu ** 2)
    a = (3 * force * radius / (4 * E_star)) ** (1 / 3)
    return {"radius": a, "peak_pressure": 3 * force / (2 * math.pi * a ** 2) if a > 0 else 0.0}


def compare_with_reference(problem, row):
    """Rows of (quantity, computed, reference) for the problem's [reference] table: Hertz's contact size and
    peak pressure for the computed contact resultant (divided by ``reference.model_fraction``); none when
    that resultant is zero (the body does not touch the foundation)."""
    ref, material = problem.values["reference"], problem.values["material"]
    fraction = ref["model_fraction"]
    force = row["contact_resultant"] / fraction
    if not force > 0:  # nothing touches the foundation (c_n = 0, a gap that never closes): no Hertz contact
        return []
    if ref["hertz"] == "line":
        hertz = hertz_line_contact(force, ref["radius"], material["E"], material["nu"])
        return [("contact half-width", row["contact_length"] / 2, hertz["half_width"]),
                ("peak contact pressure", row["max_contact_pressure"], hertz["peak_pressure"])]
    if ref["hertz"] == "sphere":
        hertz = hertz_sphere_contact(force, ref["radius"], material["E"], material["nu"])
        radius = math.sqrt(row["contact_area"] / fraction / math.pi)
        return [("contact radius", radius, hertz["radius"]),
                ("peak contact pressure", row["max_contact_pressure"], hertz["peak_pressure"])]
    return []
