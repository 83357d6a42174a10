"""Closed-loop simulation: a mission's plan executed on its own dynamics under a bounded
disturbance, with agents lost and regions closed on the way, replanned by a policy.

:mod:`~stlplan.simulation.settings` reads and checks what a simulation runs (the disturbance
bound, the policy, the events); :mod:`~stlplan.simulation.run` executes one run and judges it;
:mod:`~stlplan.simulation.batch` runs many on the sweep's machinery (workers, Dask, resume) and
writes their records, table and figures; :mod:`~stlplan.simulation.report` summarizes records
and draws the fraction satisfied against the disturbance.
"""
