"""Numerics acting on any residual: Newton's method (:mod:`.newton`) and pseudo-arclength continuation
(:mod:`.arclength`).  They sit below the methods (:mod:`mshbm.methods`); the solve route that uses them is
:mod:`mshbm.route`."""
