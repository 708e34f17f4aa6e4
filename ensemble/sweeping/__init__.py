"""Parameter sweeps: sweep files, the planner, the Zarr stores, and running batches here or on Dask workers."""
