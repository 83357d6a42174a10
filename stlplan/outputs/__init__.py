"""What a run writes and shows: the plan directory, CSV, JSON summary, plots, terminal."""
