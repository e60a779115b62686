"""nc_dolfinx: frictionless normal compliance contact with a residual a posteriori estimator.

Implements Fernández & Hild, "A posteriori error analysis for the normal compliance problem": the
discrete problem (7) with P1 elements, the estimator of Definition 5 and adaptive refinement, on
DOLFINx 0.5.
"""
__version__ = "0.1.0"
