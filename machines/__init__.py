"""Five-axis machine data files (package data: ``postproc.machine_files``)."""
