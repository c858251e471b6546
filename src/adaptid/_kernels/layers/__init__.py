"""The kernels of the later layers: compiled loops that diagnostics, models,
datasets and fleet call.

``_residuals`` (recursive residuals), ``_breakpoints`` (recursive and moving
estimates, F statistics, break dating), ``_pseudolinear`` (the pseudo-linear
regressions of ARMAX/OE/BJ), ``_plr_stream`` (the same, resumable, for the
streaming model objects), ``_riv`` (recursive instrumental variables with
an auxiliary model), ``_mimoarx`` (MIMO ARX simulation), ``_narx`` (NARX
term evaluation and free-run simulation), ``_statespace`` (the prediction-
error sensitivities of a state-space model, for its covariance),
``_simulators`` (the DC motor), ``_fleet`` (the per-group scans of
:mod:`adaptid.fleet`).
"""
