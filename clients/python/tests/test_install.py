"""The package installs offline with Debian's pip and setuptools, and its `rcd` script runs."""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import unittest

from support import PACKAGE_ROOT


class InstallTest(unittest.TestCase):
    def test_pip_install_no_build_isolation_offline(self) -> None:
        if subprocess.run(
            [sys.executable, "-m", "pip", "--version"], capture_output=True
        ).returncode:
            self.skipTest("pip is not installed for this Python (Debian: python3-pip)")
        with tempfile.TemporaryDirectory() as tmp:
            src = pathlib.Path(tmp) / "src"
            shutil.copytree(
                PACKAGE_ROOT,
                src,
                ignore=shutil.ignore_patterns("tests", "__pycache__", "*.egg-info"),
            )
            target = pathlib.Path(tmp) / "site"
            run = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "pip",
                    "install",
                    "-q",
                    "--no-build-isolation",
                    "--no-index",
                    "--disable-pip-version-check",
                    "--target",
                    str(target),
                    str(src),
                ],
                capture_output=True,
                text=True,
                timeout=300,
            )
            self.assertEqual(run.returncode, 0, run.stderr)
            script = target / "bin" / "rcd"
            self.assertTrue(script.is_file())
            self.assertFalse((target / "bin" / "raycastd").exists())  # would shadow the server
            env = {**os.environ, "PYTHONPATH": str(target)}
            helped = subprocess.run(
                [sys.executable, str(script), "--help"],
                capture_output=True,
                text=True,
                env=env,
                timeout=60,
            )
            self.assertEqual(helped.returncode, 0, helped.stderr)
            self.assertTrue(helped.stdout.startswith("usage: rcd"))
            imported = subprocess.run(
                [
                    sys.executable,
                    "-c",
                    "import raycastd, raycastd.grading; print(raycastd.__file__)",
                ],
                capture_output=True,
                text=True,
                env=env,
                timeout=60,
                cwd=tmp,
            )
            self.assertTrue(
                imported.stdout.startswith(str(target)), imported.stdout + imported.stderr
            )


if __name__ == "__main__":
    unittest.main()
