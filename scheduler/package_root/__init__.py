"""hertzmap: the vibration of a preloaded Hertzian contact (a ball pressed on a plane, shaken
by a harmonic force) mapped over (omega, sigma, zeta) grids: every periodic response, stable or
not, of any period, with its Floquet multipliers, and what attracts where none does.

The library's front door (pyproject.toml installs this file as the package ``hertzmap``; the
functions live in hertzmap.scheduler.doors.library and hertzmap.kernels.api)::

    import hertzmap
    tree = hertzmap.run("default", "results/default.zarr", client=client)  # -> xarray.DataTree
    tree = hertzmap.open("results/default.zarr")                            # lazily
    hertzmap.plot("results/default.zarr", ["map"])                          # PNGs
    bm = hertzmap.basins("results/default.zarr", omega=1.95, sigma=2.0)     # a basin map
    fit = hertzmap.fit("measured.csv", "rig.toml", out="results")          # f0, zeta, sigma
    orbit = hertzmap.shoot(1.9, 0.5, 0.01, period=2)                        # one orbit

Studies: a path, a scene's name (``hertzmap.scene_paths()``), TOML text or a dict
(docs/study-file.md); stores: docs/dataset.md. Bad input raises :class:`StudyError` (its
``field`` names the key) or :class:`RefusedError` before anything is written.
"""
from __future__ import annotations

import importlib

#: each public name -> the module that defines it (imported on first use: ``import hertzmap``
#: loads neither numba nor Dask)
_WHERE = {
    **{name: "hertzmap.scheduler.doors.library" for name in (
        "run", "open", "load_study", "scene_paths", "products", "plot", "basins", "fit",
        "Study", "StudyError", "RefusedError", "FitInputError", "IncompleteRun")},
    **{name: "hertzmap.kernels.api" for name in (
        "shoot", "shoot_batch", "simulate", "attractor", "attractor_batch", "lyapunov",
        "Orbit")},
}
__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'hertzmap' has no attribute {name!r}")
    value = getattr(importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
