"""Experiments over many runs: campaigns (Monte Carlo over seeds, parameter sweeps) of a
scenario's real node graph or of its cores, run as Dask tasks (:mod:`.campaign`)."""
