"""hertzmap kernels: pure numba functions on arrays (no I/O, no Dask, no xarray).

Public API::

    from hertzmap.kernels import shoot, shoot_batch, simulate, Orbit, status
    orbit = shoot(omega, sigma, zeta, period=1, guess=(q0, v0))   # Hertz, n = 3/2, rtol 1e-10
    a = attractor(omega, sigma, zeta, x0=(q0, v0), transient_periods=1000, record_periods=500)

Modules: ``model`` (paper Eq. 7 and 11), ``flight`` (closed-form flight), ``_dop853`` (generated
integrator steps), ``integrate`` (events, dense output, measures), ``shooting`` (Newton, Floquet),
``attractors`` (stroboscopic transients, period detection, Lyapunov exponents),
``continuation`` (a package: branches, the line search's seed path and bifurcation curves, one
module per algorithm on one predictor-corrector), ``central_difference`` (the paper's own
scheme, baseline), ``api`` (this interface).
"""
from hertzmap.kernels._cache import configure_cache_dir

CACHE_DIR = configure_cache_dir()   # before any kernel module is compiled

from hertzmap.kernels import status  # noqa: E402
from hertzmap.kernels._jit import compile_kernels, leaf_kernels  # noqa: E402
from hertzmap.kernels.api import (Attractor, Orbit, attractor, attractor_batch, lyapunov,  # noqa: E402
                         shoot, shoot_batch, simulate)

__all__ = ["Attractor", "Orbit", "attractor", "attractor_batch", "compile_kernels",
           "leaf_kernels", "lyapunov", "shoot", "shoot_batch", "simulate", "status"]
