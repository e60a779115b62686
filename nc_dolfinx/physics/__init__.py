"""Physics and forms: linear elasticity (:mod:`.elasticity`), the discrete problem (7) in UFL
(:mod:`.forms`), a problem's data bound to a mesh as DOLFINx objects (:mod:`.binding`), errors and contact
quantities of a solution (:mod:`.quantities`) and the Hertz references (:mod:`.reference`)."""
