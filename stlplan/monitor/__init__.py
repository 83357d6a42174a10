"""The independent monitor: verdicts and robustness of any team trajectory."""
