"""Running simulations: the flow runner (stop criteria, guards, checkpoints), output writers (time series, VTK,
figures, progress), execution on Dask, and throughput measurement.
"""

