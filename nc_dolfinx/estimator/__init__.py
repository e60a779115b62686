"""The residual a posteriori estimator of Definition 5 (:mod:`.indicators`), its cell and facet geometry
(:mod:`.geometry`), the Γ_C law residual at the kink of (·)_+ (:mod:`.kink`) and Dörfler marking
(:mod:`.marking`)."""
