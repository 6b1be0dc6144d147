# %% [markdown]
# # Fig. 1 — the oscillator chain
#
# Schreyer & Leine (2016), Fig. 1: *"Three DOF oscillator with dry friction and unilateral
# constraint."*  The figure itself is not part of the text we reproduce from, so this schematic
# is drawn from the description and from our reading of the chain (config key `chain_support`):
# the wall holds mass 1 through spring $k_1$, spring $k_i$ joins masses $i-1$ and $i$, each
# damper $c_i$ is parallel to spring $k_i$, and the last mass is free and carries the forcing
# $f_{ex,n} = 5\cos(\omega t)$.  Mass 1 carries the nonlinearity: dry friction (normal force $F_N$,
# coefficient $\mu$; Figs. 3–4) or a unilateral stop at gap $g_{N,0}$ (Figs. 5–8).  The longer
# chains of Figs. 4, 7 and 8 insert further masses between mass 2 and the last one.

# %% tags=["parameters"]
config = "results/config.json"
out_png = "results/figures/fig1.png"
out_pdf = "results/figures/fig1.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import numpy as np
import matplotlib.pyplot as plt
from matplotlib.patches import Rectangle, FancyArrowPatch
from IPython.display import Markdown, display

nc.setup()
cfg = nc.load_json(config)
print(cfg["chain_support"])

# %%
def spring(ax, x0, x1, y, n=6, h=0.12, **kw):
    xs = np.linspace(x0 + 0.12 * (x1 - x0), x1 - 0.12 * (x1 - x0), 2 * n + 1)
    ys = y + h * np.array([0] + [(-1) ** i for i in range(2 * n - 1)] + [0])
    ax.plot([x0, xs[0]], [y, y], "k", lw=1, **kw)
    ax.plot(xs, ys, "k", lw=1, **kw)
    ax.plot([xs[-1], x1], [y, y], "k", lw=1, **kw)


def damper(ax, x0, x1, y, w=0.12):
    xm = 0.5 * (x0 + x1)
    ax.plot([x0, xm - 0.05], [y, y], "k", lw=1)
    ax.plot([xm - 0.05, xm - 0.05], [y - w, y + w], "k", lw=1)
    ax.plot([xm - 0.2, xm + 0.12, xm + 0.12, xm - 0.2], [y - w * 1.4, y - w * 1.4, y + w * 1.4, y + w * 1.4], "k", lw=1)
    ax.plot([xm + 0.12, x1], [y, y], "k", lw=1)


def hatch_ground(ax, x0, x1, y, down=True):
    ax.plot([x0, x1], [y, y], "k", lw=1.2)
    for x in np.arange(x0, x1, 0.15):
        ax.plot([x, x + 0.1], [y, y - 0.1] if down else [y, y + 0.1], "k", lw=0.6)


fig, ax = plt.subplots(figsize=(7.2, 2.9))
ax.set_aspect("equal"); ax.axis("off")
# wall
ax.plot([0, 0], [0, 1.6], "k", lw=1.2)  # wall
for y in np.arange(0.0, 1.6, 0.15):
    ax.plot([0, -0.1], [y, y + 0.1], "k", lw=0.6)
hatch_ground(ax, 0, 9.6, 0.0)
xs = [1.6, 4.4, 7.2]
W, H = 1.0, 0.9
for i, x in enumerate(xs):
    ax.add_patch(Rectangle((x, 0.02), W, H, fc="0.92", ec="k", lw=1.2))
    ax.text(x + W / 2, 0.47, f"$m_{i + 1}$", ha="center", va="center", fontsize=10)
    left = 0 if i == 0 else xs[i - 1] + W
    spring(ax, left, x, 0.7)
    damper(ax, left, x, 0.25)
    ax.text(0.5 * (left + x), 0.93, f"$k_{i + 1}$", ha="center")
    ax.text(0.5 * (left + x) - 0.3, 0.25, f"$c_{i + 1}$", ha="right", va="center", fontsize=8)
    ax.plot([x + W / 2, x + W / 2], [H + 0.05, 2.05], color="0.5", lw=0.6, ls=":")
    ax.add_patch(FancyArrowPatch((x + W / 2, 2.0), (x + W / 2 + 0.6, 2.0), arrowstyle="-|>", mutation_scale=8))
    ax.text(x + W / 2 + 0.3, 2.07, f"$q_{i + 1}$", ha="center", va="bottom")
# friction under mass 1
ax.text(xs[0] + W / 2, -0.22, r"$\mu,\ F_N$", ha="center", va="top", fontsize=8)
ax.plot([xs[0] + 0.1, xs[0] + W - 0.1], [-0.03, -0.03], color="#d62728", lw=2.2)
# unilateral stop: a lug on mass 1 and a fixed stop at distance g0
ax.add_patch(Rectangle((xs[0] + W - 0.15, H + 0.02), 0.15, 0.5, fc="0.6", ec="k", lw=0.8))
xs_stop = xs[0] + W + 0.35
ax.add_patch(Rectangle((xs_stop, 1.12), 0.15, 0.48, fc="0.75", ec="k", lw=0.8, hatch="////"))
hatch_ground(ax, xs_stop - 0.3, xs_stop + 0.45, 1.6, down=False)
ax.annotate("", xy=(xs_stop, 1.3), xytext=(xs[0] + W, 1.3), arrowprops=dict(arrowstyle="<->", lw=0.8))
ax.text(xs[0] + W - 0.22, 1.3, "$g_{N,0}$", ha="right", va="center", fontsize=8)
ax.text(xs_stop + 0.25, 1.25, "stop", fontsize=7, va="center")
# forcing
ax.add_patch(FancyArrowPatch((xs[2] + W, 0.47), (xs[2] + W + 0.9, 0.47), arrowstyle="-|>", mutation_scale=10,
                             color="#1f77b4", lw=1.5))
ax.text(xs[2] + W + 0.95, 0.47, r"$f_{ex,n}(t)$", va="center", color="#1f77b4")
ax.set_xlim(-0.3, 10.2); ax.set_ylim(-0.45, 2.4)
nc.save(fig, out_png, out_pdf)

# %% [markdown]
# Systems of the figures (from the configuration):

# %%
rows = []
for name, s in cfg["systems"].items():
    law = ("friction: mu = {mu}, F_N = {normal_force}, kappa = {kappa}".format(**s["friction"]) if "friction" in s
           else "contact: g0 = {gap}, e_N = {restitution}, k_c = {penalty_stiffness}, d_c = {penalty_damping}".format(**s["contact"]))
    rows.append((name, s["n"], s["mass_first"], s["mass_other"], s["stiffness"], s["damping"], law))
display(Markdown(nc.md_table(["system", "n", "m_1", "m_i (i>1)", "k_i", "c_i", "element on mass 1"], rows)))
