"""Shared helpers of the workflow scripts: systems from the config, paths, small statistics.

Nothing here solves anything by itself; the solver is :func:`mshbm.solve`.  Imported by the rule
files (``workflow/rules/common.smk``), the scripts, the notebooks' helpers and the tests.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

METHOD_LABELS = {"shooting": "full shooting", "hbm": "HBM", "mshbm": "MS-HBM",
                 "mshbm-intermediate": "MS-HBM (intermediate)", "shooting-fd": "full shooting, FD Jacobian",
                 "mshbm-fd": "MS-HBM, FD Jacobian"}


def split_method(method):
    """``"mshbm-fd"`` -> ``("mshbm", "fd")``: a ``-fd`` suffix selects the finite-difference Jacobian
    (the paper's choice) instead of the configured one; ``(method, None)`` otherwise."""
    if method.endswith("-fd"):
        return method[: -len("-fd")], "fd"
    return method, None


# ----------------------------------------------------------------------------- config
def omega(config):
    """Forcing angular frequency (rad/s)."""
    return float(config["omega_over_pi"]) * math.pi


def hbm_samples(config, n_h):
    """AFT samples of HBM for ``n_h`` harmonics (config ``numerics.hbm_samples``)."""
    rule = config["numerics"]["hbm_samples"]
    if rule == "auto":
        return 1 << max(9, math.ceil(math.log2(16 * (2 * int(n_h) + 1))))
    return int(rule)


def method_steps(config, method, n_h, reference=False):
    """Time points per period used for a solve of ``method`` with ``n_h`` harmonics."""
    if split_method(method)[0] in ("hbm", "dlft"):  # the AFT samples (DLFT uses HBM's rule)
        return hbm_samples(config, n_h)
    return int(config["numerics"]["reference_steps" if reference else "steps"])


def method_harmonics(config, method, n_h):
    """``n_h`` in the result key (shooting: harmonics of its reported Fourier coefficients)."""
    return int(config["numerics"]["shooting_harmonics"]) if split_method(method)[0] == "shooting" else int(n_h)


def solve_stem(config, case, method, n_h=None, reference=False):
    """Path stem (without .json/.npz) of one solve under ``results_dir``."""
    nh = method_harmonics(config, method, n_h)
    steps = method_steps(config, method, nh, reference)
    return f"{config['results_dir']}/solves/{case}/{method}_nh{nh}_N{steps}"


#: the repository root (case files are named relative to it) and the case files of the paper's systems
ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples"
#: keys of a ``systems.<name>`` entry that :func:`resolve_systems` derives from its case file (for the
#: tables, notebooks and the footnote keys of ``choices``); the case file is their only source
DERIVED_KEYS = ("n", "mass_first", "mass_other", "stiffness", "damping", "forcing_amplitude", "friction", "contact")


def case_path(case):
    """Path of a case file: ``"examples/impact5.yaml"`` (relative to the repository root), an absolute
    path, or a bare name (``"impact5"`` -> ``examples/impact5.yaml``)."""
    path = Path(case)
    if path.suffix not in (".yaml", ".yml") and len(path.parts) == 1:
        path = EXAMPLES / f"{case}.yaml"
    return path if path.is_absolute() else ROOT / path


def load_case(case, **overrides):
    """:func:`mshbm.load_case` of a case file named as in :func:`case_path`."""
    import mshbm

    return mshbm.load_case(case_path(case), **overrides)


def build_system(scfg, name="system"):
    """:class:`mshbm.System` of one ``systems.<name>`` entry of the config: its case file (``case``)."""
    system = load_case(scfg["case"]).system
    system.name = name
    return system


def chain_parameters(system):
    """The chain parameters of a paper system (wall - k - m_1 - k - ... - m_n, one element on mass 1,
    ``A cos(omega t)`` on mass n): ``{n, mass_first, mass_other, stiffness, damping, forcing_amplitude,
    friction: {mu, normal_force, kappa} | contact: {gap, restitution, penalty_stiffness,
    penalty_damping}}``.  Raises ``ValueError`` for a system of another form."""
    from mshbm import chain

    n = system.n
    M, C, K = (np.asarray(system.dense(k), dtype=float) for k in "MCK")
    f_hat = np.asarray(system.f_hat, dtype=float)
    masses = np.diag(M)
    out = {"n": int(n), "mass_first": float(masses[0]), "mass_other": float(masses[-1]),
           "stiffness": float(K[-1, -1]), "damping": float(C[-1, -1]),
           "forcing_amplitude": float(f_hat[1, n - 1]) if f_hat.shape[0] > 1 else 0.0}
    if len(system.elements) != 1 or system.elements[0].dof != 0:
        raise ValueError(f"{system.name}: a paper system has one element, on mass 1")
    el = system.elements[0]
    if el.kind == "friction":
        out["friction"] = {"mu": float(el.mu), "normal_force": float(el.normal_force), "kappa": None if el.smoothing is None else float(el.smoothing)}
    else:
        out["contact"] = {"gap": float(el.gap), "restitution": float(el.restitution),
                          "penalty_stiffness": None if el.penalty_stiffness is None else float(el.penalty_stiffness), "penalty_damping": float(el.penalty_damping)}
    same = chain([out["mass_first"]] + [out["mass_other"]] * (n - 1), out["stiffness"], out["damping"],
                 forcing=[{"dof": n - 1, "amplitude": out["forcing_amplitude"]}], elements=system.elements)
    if not all(np.array_equal(np.asarray(same.dense(k)), A) for k, A in zip("MCK", (M, C, K))) \
            or not np.array_equal(np.asarray(same.f_hat), f_hat):
        raise ValueError(f"{system.name}: not a chain of the paper's form (uniform springs and dampers, "
                         "masses 2..n equal, forcing A cos(omega t) on the last mass only)")
    return out


def resolve_systems(config):
    """Fill the parameters of every ``systems.<name>`` entry from its case file, in place.

    The case files (``examples/*.yaml``) are the one definition of the paper's systems; the derived
    keys (:data:`DERIVED_KEYS`) are what the tables, notebooks and ``choices`` read.  Returns ``config``.
    """
    for name, scfg in config["systems"].items():
        for key in DERIVED_KEYS:
            scfg.pop(key, None)
        scfg.update(chain_parameters(load_case(scfg["case"]).system))
    return config


def chain_case(case, n=None, name=None, **element):
    """The system of a paper case file with ``n`` masses instead of its own (``None``: its own; masses
    2..n as its mass 2, the forcing moved to mass n), its element's parameters replaced by ``element``
    (keys of the case file's ``friction``/``contact`` mapping, e.g. ``smoothing=``,
    ``penalty_stiffness=``, ``gap=``): the parameterised families of the scaling benchmarks, the
    stress suite and the tests."""
    from mshbm.io import parse_case
    from mshbm.io.yaml import load_yaml, read_text

    path = case_path(case)
    data = load_yaml(read_text(path))
    kind = "friction" if "friction" in data else "contact"
    if n is not None:
        masses = list(data["masses"])
        data["masses"] = masses[:1] + [masses[1] if len(masses) > 1 else masses[0]] * (n - 1)
        data["forcing"] = [dict(f, dof=n - 1) for f in data["forcing"]]
        data.pop("name", None)
    if element:
        data[kind] = dict(data[kind], **element)
    name = name or data.get("name") or f"{kind if kind == 'friction' else 'impact'}{n}"
    data.pop("name", None)
    return parse_case(data, name=name, source=str(path)).system


def get_key(config, dotted):
    """Value of a dotted key (``"systems.friction3.friction.normal_force"``) of the config."""
    node = config
    for part in dotted.split("."):
        node = node[int(part)] if isinstance(node, list) else node[part]
    return node


# ----------------------------------------------------------------------------- results
def load_validated_yaml(path, schema_path):
    """The YAML file ``path`` validated against the JSON schema in the YAML file ``schema_path``; ``ValueError``
    naming the file and the failing key (dotted path) when it does not conform."""
    import jsonschema
    import yaml

    with open(path, encoding="utf-8") as fh:
        cfg = yaml.safe_load(fh)
    with open(schema_path, encoding="utf-8") as fh:
        schema = yaml.safe_load(fh)
    try:
        jsonschema.validate(cfg, schema)
    except jsonschema.ValidationError as exc:
        where = ".".join(str(p) for p in exc.absolute_path) or "(top level)"
        raise ValueError(f"{path}: {where}: {exc.message}") from None
    return cfg


def load_json(path):
    with open(path) as fh:
        return json.load(fh)


def write_json(path, data, allow_nan=True):
    """Write ``data`` atomically, converted by :func:`mshbm.outfile.jsonable`.  ``allow_nan``: non-finite
    floats stay ``NaN``/``Infinity`` (the solve facts, which the summaries read back); else ``null``."""
    from mshbm.outfile import jsonable

    Path(path).parent.mkdir(parents=True, exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as fh:
        json.dump(jsonable(data, allow_nan=allow_nan), fh, indent=1, sort_keys=False, allow_nan=allow_nan)
        fh.write("\n")
    os.replace(tmp, path)
    return Path(path)


def runs(mask):
    """Maximal runs of True in a periodic boolean sequence: list of (start, length)."""
    mask = np.asarray(mask, dtype=bool)
    n = mask.size
    if n == 0 or not mask.any():
        return []
    if mask.all():
        return [(0, n)]
    # rotate so that index 0 is False: runs then never wrap around
    shift = int(np.flatnonzero(~mask)[0])
    m = np.roll(mask, -shift)
    d = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int((s + shift) % n), int(e - s)) for s, e in zip(starts, ends)]


def md_table(header, rows):
    """A Markdown table; a ``|`` inside a cell is written as ``/`` (it would end the cell)."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c).replace("|", "/") for c in r) + " |" for r in rows]
    return "\n".join(out)


def rel_err(value, ref):
    """``|value / ref - 1|`` (``None`` when either is missing)."""
    if value is None or ref is None:
        return None
    return abs(float(value) / float(ref) - 1.0)


# ----------------------------------------------------------------------------- placeholders
_PLACEHOLDER = None


def format_value(value, fmt=None):
    """Format a generated number for text: filters pct, pct1, pct3, f1..f4, sci, int, g, yesno."""
    if value is None:
        return "n/a"
    if isinstance(value, bool) or fmt == "yesno":
        return "yes" if value else "no"
    if isinstance(value, str):
        return value
    if fmt is None and isinstance(value, int):
        return str(value)
    if fmt is None or fmt == "g":
        return f"{value:.4g}"
    if fmt.startswith("pct"):
        digits = int(fmt[3:] or 2)
        if value == 0:
            return "0 %"
        v = 100 * float(value)
        s = f"{v:.{digits}g}"
        if "e" in s:  # 100 % -> "100 %", not "1e+02 %"; tiny values in scientific notation
            s = f"{v:.0f}" if abs(v) >= 1 else f"{v:.{digits}e}"
        return f"{s} %"
    if fmt.startswith("f") and fmt[1:].isdigit():
        return f"{float(value):.{int(fmt[1:])}f}"
    if fmt == "sci":
        return f"{float(value):.2e}"
    if fmt == "int":
        return f"{int(round(float(value)))}"
    raise ValueError(f"unknown format {fmt!r}")


def fill_placeholders(text, context):
    """Replace ``{{fig8.key|fmt}}`` and ``{{config.dotted.key|fmt}}`` by generated values.

    ``context`` maps a prefix (``fig3``..``fig8``, ``config``) to the figure's summary
    ``numbers`` dict or the configuration.  An unknown key raises ``KeyError``: a typo in the
    manuscript must fail the build, never print a wrong number.
    """
    import re

    global _PLACEHOLDER
    if _PLACEHOLDER is None:
        _PLACEHOLDER = re.compile(r"\{\{\s*([A-Za-z0-9_]+)\.([A-Za-z0-9_.\-]+?)\s*(?:\|\s*([a-z0-9]+)\s*)?\}\}")

    def repl(m):
        prefix, key, fmt = m.group(1), m.group(2), m.group(3)
        if prefix not in context:
            raise KeyError(f"placeholder {m.group(0)}: unknown prefix {prefix!r}")
        src = context[prefix]
        if prefix == "config":
            value = get_key(src, key)
        else:
            if key not in src:
                raise KeyError(f"placeholder {m.group(0)}: no key {key!r} in {prefix}")
            value = src[key]
        return format_value(value, fmt)

    return _PLACEHOLDER.sub(repl, text)


def run_case_script(run, doc, script_globals):
    """Entry point of a per-case script ``run(cfg, case, stem, log=print)`` (rules ``longrun``, ``impact_time``).

    Under Snakemake (``snakemake`` in the script's globals): the rule's ``params.cfg``, ``wildcards.case``
    and ``output.json`` without its suffix, with the messages in the rule's log.  Stand-alone:
    ``python SCRIPT CONFIG.yaml CASE OUT_STEM`` (else print ``doc`` and exit).
    """
    smk = script_globals.get("snakemake")
    if smk is not None:
        with open(smk.log[0], "w") as logf:
            def _log(msg):
                print(msg, file=logf, flush=True)
            return run(smk.params.cfg, smk.wildcards.case, smk.output.json[: -len(".json")], log=_log)
    import sys

    import yaml

    if len(sys.argv) != 4:
        sys.exit(doc)
    with open(sys.argv[1]) as fh:
        cfg = yaml.safe_load(fh)
    return run(cfg, sys.argv[2], sys.argv[3])
