"""The command line and what each command does: solve, run, study, bench, gradcheck.
The only layer that knows of exit statuses, run folders and the console."""
