"""The classic escape agent: split-and-merge, exits, A*, potential field, a state machine."""
