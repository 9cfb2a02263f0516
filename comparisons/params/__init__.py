"""params: see comparisons/__init__.py."""
