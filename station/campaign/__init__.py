"""Campaigns: one station task (identify, validate, diagnose) over thousands of captures on Dask.

Modules, one job each:

* :mod:`station.campaign.sources` expands HDF5 sessions, CSV folders and globs into
  :class:`~station.campaign.sources.CaptureRef` (a path and a capture index: what is shipped
  to the workers, never the arrays);
* :mod:`station.campaign.tasks` is the work of one capture, run on a worker: read it, call the
  station's pipeline, turn the result into one table row (a failure becomes a row too);
* :mod:`station.campaign.table` keeps the rows: an append-only journal (resume), the CSV and
  Parquet tables and the model JSON files;
* :mod:`station.campaign.run` drives a ``dask.distributed`` cluster (a ``LocalCluster`` of
  processes by default, or an existing scheduler).

``station campaign`` (:mod:`station.commands.campaign`) is the command line. See
``docs/campaigns.md``.
"""
