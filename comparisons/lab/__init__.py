"""lab: see comparisons/__init__.py."""
