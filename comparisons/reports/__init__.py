"""reports: see comparisons/__init__.py."""
