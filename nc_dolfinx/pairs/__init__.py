"""Contact between two deformable bodies ([[pairs]] of faces), beside the foundation's Γ_C.

- :mod:`.bodies`: the mesh's bodies (its connected parts), found in parallel;
- :mod:`.binding`: the pairs of a problem bound to a mesh, and the checks that need the mesh;
- :mod:`.faces`: a face's facets (vertices, dofs, normals) and a Gauss rule on them;
- :mod:`.search`: the closest point Π x on the other face, across ranks (bounding boxes, a k-d tree);
- :mod:`.segments`: where the pair's integrals are taken (edges cut where the other face's vertices project);
- :mod:`.coupling`: the gap operator B and the pairs' term of the residual, Jacobian and energy of (7);
- :mod:`.quantities`: each pair's force, contact zone and peak pressure.
"""
