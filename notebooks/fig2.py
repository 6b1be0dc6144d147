# %% [markdown]
# # Fig. 2 — calculation scheme of MS-HBM (Section 3.2)
#
# Schreyer & Leine (2016), Fig. 2: *"Calculation scheme of MS-HBM with linear and nonlinear
# subsystem."*  Redrawn from the text (eqs. 22, 25–29).  One evaluation of the residual:
# the harmonic unknowns of the nonlinear subsystem give the motion of the linear subsystem in
# closed form (eq. 22); that motion forces the nonlinear subsystem, which is integrated in time
# with the set-valued laws by Moreau–Jean time-stepping (eq. 25, forcing sign as in eq. 6);
# the residual (27) asks for periodicity of the nonlinear subsystem and for its harmonic part to
# match the unknowns $\hat q_N$ (connectivity).  Newton's method (eq. 29) updates the unknowns;
# our implementation uses the exact Jacobian from the step sensitivities instead of the paper's
# finite differences (same solution; config `numerics.jacobian`).

# %% tags=["parameters"]
config = "results/config.json"
out_png = "results/figures/fig2.png"
out_pdf = "results/figures/fig2.pdf"

# %%
from mshbm_workflow import nbcommon as nc
import matplotlib.pyplot as plt
from matplotlib.patches import FancyBboxPatch, FancyArrowPatch

nc.setup()
cfg = nc.load_json(config)

# %%
fig, ax = plt.subplots(figsize=(7.2, 5.0))
ax.axis("off"); ax.set_xlim(0, 10); ax.set_ylim(0, 10)


def box(x, y, text, w=4.2, h=1.0, fc="#f2f2f2"):
    ax.add_patch(FancyBboxPatch((x - w / 2, y - h / 2), w, h, boxstyle="round,pad=0.05", fc=fc, ec="k", lw=0.9))
    ax.text(x, y, text, ha="center", va="center", fontsize=8.5)
    return (x, y, w, h)


def arrow(p, q, text=None, **kw):
    ax.add_patch(FancyArrowPatch(p, q, arrowstyle="-|>", mutation_scale=10, lw=0.9, **kw))
    if text:
        ax.text(0.5 * (p[0] + q[0]) + 0.1, 0.5 * (p[1] + q[1]), text, fontsize=7.5, va="center")


b0 = box(3.0, 9.2, r"unknowns $x = (\hat q_N,\ q_N(0),\ \dot q_N(0))$  (eq. 26)", w=5.4, fc="#fde0dd")
b1 = box(3.0, 7.6, r"linear subsystem (frequency domain, eq. 22)" "\n"
         r"$\hat q_L = H_{LL}^{-1}(\hat f_{ex,L} - H_{LN}\hat q_N)$", w=5.4)
b2 = box(3.0, 5.8, r"coupling force on N:  $q_L(t) = V_L(t)^T \hat q_L$" "\n"
         r"$f(t) = f_{ex,N}(t) - M_{NL}\ddot q_L - C_{NL}\dot q_L - K_{NL} q_L$", w=5.4)
b3 = box(3.0, 4.0, "nonlinear subsystem (time domain, eq. 25)\n"
         f"Moreau–Jean, {cfg['numerics']['steps']} steps/period, " r"$\theta$" f" = {cfg['numerics']['theta']}\n"
         "set-valued friction / contact + impact laws", w=5.4, h=1.3)
b4 = box(3.0, 2.1, r"residual (27):  $\hat q_N - \mathrm{FFT}(q_N(t))$," "\n"
         r"$q_N(T) - q_N(0)$,  $\dot q_N(T) - \dot q_N(0)$", w=5.4)
b5 = box(8.1, 2.1, r"$\|f_R\| \leq$ tol ?", w=2.4, fc="#e5f5e0")
b6 = box(8.1, 5.8, "Newton update (eq. 29)\n" r"$x \leftarrow x - (\partial f_R/\partial x)^{-1} f_R$" "\n"
         "(Jacobian: exact step\nsensitivities or FD)", w=3.2, h=1.6)
b7 = box(8.1, 0.55, "periodic solution", w=2.6, h=0.8, fc="#e5f5e0")
for a, b in ((b0, b1), (b1, b2), (b2, b3), (b3, b4)):
    arrow((a[0], a[1] - a[3] / 2), (b[0], b[1] + b[3] / 2))
arrow((b4[0] + b4[2] / 2, b4[1]), (b5[0] - b5[2] / 2, b5[1]))
arrow((b5[0], b5[1] + b5[3] / 2), (b6[0], b6[1] - b6[3] / 2), "no")
arrow((b5[0], b5[1] - b5[3] / 2), (b7[0], b7[1] + b7[3] / 2), "yes")
arrow((b6[0], b6[1] + b6[3] / 2), (b0[0] + b0[2] / 2, b0[1]), connectionstyle="arc3,rad=0.3")
ax.set_ylim(0, 9.9)
nc.save(fig, out_png, out_pdf)
