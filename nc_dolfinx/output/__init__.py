"""Results on disk: the result folder and its atomic files (:mod:`.files`), VTK pieces (:mod:`.vtu`), the
fields written beside the solution (:mod:`.postprocess`), what each column means (:mod:`.columns`), the
convergence plot (:mod:`.plots`) and the run's provenance (:mod:`.provenance`)."""
