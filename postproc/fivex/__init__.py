"""Five-axis machines: machine data, kinematics, rotary-axis calibration (seeds 003, 004), probing,
error maps, the calibration as controller machine data. Programs for them are ``postproc.jobs.five_axis``."""
