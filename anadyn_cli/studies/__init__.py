"""Studies: many runs of the services, as one piece of work (parameter sweeps,
batch files), on this machine or a Dask cluster."""
