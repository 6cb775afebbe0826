"""Runs the Python module's tests under pytest for CTest (python/CMakeLists.txt): exit 77,
which CTest reports as skipped, when pytest is not installed (apt-get install python3-pytest)."""
import sys

try:
    import pytest
except ImportError:
    print("python3-pytest is not installed: the Python module's tests are skipped")
    sys.exit(77)

sys.exit(pytest.main(["-q", "-p", "no:cacheprovider", sys.argv[1]]))
