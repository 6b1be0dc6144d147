"""Command line ``mshbm sweep``: a frequency-response curve of a case file (:func:`mshbm.sweep`).

``mshbm sweep CASE.yaml --method M --omega-start A --omega-end B [--harmonics N] [--steps N] [--period K]
[--integrator moreau|event] [--out branch.json] [--plot branch.png] [--dofs D [D ...]] [--max-points N] [--quiet]``

Exit codes as for ``mshbm solve`` (:mod:`mshbm.cli`): 0 the branch reached ``--omega-end`` with every
point certified, 1 it stopped before (the points so far are still written), 2 invalid input (one line
``error: <key>: <problem>``), 3 internal error, 130 interrupted.

Progress (points done, omega, step size) goes to stderr unless ``--quiet``.  The JSON holds
``success``, ``message``, arrays ``omega``, ``amplitude`` (per point, per DOF), ``stable`` and
``bifurcations`` (``[{type, omega}]``), plus per-point details.  The plot shows the amplitude of the
chosen DOFs against omega: solid where stable, dashed where unstable, dotted where undecided (each DOF in its own colour), and
markers at bifurcations.
"""
from __future__ import annotations

from io import BytesIO

import numpy as np

from . import __version__
from .branch import sweep
from .errors import InputError
from . import io as _io
from .options import COMMON as _COMMON, METHODS
from .outfile import check_out

__all__ = ["add_parser", "run"]


def add_parser(sub, method_choices):
    s = sub.add_parser("sweep", help="trace a frequency-response curve", description="Trace the branch of "
                       "periodic solutions of a case file from --omega-start to --omega-end by pseudo-arclength "
                       "continuation. Exit codes: 0 end reached, 1 stopped early, 2 invalid input, 3 internal error.")
    s.add_argument("case", metavar="CASE.yaml", help="case file (see examples/)")
    s.add_argument("--method", choices=method_choices, default=None,
                   help="solution method (default: the case's solver.method, else mshbm)")
    s.add_argument("--omega-start", type=float, required=True, metavar="A", help="start frequency (rad/s)")
    s.add_argument("--omega-end", type=float, required=True, metavar="B", help="end frequency (rad/s)")
    s.add_argument("--harmonics", type=int, default=None, metavar="N", help="number of harmonics n_h (per period T)")
    s.add_argument("--steps", type=int, default=None, metavar="N", help="time steps (samples) per period T")
    s.add_argument("--period", type=int, default=1, metavar="K", help="trace K T-periodic solutions (default 1)")
    s.add_argument("--integrator", choices=("moreau", "event"), default=None,
                   help="time integration of shooting and MS-HBM: Moreau-Jean time stepping (default) or the "
                   "exact event-driven flow, whose residual is smooth in omega at impacts")
    s.add_argument("--max-points", type=int, default=None, metavar="N", help="most points on the branch (400)")
    s.add_argument("--out", default=None, metavar="FILE.json", help="write the branch as JSON")
    s.add_argument("--plot", default=None, metavar="FILE.png", help="plot amplitude against omega")
    s.add_argument("--dofs", type=int, nargs="+", default=None, metavar="D",
                   help="DOFs to plot (default: all, at most 6)")
    s.add_argument("--quiet", action="store_true", help="no progress and no summary (errors still go to stderr)")
    return s


def _check_dofs(dofs, n):
    if dofs is None:
        return list(range(min(n, 6)))
    for d in dofs:
        if not 0 <= d < n:
            raise InputError("--dofs", f"DOF {d} out of range 0..{n - 1}")
    return list(dict.fromkeys(dofs))


def plot(branch, path, dofs, title=""):
    """Write the figure of :func:`figure` as a PNG to ``path``."""
    import matplotlib.pyplot as plt

    fig = figure(branch, dofs, title)
    buf = BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    with open(path, "wb") as f:
        f.write(buf.getvalue())


def figure(branch, dofs, title=""):
    """Amplitude of ``dofs`` against omega (a matplotlib Figure): each DOF in its own colour, solid where
    stable, dashed where unstable, dotted where undecided (one polyline per run of equal stability; a segment
    between points of different verdicts counts as undecided); markers at the bifurcations.

    ``branch`` needs ``omega`` (shape (P,), rad/s), ``amplitude`` (shape (P, n)), ``stable`` (P entries,
    True/False/None) and ``bifurcations`` (dicts with ``type``, ``omega``, optional ``index``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    w, A, st = branch.omega, branch.amplitude, branch.stable
    fig, ax = plt.subplots(figsize=(8.5, 4.5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = {True: "-", False: "--", None: ":"}
    seg = [st[i] if st[i] == st[i + 1] else None for i in range(len(w) - 1)]  # state of segment i..i+1
    for c, d in enumerate(dofs):
        col = colors[c % len(colors)]
        i = 0
        while i < len(seg):  # one polyline per run of equal stability (the dashes stay continuous)
            j = i
            while j + 1 < len(seg) and seg[j + 1] == seg[i]:
                j += 1
            ax.plot(w[i:j + 2], A[i:j + 2, d], color=col, ls=styles[seg[i]],
                    lw=1.6 if seg[i] is not None else 1.2)
            i = j + 1
        ax.plot([], [], color=col, ls="-", label=f"dof {d}")
    markers = {"fold": "o", "period-doubling": "s", "neimark-sacker": "D", "grazing": "^"}
    seen = set()
    for b in branch.bifurcations:
        wb = b.get("omega")
        if wb is None or not len(w):
            continue
        i = int(np.clip(b.get("index", int(np.argmin(np.abs(w - wb)))), 0, len(w) - 1))
        for d in dofs:
            lab = b["type"] if b["type"] not in seen else None
            seen.add(b["type"])
            ax.plot([wb], [A[i, d]], markers.get(b["type"], "x"), color="k", mfc="none", ms=8, label=lab)
    ax.plot([], [], color="k", ls="-", label="stable")
    ax.plot([], [], color="k", ls="--", label="unstable")
    ax.plot([], [], color="k", ls=":", lw=1.2, label="stability unknown")
    ax.set_xlabel(r"$\omega$ (rad/s)")
    ax.set_ylabel("amplitude (max - min)/2")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)  # beside the curves
    fig.tight_layout()
    return fig


def run(args, exit_codes, write_json, error):
    """Run ``mshbm sweep`` (``args`` from :func:`add_parser`); returns the exit code."""
    ok, not_conv = exit_codes
    for key, path in (("--out", args.out), ("--plot", args.plot)):
        if path is not None:
            check_out(path, args.case)
    case = _io.load_case(args.case)
    method = args.method or case.method
    dofs = _check_dofs(args.dofs, case.system.n)
    if case.reduction is not None:  # the branch holds the reduced model's DOFs: its boundary DOFs are physical
        dofs = [case.reduction.reduced_dof(d, "--dofs") for d in (args.dofs or case.reduction.boundary[:6])]
    defaults = {k: v for k, v in case.solver.items() if k != "method" and k in (METHODS.get(method, set()) | _COMMON)}
    cli = {k: getattr(args, k) for k in ("harmonics", "steps", "integrator") if getattr(args, k) is not None}
    if args.max_points is not None:
        cli["max_points"] = args.max_points
    progress = False if args.quiet else "always"
    try:
        br = sweep(case.model, args.omega_start, args.omega_end, method, period=args.period,
                   progress=progress, **{**defaults, **cli})
    except InputError as exc:
        names = {"omega_start": "--omega-start", "omega_end": "--omega-end", "period": "--period",
                 "max_points": "--max-points", "harmonics": "--harmonics", "steps": "--steps",
                 "integrator": "--integrator"}
        if exc.key in names and (exc.key in cli or exc.key in ("omega_start", "omega_end", "period")):
            raise InputError(names[exc.key], exc.problem) from None
        raise
    if args.out is not None:
        payload = {"case": case.name, **br.to_dict(), "n_dofs": int(case.system.n), "source": case.source,
                   "version": __version__}
        if case.reduction is not None:  # the amplitudes are those of the reduced DOFs (boundary first)
            payload["reduction"] = case.reduction.as_dict()
        write_json(args.out, payload, args.case)
    if args.plot is not None and len(br):
        plot(br, args.plot, dofs, title=f"{case.name}: {method}" + (f", period {args.period}" if args.period > 1
                                                                     else ""))
    if not args.quiet:
        w = br.omega
        bifs = ", ".join(f"{b['type']} at {b['omega']:.6g}" for b in br.bifurcations) or "none"
        print(f"case        {case.name}\nmethod      {method}\nperiod      {args.period}\n"
              f"points      {len(br)}" + (f" (omega {w.min():.6g} .. {w.max():.6g})" if len(br) else "") +
              f"\nsuccess     {'yes' if br.success else 'no'}\nwall time   {br.wall_time:.2f} s\n"
              f"bifurcations {bifs}")
        for path in (args.out, args.plot):
            if path is not None:
                print(f"wrote {path}")
    if not br.success:
        error(f"sweep stopped early: {br.message}")
        return not_conv
    return ok
