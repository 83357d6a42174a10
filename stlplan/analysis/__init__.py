"""Facts about a problem found before any model is built: its size, the conflicts of step 0,
the regions no agent can reach in time, and the diagnosis of an infeasible mission. No Pyomo,
no HiGHS."""
