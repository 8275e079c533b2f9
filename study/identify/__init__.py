"""From the rig to the model (issue 49): the linearised natural frequency f0, the damping
ratio zeta and the excitation amplitude sigma (and on request the contact exponent n)
identified from a lab's measured stepped-sine sweeps, with 95 % profile-likelihood intervals.

One step of the identification per module, each pure (numpy, scipy, xarray; no Dask, no files
written; scheduler.stages.fit_tasks ships the work to a cluster and writes the result):

* ``measurement.py``: the measured sweeps as a lab exports them (CSV or xarray Dataset), read
  and validated (every error names its row and column), and the one input error of a fit;
* ``rig_table.py``: the rig table (RIG.toml: the preload N, what else is known of the rig, the
  excitation set point), validated field by field;
* ``problem.py``: the fit's problem (measurement, rig, free parameters and their bounds, the
  forward model's omega grid), checked against what the model covers;
* ``forward_model.py``: the model's quasi-static stepped sweeps up and down at one (sigma,
  zeta[, n]) over a fine omega grid, read at every measured frequency for any f0 (f0 only
  stretches the frequency axis), on the branch the sweep is on there;
* ``likelihood.py``: the noise model (multiplicative plus an additive floor, its two
  parameters estimated by maximum likelihood) and the log-likelihood, maximised over f0;
* ``profile_likelihood.py``: one point of a parameter's profile (the others re-optimised), the
  95 % interval read off a profile, open to a bound where it does not cross;
* ``estimation.py``: the fit: a global grid over (sigma, zeta[, n]), a Gauss-Newton
  refinement, the profiles until each interval is found (the work handed out in batches
  through a mapper: scheduler.stages.fit_tasks gives Dask's);
* ``fit_dataset.py``: the result as an xarray Dataset (every variable with long_name, units).
"""
