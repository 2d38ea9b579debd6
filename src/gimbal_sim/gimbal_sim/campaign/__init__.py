"""The campaign engine: a campaign's spec and plan, one task per run (serially or on Dask),
the results table, the campaign report, and the experiment-campaign types the paper
runners fill in."""
