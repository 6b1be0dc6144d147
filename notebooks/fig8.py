# %% [markdown]
# # Fig. 8 — work–precision diagram, 50-mass chain with impact
#
# **Paper (Sec. 4.2, Fig. 8):** the 5-DOF impact oscillator extended to 50 masses (Table 2,
# contact gap at mass 1).  Work–precision as in Fig. 4, full shooting as reference.  Claim:
# *"The MS-HBM provides an accuracy of less than 2% deviation of the amplitude with only
# one-fifth of the calculation effort.  It should be noted that the reduction of the calculation
# effort becomes even more significant if the size of the linear subsystem increases."*  HBM uses
# the penalty contact ($k_c = 8000$, $d_c = 0$); MS-HBM and shooting the set-valued contact with
# Newton's impact law ($e_N = 1$).  The harmonics of Fig. 8 are not stated; we use those of
# Fig. 4.
#
# **Here (protocol):** each point is one solve job.  The timed solve at $\omega$ starts from the
# method's own converged solution at the nearby frequency (config `starts.nearby_factor`),
# computed in the same job; if no such solution exists, it starts from the linear response at
# $\omega$ (half-filled marker) — full shooting, the effort reference, is timed from both starts
# and each point is divided by the shooting time *from the same start*.  Effort = median of
# the timed repeats after an untimed warm-up (numba compilation excluded), whole `mshbm.solve`
# call.  Errors are against the exact periodic solution of the event-driven flow
# (`mshbm.methods.exact`, started from full shooting with the finer reference step; no time step, events
# to machine precision) — not against that shooting reference, whose own discretisation error
# would otherwise show as the plateau of the paper's diagrams.  The dashed black line is the
# error of full shooting with the working step count against the exact solution (the
# time-discretisation floor).  Next to the times, the table lists machine-independent counts
# (residual evaluations, Moreau–Jean steps times integrated DOFs).  Points that did not converge from any start are drawn as ×
# at the top of the panels and never as if valid.

# %% tags=["parameters"]
config = "results/config.json"
summary = "results/summary/fig8.json"
out_png = "results/figures/fig8.png"
out_pdf = "results/figures/fig8.pdf"

# %%
from mshbm_workflow.wpcommon import WorkPrecision
from IPython.display import Markdown, display

fig = WorkPrecision(config, summary)

# %% [markdown]
# ## The paper's claims and our numbers

# %%
display(Markdown(fig.claims()))

# %%
fig.plot(out_png, out_pdf)

# %% [markdown]
# ## All points
#
# `effort` = median time of the method / median time of full shooting from the same start
# (clock: config `timing.clock`; `effort (other clock)` uses the other one — wall time vs.
# process CPU time — as a check of the timing noise).  `start` is the start actually used
# (`nearby`: the paper's protocol).

# %%
display(Markdown(fig.points()))

# %% [markdown]
# ## Reference solutions
#
# The exact solution (error reference), the reference full shooting it starts from, and the
# effort reference (full shooting with the working step), reached from the solution at the nearby
# frequency (Newton).  Their stability comes from the Floquet multipliers of the exact
# event-driven flow with the saltation matrices of the impacts (`mshbm.stability`); Fig. 7 shows
# what the chain does from rest next to this orbit.

# %%
display(Markdown(fig.references()))
