"""Command line ``mshbm sweep``: a frequency-response curve of a case file (:func:`mshbm.sweep`), or a branch in
any numeric key of it (:func:`mshbm.parameter.sweep_case`).

``mshbm sweep CASE.yaml --method M --omega-start A --omega-end B [--harmonics N] [--steps N] [--period K]
[--integrator moreau|event] [--set KEY=VALUE ...] [--out branch.json] [--plot branch.png] [--dofs D [D ...]]
[--max-points N] [--quiet]``

``mshbm sweep CASE.yaml --parameter KEY --start A --end B [--omega W] ...`` continues in the case-file entry
``KEY`` (a dotted key, :mod:`mshbm.io.overrides`: ``friction.0.normal_force``, ``forcing.0.amplitude``,
``masses.1``, ...) at the fixed frequency ``W`` (default: the case's ``omega``); ``--parameter omega --start A
--end B`` is the frequency sweep.

Exit codes as for ``mshbm solve`` (:mod:`mshbm.cli`): 0 the branch reached the end of the range with every
point certified, 1 it stopped before -- at ``--max-points``, at ``ds_min``, out of range -- (the points so
far are written: JSON and plot), 2 invalid input (one line ``error: <key>: <problem>``), 3 internal error,
130 interrupted by Ctrl-C (SIGINT) and 143 by SIGTERM: the points accepted so far are written too (JSON
with ``"success": false``, ``counters.interrupted``, and the plot), unless the interrupt came before the
first point.

Progress (points done, the parameter, step size) goes to stderr unless ``--quiet``.  The JSON holds
``success``, ``message``, ``parameter`` (``"omega"`` or the key), arrays ``omega``, ``amplitude`` (per
point, per DOF), ``stable`` and ``bifurcations`` (``[{type, omega}]``; with ``value`` in a parameter
sweep), ``parameter_values`` in a parameter sweep, plus per-point details.  The plot shows the amplitude
of the chosen DOFs against omega (or the parameter): solid where stable, dashed where unstable, dotted where
undecided (each DOF in its own colour), and markers at bifurcations.
"""
from __future__ import annotations

import signal
from io import BytesIO

import numpy as np

from . import __version__
from .branch import sweep
from .branch_accuracy import add_reduction
from .errors import InputError
from .interrupt import SweepInterrupted
from .io.case import describe_auto
from .io.overrides import add_set_option, case_sets
from . import io as _io
from .options import COMMON as _COMMON, METHODS
from .outfile import check_out, write_text
from .parameter import sweep_case

__all__ = ["add_parser", "run"]


def add_parser(sub, method_choices):
    s = sub.add_parser("sweep", help="trace a frequency-response curve (or a branch in another parameter)",
                       description="Trace the branch of periodic solutions of a case file from --omega-start to "
                       "--omega-end (or in --parameter KEY from --start to --end at fixed omega) by pseudo-arclength "
                       "continuation. Exit codes: 0 end reached, 1 stopped early (max points, step size; the points "
                       "so far are written), 2 invalid input, 3 internal error, 130 interrupted (Ctrl-C), 143 "
                       "terminated (SIGTERM): the points so far are written.")
    s.add_argument("case", metavar="CASE.yaml", help="case file (see examples/)")
    s.add_argument("--method", choices=method_choices, default=None,
                   help="solution method (default: the case's solver.method, else mshbm)")
    s.add_argument("--omega-start", type=float, default=None, metavar="A", help="start frequency (rad/s)")
    s.add_argument("--omega-end", type=float, default=None, metavar="B", help="end frequency (rad/s)")
    s.add_argument("--parameter", default="omega", metavar="KEY",
                   help="continuation parameter: omega (default) or a numeric dotted key of the case file, e.g. "
                   "friction.0.normal_force or forcing.0.amplitude (dR/dKEY by finite differences)")
    s.add_argument("--start", type=float, default=None, metavar="A", help="start value of --parameter")
    s.add_argument("--end", type=float, default=None, metavar="B", help="end value of --parameter")
    s.add_argument("--omega", type=float, default=None, metavar="W",
                   help="fixed forcing frequency (rad/s) of a sweep in another --parameter (default: the case's)")
    add_set_option(s)
    s.add_argument("--harmonics", type=int, default=None, metavar="N", help="number of harmonics n_h (per period T)")
    s.add_argument("--steps", type=int, default=None, metavar="N", help="time steps (samples) per period T")
    s.add_argument("--period", type=int, default=1, metavar="K", help="trace K T-periodic solutions (default 1)")
    s.add_argument("--integrator", choices=("moreau", "event"), default=None,
                   help="time integration of shooting and MS-HBM: Moreau-Jean time stepping (default) or the "
                   "exact event-driven flow, whose residual is smooth in omega at impacts")
    s.add_argument("--accuracy", type=float, default=None, metavar="E",
                   help="requested relative amplitude error of every point: the branch is traced again with more "
                   "harmonics or steps until every point's combined error estimate is below E, else the points "
                   "that fail are reported (default: no refinement, points certified at 1e-2; "
                   "mshbm.branch_accuracy)")
    s.add_argument("--estimate-every", type=int, default=None, metavar="K",
                   help="re-solve the error estimates at every K-th point (default 4; also at the ends, peaks and "
                   "bifurcations), the larger of the neighbours' estimates in between; 1: every point")
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


def plot(branch, path, dofs, title="", case=None, labels=None):
    """Write the figure of :func:`figure` as a PNG to ``path`` (the rules of ``--out``, :mod:`mshbm.outfile`;
    errors name ``--plot``)."""
    import matplotlib.pyplot as plt

    fig = figure(branch, dofs, title, labels)
    buf = BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    write_text(path, buf.getvalue(), case, key="--plot")


def figure(branch, dofs, title="", labels=None):
    """Amplitude of ``dofs`` against omega (a matplotlib Figure): each DOF in its own colour, solid where
    stable, dashed where unstable, dotted where undecided (one polyline per run of equal stability; a segment
    between points of different verdicts counts as undecided); markers at the bifurcations.

    ``branch`` needs ``omega`` (shape (P,), rad/s), ``amplitude`` (shape (P, n)), ``stable`` (P entries,
    True/False/None) and ``bifurcations`` (dicts with ``type``, ``omega``, optional ``index``).  ``labels``:
    the DOF numbers the legend shows (default ``dofs``; a reduced model's branch holds its own DOF indices, the
    legend names the user's)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    param = getattr(branch, "parameter", "omega")
    w = branch.omega if param == "omega" else branch.values
    A, st = branch.amplitude, branch.stable
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
        ax.plot([], [], color=col, ls="-", label=f"dof {d if labels is None else labels[c]}")
    markers = {"fold": "o", "period-doubling": "s", "neimark-sacker": "D", "grazing": "^"}
    seen = set()
    for b in branch.bifurcations:
        wb = b.get("omega") if param == "omega" else b.get("value")
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
    ax.set_xlabel(r"$\omega$ (rad/s)" if param == "omega" else param)
    ax.set_ylabel("amplitude (max - min)/2")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)  # beside the curves
    fig.tight_layout()
    return fig


def _range(args):
    """``(parameter, start, end)`` from ``--parameter/--start/--end`` or ``--omega-start/--omega-end``."""
    param = args.parameter
    if param == "omega":
        if args.omega is not None:
            raise InputError("--omega", "fixes the frequency of a sweep in another --parameter; this sweep is in "
                                        "omega (give --omega-start/--omega-end)")
        start = args.omega_start if args.omega_start is not None else args.start
        end = args.omega_end if args.omega_end is not None else args.end
        for flag, given, alt in (("--omega-start", start, "--start"), ("--omega-end", end, "--end")):
            if given is None:
                raise InputError(flag, f"missing (required: the range of the sweep, {flag} or {alt})")
        return param, start, end
    for flag, given in (("--omega-start", args.omega_start), ("--omega-end", args.omega_end)):
        if given is not None:
            raise InputError(flag, f"is for sweeps in omega; a sweep in --parameter {param} takes --start/--end "
                                   "(and --omega for its fixed frequency)")
    for flag, given in (("--start", args.start), ("--end", args.end)):
        if given is None:
            raise InputError(flag, f"missing (required with --parameter {param})")
    return param, args.start, args.end


_NAMES = {"omega_start": "--omega-start", "omega_end": "--omega-end", "period": "--period",
          "max_points": "--max-points", "harmonics": "--harmonics", "steps": "--steps", "integrator": "--integrator",
          "lam_start": "--start", "lam_end": "--end", "start": "--start", "end": "--end", "omega": "--omega",
          "parameter": "--parameter", "accuracy": "--accuracy", "estimate_every": "--estimate-every"}


def run(args, exit_codes, write_json, error):
    """Run ``mshbm sweep`` (``args`` from :func:`add_parser`); returns the exit code."""

    ok, not_conv = exit_codes
    for key, path in (("--out", args.out), ("--plot", args.plot)):
        if path is not None:
            check_out(path, args.case, key)
    param, start, end = _range(args)
    case = _io.load_case(args.case, sets=case_sets(args))
    method = args.method or case.method
    dofs = labels = _check_dofs(args.dofs, case.system.n)
    defaults = {k: v for k, v in case.solver.items() if k != "method" and k in (METHODS.get(method, set()) | _COMMON)}
    cli = {k: getattr(args, k) for k in ("harmonics", "steps", "integrator") if getattr(args, k) is not None}
    if param == "omega" and case.reduction is None:  # stiff time-integrated DOFs (mshbm.io.case.Case.solve)
        case.reduction = case.automatic_reduction(method, {**defaults, **cli}, omega=max(start, end))
        if case.reduction is not None and not args.quiet:
            print(describe_auto(case.reduction), flush=True)
    if case.reduction is not None:  # the branch holds the reduced model's DOFs: its boundary DOFs are physical
        labels = [int(d) for d in (dofs if args.dofs else case.reduction.boundary[:6])]
        dofs = [case.reduction.reduced_dof(d, "--dofs") for d in labels]
    if args.max_points is not None:
        cli["max_points"] = args.max_points
    if args.accuracy is not None:
        cli["accuracy"] = args.accuracy
    if args.estimate_every is not None:
        cli["estimate_every"] = args.estimate_every
    progress = False if args.quiet else "always"
    interrupted = None
    try:
        if param == "omega":
            br = sweep(case.model, start, end, method, period=args.period, progress=progress, **{**defaults, **cli})
        else:
            br = sweep_case(case, param, start, end, args.omega, method, period=args.period, progress=progress, **cli)
    except SweepInterrupted as exc:
        br, interrupted = exc.branch, exc
    except InputError as exc:
        given = set(cli) | {"omega_start", "omega_end", "period", "lam_start", "lam_end", "start", "end", "parameter"}
        given |= {"omega"} if args.omega is not None else set()
        if exc.key in _NAMES and exc.key in given:
            raise InputError(_NAMES[exc.key], exc.problem) from None
        raise
    if case.reduction is not None and param == "omega" and interrupted is None:
        add_reduction(br, case.reduction)  # the Craig-Bampton estimate, summed into every point's accuracy
    what = "omega" if param == "omega" else f"{param} at omega = {args.omega or case.omega:g}"
    if args.out is not None:
        payload = {"case": case.name, **br.to_dict(), "n_dofs": int(case.system.n), "source": case.source,
                   "version": __version__}
        if case.reduction is not None:  # on the user's DOFs, as solve --out (mshbm.reduction.ReducedModel.expand)
            _on_full_dofs(payload, br, case.reduction)
        write_json(args.out, payload, args.case)
    if args.plot is not None and len(br):
        plot(br, args.plot, dofs, labels=labels, title=f"{case.name}: {method}" + (f", period {args.period}" if args.period > 1
                                                                     else "") + ("" if param == "omega" else
                                                                                 f", {what}"), case=args.case)
    if not args.quiet:
        x = br.omega if param == "omega" else br.values
        bifs = ", ".join(f"{b['type']} at {b.get('omega' if param == 'omega' else 'value', float('nan')):.6g}"
                         for b in br.bifurcations) or "none"
        print(f"case        {case.name}\nmethod      {method}\nparameter   {what}\nperiod      {args.period}\n"
              f"points      {len(br)}" + (f" ({param} {x.min():.6g} .. {x.max():.6g})" if len(br) else "") +
              f"\nsuccess     {'yes' if br.success else 'no'}\naccuracy    {_accuracy_line(br)}\nwall time   {br.wall_time:.2f} s\n"
              f"bifurcations {bifs}")
        for path in (args.out, args.plot):
            if path is not None and (path == args.out or len(br)):
                print(f"wrote {path}")
    if interrupted is not None:
        name = "SIGTERM" if interrupted.signum == signal.SIGTERM else "SIGINT"
        error(f"{br.message} ({name})" + ("; the points so far are written" if args.out or args.plot else ""))
        return 128 + int(interrupted.signum)
    if not br.success:
        reached = (br.accuracy or {}).get("reached_end")
        error(f"sweep reached the end, but not every point is certified: {br.message}" if reached
              else f"sweep stopped early: {br.message}")
        return not_conv
    return ok


def _on_full_dofs(payload, br, reduction):
    """The ``--out`` payload of a sweep of the reduced model (``payload`` from ``br.to_dict()``) on the full model's
    DOFs, in place: per point the amplitude of every DOF the user wrote (index = DOF; the boundary DOFs' are the
    branch's own, exact for time-integrated DOFs; the others from the expanded Fourier series, ``q_hat T^T``), and
    the elements and contacts named by their DOFs in the full model.  The points' unknowns ``x`` stay the
    method's on the reduced model; ``reduction`` (:meth:`mshbm.reduction.ReducedModel.as_dict`) says so."""
    B = reduction.boundary
    for i, bp in enumerate(br.points):
        pt = payload["points"][i]
        amp = np.full(reduction.full.n, np.nan)
        if bp.solution is not None:
            full = reduction.expand(bp.solution, estimate=False)
            amp = np.asarray(full.amplitude, dtype=float)
            pt["elements"] = [e.summary() for e in (full.elements or [])]
        amp[B] = np.asarray(bp.amplitude, dtype=float)[:B.size]
        payload["amplitude"][i] = pt["amplitude"] = [float(a) for a in amp]
        pt["contact"] = [dict(c, dof=int(B[c["dof"]])) if "dof" in c else c for c in pt["contact"]]
    payload["reduction"] = {**reduction.as_dict(), "dofs": "the full model's (amplitude, elements, contact); the "
                            "points' x are the unknowns of the method on the reduced model"}


def _accuracy_line(br):
    """One line on the points' error estimates (:mod:`mshbm.branch_accuracy`)."""
    acc = br.accuracy or {}
    if not acc or acc.get("skipped"):
        return f"not estimated ({acc.get('skipped', 'no points')})"
    big = acc.get("largest") or {}
    return (f"{acc['certified_points']} of {len(br)} points within {acc['accuracy']:.0e} "
            f"({'requested' if acc['requested'] else 'default'}); largest estimate "
            + (f"{big['estimate']:.2g} ({big['name']})" if big.get("estimate") is not None else "none")
            + f"; estimated at {len(acc['estimated_points'])} points")
