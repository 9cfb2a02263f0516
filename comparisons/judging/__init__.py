"""judging: see comparisons/__init__.py."""
