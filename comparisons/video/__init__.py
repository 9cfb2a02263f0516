"""video: see comparisons/__init__.py."""
