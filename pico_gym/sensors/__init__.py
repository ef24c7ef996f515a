"""Sensors: the laser range finder and wheel odometry."""
