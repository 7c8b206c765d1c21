import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_configuration_reference_is_generated_from_the_code():
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "make_config_docs.py"), "--check"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
