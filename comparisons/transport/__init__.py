"""transport: see comparisons/__init__.py."""
