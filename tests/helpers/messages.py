"""What a message shown to a user never contains."""

from __future__ import annotations

NOISE = ("Input should", "pydantic", "https://", "Traceback", "Value error", "For further")
"""Fragments of pydantic's own wording and of tracebacks, which a clean message translates."""
