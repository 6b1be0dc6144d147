"""The solve route: orchestration above the methods.

Layers, from the bottom: the numerics (:mod:`mshbm.solvers`: Newton, pseudo-arclength continuation) know
only residuals; the methods (:mod:`mshbm.methods`) build a problem's residual; the route (this package)
decides where Newton starts and whether a solution is accepted:

* :mod:`.acceptance` -- the start-independent residual test of a solution;
* :mod:`.ladder` -- the start ladder (registered start objects, its time budget);
* :mod:`.starts`, :mod:`.frequency` -- the starts;
* :mod:`.continuation` -- restarts and natural-parameter continuation;
* :mod:`.driver` -- :class:`~mshbm.route.driver.Route`: the strategy chain of one solve, what nested solves
  inherit (deadline, nesting), the certificate and the solution;
* :mod:`.options` -- option subsets and the capabilities of a method by name.

The sweep (:mod:`mshbm.branch`) is a component of the route, given to it explicitly
(:attr:`Route.sweep <mshbm.route.driver.Route.sweep>`).
"""
