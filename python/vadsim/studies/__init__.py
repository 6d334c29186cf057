"""Studies over operating points and designs: flow sweeps and maps (resumable, threads or
Dask), the dissertation's design studies and optimisation, and its reproduction."""
