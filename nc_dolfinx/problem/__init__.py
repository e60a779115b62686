"""The problem file: every key (:mod:`.schema`), expressions in it (:mod:`.expressions`), reading TOML and
``--set`` (:mod:`.reading`), the validated :class:`~nc_dolfinx.problem.problem.Problem` (:mod:`.problem`) and
the built-in cases found by name (:mod:`.cases`). Nothing here knows a mesh."""
