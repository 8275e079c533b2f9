"""The solve layer: from a study's grid to the orbits at every point, over the kernels.

``seeds`` (where Newton starts: the linear response, the multiple-scales 2T response, flip
eigenvectors, continuation from a neighbour), ``point`` (shooting from a point's seeds and keeping
each orbit once), ``block`` (one block of the grid: omega lines swept both ways; what a Dask
worker runs), ``discovery`` (transients and continuation along a line: isolas, unstable
branches, located bifurcation points). Numpy and the kernels only: no Dask, no I/O.
"""
