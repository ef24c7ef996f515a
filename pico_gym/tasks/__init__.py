"""Tasks: where the robot starts, what counts as success, which reward terms apply."""
