"""The front doors: the command line (cli), the library (library), the dry run and the run's report, and the explore app (explore/)."""
