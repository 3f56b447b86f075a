"""Running sweeps: the sweep file and its versions, signals, the worker, the runner and its
executors (local processes, Dask), locks, watchdog and progress.  Imports metrics and the store,
never the report."""
