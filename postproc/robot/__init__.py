"""The robot: kinematics, robot files, postures, rotations."""
