"""Runs the panotrack pytest suite for ctest (python/pytest).

Exits 77 (skipped) when pytest or numpy is missing from the interpreter the
module was built for; any other failure, including an import error of
panotrack itself, fails the test.
"""
import sys


def main():
    try:
        import numpy  # noqa: F401
        import pytest
    except ImportError as e:
        print(f"python/pytest: skipped: {e}")
        return 77
    # No cache folder in the source tree; -rs lists the skipped tests and why.
    return pytest.main(["-q", "-rs", "-p", "no:cacheprovider", *sys.argv[1:]])


# Guarded: processes that a test spawns (Dask's workers) import this file again.
if __name__ == "__main__":
    sys.exit(main())
