"""Building and solving the planning MILP: encoding, HiGHS sessions, lazy rounds, parts."""
