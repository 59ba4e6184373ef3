"""Runs the panotrack pytest suite for ctest (python/pytest).

Exits 77 (skipped) when pytest or numpy is missing from the interpreter the
module was built for; any other failure, including an import error of
panotrack itself, fails the test.
"""
import sys

try:
    import numpy  # noqa: F401
    import pytest
except ImportError as e:
    print(f"python/pytest: skipped: {e}")
    sys.exit(77)

# No cache folder in the source tree; -rs lists the skipped tests and why.
sys.exit(pytest.main(["-q", "-rs", "-p", "no:cacheprovider", *sys.argv[1:]]))
