"""stlplan: multi-agent plans from global STL tasks with synchronous satisfaction requirements."""

__version__ = "0.1.0"
