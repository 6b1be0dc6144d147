"""Per-figure summaries (``results/summary/<fig>.json``, rule ``summary``, script
``workflow/scripts/summaries/summarize.py``): errors against the reference, efforts, impacts, stick
fractions, Floquet multipliers and the paper's claims next to our numbers, by kind of figure:

* :mod:`.common` -- the paper's claims, the facts of one solve, stability, long runs, amplitude errors;
* :mod:`.timeseries` -- time-series figures (Figs. 3, 5, 6): one solve per method against the reference;
* :mod:`.workprecision` -- work-precision diagrams (Figs. 4, 8): error and effort against n_H;
* :mod:`.phase` -- the phase diagram of the impact chain (Fig. 7).

Cheap: they read JSON results only, never solve.
"""
