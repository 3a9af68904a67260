"""Runs test modules as on a machine without NumPy: `import numpy` fails, so `arrays="auto"`
clients take and return lists and the command line reads `.npy` with the standard library.

    python3 without_numpy.py test_arrays test_cli
"""

import sys
import unittest

sys.modules["numpy"] = None  # type: ignore[assignment]  # makes `import numpy` raise ImportError

unittest.main(module=None, argv=[sys.argv[0], "-v", *sys.argv[1:]])
