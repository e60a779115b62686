"""Meshes and refinement: a :class:`~nc_dolfinx.mesh.domain.Domain` (a DOLFINx mesh with boundary groups and
material regions, :mod:`.domain`) from a user's DOLFINx mesh (:mod:`.tagged`), the built-in rectangle and
box (:mod:`.builtin`) or gmsh (:mod:`.gmsh_io`); marked refinement with the transfer of fields to the child
(:mod:`.refinement`)."""
