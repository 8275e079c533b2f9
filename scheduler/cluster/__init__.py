"""Where a study runs: an embedded LocalCluster, an existing Dask scheduler, or a dask-jobqueue cluster (clusters)."""
