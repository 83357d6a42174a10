"""The only code that talks to the solver: sessions, starts, confirmations of infeasible verdicts, values by key."""
