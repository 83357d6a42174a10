"""Batches of solves from random initial states (the paper's Table 3)."""
