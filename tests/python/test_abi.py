"""test_abi.py -- the ctypes mirrors of padapt.h's structures have the C
layout: sizes of every mirrored structure and offsets of the option fields
Python fills in, against tests/python/abi_layout.c built with the library
(PADAPT_ABI_LAYOUT names that program)."""
import os
import subprocess
import unittest

from padapt import _lib
from padapt import levelset as _levelset
from padapt import mesh as _mesh

MIRROR = {
    "pa_stats": _lib.Stats,
    "pa_fidelity": _lib.Fidelity,
    "pa_write_opts": _mesh._WriteOpts,
    "pa_remesh_opts": _lib.RemeshOpts,
    "pa_transfer_report": _lib.TransferReport,
    "pa_remesh_report": _lib.RemeshReport,
    "pa_metric_hessian_opts": _lib.HessianOpts,
    "pa_metric_levelset_opts": _lib.LevelsetOpts,
    "pa_dmesh_iter": _lib.DmeshIter,
    "pa_adapt_iter": _lib.AdaptIter,
    "pa_adapt_opts": _lib.AdaptOpts,
    "pa_adapt_report": _lib.AdaptReport,
    "pa_ls_material": _levelset.Material,
    "pa_levelset_opts": _levelset.CutOpts,
    "pa_levelset_report": _levelset.CutReport,
}


class TestAbi(unittest.TestCase):
    def test_layout(self):
        out = subprocess.run([os.environ["PADAPT_ABI_LAYOUT"]], check=True,
                             capture_output=True, text=True).stdout
        seen = 0
        for line in out.split("\n"):
            if not line:
                continue
            name, value = line.split()
            struct, _, field = name.partition(".")
            cls = MIRROR[struct]
            got = getattr(cls, field).offset if field else \
                __import__("ctypes").sizeof(cls)
            self.assertEqual(got, int(value), "%s: ctypes says %d, C says %s"
                             % (name, got, value))
            seen += 1
        self.assertGreaterEqual(seen, len(MIRROR))


if __name__ == "__main__":
    unittest.main()
