"""Command line: ``mshbm solve CASE.yaml [--method M] [--harmonics N] [--steps N] [--accuracy E] [--omega W]
[--set KEY=VALUE ...] [--out FILE] [--quiet]`` and ``mshbm sweep CASE.yaml ...`` (branches in omega or any parameter,
:mod:`mshbm.cli_sweep`), ``mshbm backbone CASE.yaml ...`` (nonlinear modes,
:mod:`mshbm.cli_backbone`).

``--set KEY=VALUE`` (repeatable) sets a dotted key of the case file before it is checked
(:mod:`mshbm.io.overrides`: ``--set friction.0.normal_force=2.5 --set solver.harmonics=9``; the value is
read as YAML; an unknown key is an input error naming it); ``--omega W`` is ``--set omega=W``.

Exit codes: 0 converged, 1 not converged, 2 invalid input (one line
``error: <key>: <problem>``), 3 internal error, 130 interrupted (Ctrl-C, SIGINT), 143 terminated
(SIGTERM).  No traceback ever reaches the user.  The first use of a numba kernel whose on-disk cache is
missing compiles it (seconds to a minute): one line ``mshbm: compiling ...`` on stderr says so (not with
``--quiet``).
"""
from __future__ import annotations

import argparse
import json
import signal
import sys

import numpy as np

from . import __version__
from . import cli_backbone, cli_sweep
from .certificate.record import SUPERSEDED
from .errors import ConvergenceError, InputError
from .interrupt import terminate_as_interrupt
from . import io as _io
from .options import METHODS
from .outfile import check_out, jsonable, write_text
from .io.overrides import add_set_option, case_sets
from .validate import quiet_floats

__all__ = ["main"]

EXIT_OK, EXIT_NOT_CONVERGED, EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
#: exit code after SIGTERM (128 + 15, as a shell reports a process killed by it)
EXIT_TERMINATED = 128 + signal.SIGTERM
METHOD_CHOICES = tuple(METHODS)


def _one_line(text):
    return " ".join(str(text).split())


def _error(text):
    print(f"error: {_one_line(text)}", file=sys.stderr)


def _parser():
    p = argparse.ArgumentParser(prog="mshbm", description="Periodic solutions of linear structures with local "
                                "friction and contact (shooting, HBM, mixed shooting-harmonic balance).")
    p.add_argument("--version", action="version", version=f"mshbm {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    s = sub.add_parser("solve", help="solve a case file", description="Compute the periodic solution of a case "
                       "file. Exit codes: 0 converged, 1 not converged, 2 invalid input, 3 internal error.")
    s.add_argument("case", metavar="CASE.yaml", help="case file (see examples/)")
    s.add_argument("--method", choices=METHOD_CHOICES, default=None,
                   help="solution method (default: the case's solver.method, else mshbm)")
    s.add_argument("--harmonics", type=int, default=None, metavar="N", help="number of harmonics n_h")
    s.add_argument("--steps", type=int, default=None, metavar="N", help="time steps (samples) per period")
    s.add_argument("--integrator", choices=("moreau", "event"), default=None,
                   help="time integration of shooting and MS-HBM: Moreau-Jean time stepping (default) or the "
                   "exact event-driven flow (mshbm.integrators.event: friction and contact on single DOFs)")
    s.add_argument("--accuracy", type=float, default=None, metavar="E",
                   help="requested relative amplitude error: the method refines its harmonics and steps until the "
                   "combined error estimate is below E, or fails naming the estimate (default: no refinement, "
                   "success gated at 1e-2)")
    s.add_argument("--period", type=int, default=None, metavar="K",
                   help="look for a K T-periodic solution (default 1; see mshbm.period)")
    s.add_argument("--omega", type=float, default=None, metavar="W",
                   help="forcing frequency in rad/s (instead of the case's omega; same as --set omega=W)")
    add_set_option(s)
    s.add_argument("--out", default=None, metavar="FILE.json",
                   help="write the result as JSON: the summary, the element outputs over the period, the Fourier "
                   "coefficients q_hat (2 n_h + 1 rows: mean, then cos and sin of each harmonic; m) of every DOF "
                   "and the time series q_time, u_time of the time-stepped DOFs time_dofs on the grid t (keeps "
                   "the permissions of an existing file, writes through symlinks, FIFOs and character devices; "
                   "never the case file itself)")
    s.add_argument("--quiet", action="store_true", help="print no table (errors still go to stderr)")
    cli_sweep.add_parser(sub, METHOD_CHOICES)  # mshbm sweep: mshbm.cli_sweep
    cli_backbone.add_parser(sub)  # mshbm backbone: mshbm.cli_backbone
    return p


class _CompileNotice:
    """One line on stderr when numba compiles a kernel (its ``numba:compile`` event fires only on a cache
    miss: loading a kernel cached on disk is silent), once per process."""

    def __init__(self):
        self.shown = False

    def install(self):
        try:
            from numba.core import event
        except ImportError:  # pragma: no cover - numba is a dependency
            return None

        notice = self

        class Listener(event.Listener):
            def on_start(self, ev):
                if not notice.shown:
                    notice.shown = True
                    print("mshbm: compiling numba kernels on first use (cached on disk for later runs; this takes "
                          "a while once)", file=sys.stderr, flush=True)

            def on_end(self, ev):
                pass

        listener = Listener()
        event.register("numba:compile", listener)
        return lambda: event.unregister("numba:compile", listener)


def _fmt_float(x):
    return "nan" if x is None else repr(float(x))


def _stable_text(summary):
    verdict = {True: "yes", False: "no", None: "undecided"}[summary.get("stable")]
    rho = summary.get("floquet_max_modulus")
    other = ", multipliers of the nearby exact orbit, not the reported one" \
        if summary.get("stability_orbit") == "nearby exact orbit" else ""
    return f"{verdict} ({summary.get('stability_method')}{other}" + (f", max |mu| = {rho:.6f})" if rho is not None
                                                                     else ")")


def _table(case, summary):
    rows = [("case", case.name), ("method", summary["method"]), ("harmonics", summary["harmonics"]),
            ("steps", summary["steps"]), ("success", "yes" if summary["success"] else "no"),
            ("iterations", summary["iterations"]), ("residual", f"{summary['residual']:.3e}"),
            ("wall time", f"{summary['wall_time_s']:.3f} s"), ("stable", _stable_text(summary))]
    if summary.get("certificate") is not None:  # mshbm.certificate: gating checks, and estimates above bound
        bad = [c["name"] for c in summary["certificate"] if c["gating"] and not c["passed"]]
        names = {c["name"] for c in summary["certificate"]}
        superseded = SUPERSEDED if "truncation" in names else ()
        est = [f"{c['name']} {c['value']:.1e}" for c in summary["certificate"] if not c["gating"] and
               c["value"] is not None and not c["passed"] and c["name"] not in superseded]
        rows.append(("certificate", ("failed: " + ", ".join(bad)) if bad else
                     f"passed ({sum(c['gating'] for c in summary['certificate'])} checks)"
                     + (f"; above their bounds: {', '.join(est)}" if est else "")))
        sub = [c for c in summary["certificate"] if c["name"] == "model_substitution"]
        if sub:  # mshbm.certificate.substitution: the law put in place of the user's, and its estimated effect
            v = sub[0]["value"]
            rows.append(("substitution", sub[0]["note"].split(": ")[0] + (
                "; effect not estimated" if v is None else f"; estimated relative amplitude error {v:.2g}")))
    acc = summary.get("accuracy")
    if acc and acc.get("skipped"):
        rows.append(("error estimate", f"not estimated ({acc['skipped']})"))
    elif acc:  # the combined error estimate (mshbm.route.refine)
        parts = ", ".join(f"{k} {v:.1e}" for k, v in acc["estimates"].items())
        est = "not estimated" if acc["estimate"] is None else f"{acc['estimate']:.1e}"
        rows.append(("error estimate", f"{est} {'<=' if acc['passed'] else '>'} {acc['accuracy']:.0e} "
                     f"({'requested' if acc['requested'] else 'default'}){': ' + parts if parts else ''}"))
    width = max(len(r[0]) for r in rows)
    lines = [f"{k:<{width}}  {v}" for k, v in rows]
    amp = summary["amplitude"]
    n = len(amp)
    shown = list(range(n)) if n <= 12 else list(range(5)) + [None] + list(range(n - 5, n))
    lines.append(f"amplitude ({n} DOF{'s' if n != 1 else ''}, (max - min)/2 over one period)")
    dw = len(str(n - 1))
    for d in shown:
        lines.append("  ..." if d is None else f"  dof {d:>{dw}}  {_fmt_float(amp[d])}")
    return "\n".join(lines)


def _write_json(path, payload, case=None):
    write_text(path, json.dumps(jsonable(payload), indent=2, allow_nan=False) + "\n", case)


def _solve(args):
    if args.out is not None:
        check_out(args.out, args.case)  # --out rules: mshbm.outfile
    case = _io.load_case(args.case, sets=case_sets(args))
    cli_opts = {k: getattr(args, k) for k in ("harmonics", "steps", "period", "integrator", "accuracy")
                if getattr(args, k) is not None}
    try:
        sol = case.solve(args.method, progress=not args.quiet, **cli_opts)
    except InputError as exc:
        if exc.key in cli_opts:
            raise InputError(f"--{exc.key}", exc.problem) from None
        raise
    except ConvergenceError as exc:  # only with raise_on_failure; kept for safety
        _error(f"solve did not converge: {exc}")
        return EXIT_NOT_CONVERGED
    summary = sol.summary()
    summary["success"] = bool(sol.success)
    if args.out is not None:
        payload = {"case": case.name, **summary, "n_dofs": int(case.system.n), "source": case.source,
                   "version": __version__}
        # the element outputs with their series over the period (the grid of "t")
        payload["t"] = np.asarray(sol.t).tolist()
        payload["elements"] = [e.summary(series=True) for e in sol.elements]
        # the solution itself: the Fourier coefficients of every DOF (row 0 the mean, rows 2k-1 and 2k the
        # cosine and sine coefficients of harmonic k, m) and the time series of the time-stepped DOFs
        payload["q_hat"] = np.asarray(sol.q_hat).tolist()
        payload["time_dofs"] = [int(d) for d in np.asarray(sol.time_dofs).reshape(-1)]
        if len(payload["time_dofs"]):
            payload["q_time"] = np.asarray(sol.q_time).tolist()
            payload["u_time"] = np.asarray(sol.u_time).tolist()
        _write_json(args.out, payload, args.case)
    if not args.quiet:
        print(_table(case, summary))
        if args.out is not None:
            print(f"wrote {args.out}")
    if not sol.success:
        _error(f"solve did not converge: {sol.message}")
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def main(argv=None):
    """Run the ``mshbm`` command; returns the exit code."""
    try:
        parser = _parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help/--version (0) and usage errors (2)
            code = exc.code
            return code if isinstance(code, int) else (0 if code is None else EXIT_INPUT)
        if args.command is None:
            parser.print_usage(sys.stderr)
            _error("a command is required (e.g. 'mshbm solve CASE.yaml')")
            return EXIT_INPUT
        uninstall = None if args.quiet else _CompileNotice().install()
        try:
            with quiet_floats(), terminate_as_interrupt():  # no RuntimeWarnings on the terminal; SIGTERM as Ctrl-C
                if args.command == "sweep":
                    return cli_sweep.run(args, (EXIT_OK, EXIT_NOT_CONVERGED), _write_json, _error)
                if args.command == "backbone":
                    return cli_backbone.run(args, (EXIT_OK, EXIT_NOT_CONVERGED), _write_json, _error)
                return _solve(args)
        except InputError as exc:
            if exc.key == "omega" and getattr(args, "omega", None) is not None:
                exc = InputError("--omega", exc.problem)
            _error(f"{exc.key}: {exc.problem}")
            return EXIT_INPUT
        finally:
            if uninstall is not None:
                uninstall()
    except KeyboardInterrupt as exc:
        print(file=sys.stderr)
        _error("terminated (SIGTERM)" if getattr(exc, "signum", None) == signal.SIGTERM else "interrupted")
        return EXIT_TERMINATED if getattr(exc, "signum", None) == signal.SIGTERM else EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 -- the last line of defence: never show a traceback
        _error(f"internal: {type(exc).__name__}: {exc}")
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
