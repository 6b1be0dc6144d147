# %% [markdown]
# # Fig. 4 — work–precision diagram, 30-mass chain with friction
#
# **Paper (Sec. 4.1, Fig. 4):** the 3-DOF friction oscillator is extended to $n = 30$ masses
# (forcing $5\cos\omega t$ on the last mass only).  For $n_H = 1, 3, \dots, 25$ the relative
# amplitude error of mass 1 and of mass $n$ and the calculation effort of HBM and MS-HBM are
# shown, both relative to full shooting ("almost exact").  Every method starts from its own
# solution at a nearby frequency.  Claims: *"the computation effort for a moderate accuracy can
# be reduced drastically by using the MS-HBM approach.  Compared to the HBM, the mixed approach
# shows for all values of $n_H$ more accurate results.  The horizontal plateau of the relative
# error of the mixed method can be explained by the limited resolution of the used Fourier
# transformation and the integration schemes."*
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
summary = "results/summary/fig4.json"
out_png = "results/figures/fig4.png"
out_pdf = "results/figures/fig4.pdf"

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
# event-driven flow with the saltation terms of the stick-slip transitions (`mshbm.stability`); for
# the undamped friction chain the largest modulus is close to 1.

# %%
display(Markdown(fig.references()))
