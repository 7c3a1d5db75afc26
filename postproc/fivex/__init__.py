"""Five-axis machines: machine data, kinematics, rotary-axis calibration, RTCP emitters."""
