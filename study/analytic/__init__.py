"""The paper's analytic results: the multiple-scales solution (``multiple_scales``, paper
section 3.1), the physical rig and its dimensionless groups (``rig``, Eq. 1-8 and 28-30), and the
numbers the paper prints (``paper``). Plain numpy functions; no kernels, no Dask, no I/O."""
