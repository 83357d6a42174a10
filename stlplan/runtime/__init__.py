"""Process-wide state of a run: the stop requests of signals."""
