#!/usr/bin/python3
"""test_docs.py -- the API reference of docs/guide/python.md is the one the
docstrings give (scripts/python_apiref.py --check), and every public name of
the package has a docstring."""
import inspect
import os
import subprocess
import sys
import unittest

import padapt
from padapt import distributed, metric

SRC = os.environ.get("PADAPT_SRC", os.path.join(os.path.dirname(__file__), "..", ".."))


class Docs(unittest.TestCase):
    def test_reference_up_to_date(self):
        r = subprocess.run([sys.executable, os.path.join(SRC, "scripts", "python_apiref.py"), "--check"],
                           capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_docstrings(self):
        missing = []
        objs = [(n, getattr(padapt, n)) for n in padapt.__all__]
        objs += [("metric." + n, getattr(metric, n)) for n in metric.__all__]
        for cls in (padapt.Mesh, padapt.Report, distributed.DistributedMesh, distributed.Value):
            objs += [(cls.__name__ + "." + n, o) for n, o in cls.__dict__.items()
                     if not n.startswith("_") and (callable(o) or isinstance(o, (property, classmethod)))]
        for name, o in objs:
            if not isinstance(o, int) and not inspect.getdoc(o):
                missing.append(name)
        self.assertEqual(missing, [], "public names without a docstring")


if __name__ == "__main__":
    unittest.main(verbosity=2)
