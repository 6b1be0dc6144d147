"""Time integrators of the nonsmooth flow: the compiled Moreau-Jean kernels (:mod:`.kernels`) and their typed layer (:mod:`.moreau_jean`)."""
