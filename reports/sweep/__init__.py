"""Sweeps of independent tasks: the isolated worker pool and runner, the Dask executor, and
the results folder they write (Parquet, resumable). Nothing here knows about hoops."""
