"""docs/cli.md is generated from the parsers and must say what they say."""

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_cli_reference_is_current():
    done = subprocess.run([sys.executable, str(REPO / "tools" / "cli_reference.py"), "--check"],
                          capture_output=True, text=True)
    assert done.returncode == 0, (done.stdout + done.stderr
                                  + "\nrun: python tools/cli_reference.py")
