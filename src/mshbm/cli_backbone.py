"""Command line ``mshbm backbone``: the backbone (nonlinear mode) of a case file by EPMC with harmonic balance or
by shooting with the exact event-driven flow (:func:`mshbm.backbone`; a conservative system's mode with
``shooting``: damping ratio 0).

``mshbm backbone CASE.yaml --method hbm|dlft|shooting|mshbm [--integrator event|moreau] --mode K --amplitude-start A --amplitude-end B [--harmonics N]
[--steps N] [--points N] [--max-points N] [--dofs D [D ...]] [--out b.json] [--plot b.png] [--quiet]``

The case's forcing and frequency are ignored (the mode is an autonomous motion).  Exit codes as for
``mshbm sweep``: 0 the backbone reached ``--amplitude-end`` with every point certified, 1 it stopped before
or a point failed its certificate (the points so far are still written), 2 invalid input (``error: <key>:
<problem>``), 3 internal error, 130 interrupted.  Progress (points, modal amplitude, omega, damping ratio,
step) goes to stderr unless ``--quiet``.  The plot shows omega and the damping ratio against the modal
amplitude (log scale).
"""
from __future__ import annotations

from io import BytesIO

from . import __version__
from . import io as _io
from .backbone import backbone
from .errors import InputError
from .outfile import check_out

__all__ = ["add_parser", "run"]


def add_parser(sub):
    s = sub.add_parser("backbone", help="trace a nonlinear mode (backbone curve)", description="Trace the "
                       "frequency and damping ratio of a nonlinear mode against its modal amplitude by the "
                       "extended periodic motion concept. Exit codes: 0 end reached, 1 stopped early, "
                       "2 invalid input, 3 internal error.")
    s.add_argument("case", metavar="CASE.yaml", help="case file (see examples/)")
    s.add_argument("--method", choices=("hbm", "dlft", "shooting", "mshbm"), default="hbm",
                   help="hbm (HBM-AFT, default), dlft (set-valued friction and contact), shooting (the exact "
                   "event-driven flow: friction on the ground and impacts) or mshbm (the element DOFs by that flow, "
                   "the others by harmonic balance)")
    s.add_argument("--integrator", choices=("event", "moreau"), default=None,
                   help="shooting and mshbm: the exact event-driven flow (default) or Moreau-Jean time stepping "
                   "(any element the stepper takes, e.g. Jenkins joints; --steps steps per period, default 1024; "
                   "refused for a conservative system with impacts)")
    s.add_argument("--mode", type=int, default=0, metavar="K", help="0-based mode of the linear system with "
                   "the Jenkins joints stuck (default 0)")
    s.add_argument("--amplitude-start", type=float, required=True, metavar="A",
                   help="first modal amplitude (mass-normalised, kg^1/2 m)")
    s.add_argument("--amplitude-end", type=float, required=True, metavar="B", help="last modal amplitude")
    s.add_argument("--harmonics", type=int, default=5, metavar="N", help="number of harmonics n_h (default 5)")
    s.add_argument("--steps", type=int, default=None, metavar="N", help="AFT samples per period (shooting: output "
                   "samples per period, default 256)")
    s.add_argument("--points", type=int, default=50, metavar="N", help="aimed number of points (default 50)")
    s.add_argument("--max-points", type=int, default=None, metavar="N", help="most points (default 4 x points + 10)")
    s.add_argument("--dofs", type=int, nargs="+", default=None, metavar="D",
                   help="DOFs whose amplitude is reported (default: the largest entry of the mode)")
    s.add_argument("--out", default=None, metavar="FILE.json", help="write the backbone as JSON")
    s.add_argument("--plot", default=None, metavar="FILE.png", help="plot omega and damping ratio against a")
    s.add_argument("--quiet", action="store_true", help="no progress and no summary (errors still go to stderr)")
    return s


def plot(bb, path, title=""):
    """Frequency and damping ratio against the modal amplitude (two panels), written as PNG to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    a = bb.modal_amplitude
    ok = [p["certified"] for p in bb.points]
    a1.semilogx(a, bb.omega, "-o", ms=3)
    a2.semilogx(a, 100 * bb.damping_ratio, "-o", ms=3)
    bad = [i for i, c in enumerate(ok) if not c]
    if bad:
        a1.plot(a[bad], bb.omega[bad], "rx", label="not certified")
        a1.legend(fontsize=8)
    a1.set_ylabel(r"$\omega$ (rad/s)")
    a2.set_ylabel("damping ratio D (%)")
    a2.set_xlabel(r"modal amplitude $a$ (kg$^{1/2}$ m)")
    a1.set_title(title)
    for ax in (a1, a2):
        ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    buf = BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    with open(path, "wb") as f:
        f.write(buf.getvalue())


def run(args, exit_codes, write_json, error):
    """Run ``mshbm backbone`` (``args`` from :func:`add_parser`); returns the exit code."""
    ok, not_conv = exit_codes
    for path in (args.out, args.plot):
        if path is not None:
            check_out(path, args.case)
    case = _io.load_case(args.case)
    names = {"amplitude_start": "--amplitude-start", "amplitude_end": "--amplitude-end", "mode": "--mode",
             "harmonics": "--harmonics", "steps": "--steps", "points": "--points", "dofs": "--dofs", "max_points": "--max-points",
             "method": "--method", "integrator": "--integrator"}
    try:
        bb = backbone(case.system, args.amplitude_start, args.amplitude_end, mode=args.mode, method=args.method,
                      harmonics=args.harmonics, steps=args.steps, dofs=args.dofs, points=args.points,
                      max_points=args.max_points, integrator=args.integrator,
                      progress=False if args.quiet else "always")
    except InputError as exc:
        if exc.key in names:
            raise InputError(names[exc.key], exc.problem) from None
        raise
    if args.out is not None:
        payload = {"case": case.name, **bb.to_dict(), "n_dofs": int(case.system.n), "source": case.source,
                   "version": __version__}
        write_json(args.out, payload, args.case)
    if args.plot is not None and len(bb):
        how = args.method + (f" ({bb.integrator})" if bb.integrator else "")
        plot(bb, args.plot, title=f"{case.name}: mode {args.mode}, {how}, n_h = {args.harmonics}")
    if not args.quiet:
        text = f"case        {case.name}\nmethod      {args.method}\nmode        {args.mode}\npoints      {len(bb)}"
        if len(bb):
            w, D = bb.omega, bb.damping_ratio
            text += (f" (a {bb.modal_amplitude.min():.4g} .. {bb.modal_amplitude.max():.4g})\n"
                     f"omega       {w[0]:.6g} .. {w[-1]:.6g} rad/s\ndamping     {D[0]:.4g} .. {D[-1]:.4g}")
        text += f"\nsuccess     {'yes' if bb.success else 'no'}\nwall time   {bb.wall_time:.2f} s"
        print(text)
        for path in (args.out, args.plot):
            if path is not None:
                print(f"wrote {path}")
    if not bb.success:
        error(f"backbone stopped early: {bb.message}")
        return not_conv
    return ok
