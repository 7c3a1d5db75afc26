"""Compensation that imports no language: ``core`` rewrites targets by the error model and the
rules of the controller object it is given. ``postproc.jobs.compensate`` (one floor up) is the
public entry, which takes the controller of the program's language where none is given."""
