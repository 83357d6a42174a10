"""The run: its time (budget), its clock and records (how far step 1 got, the convergence record, the trace of plans by stage), and the outcome rules."""
