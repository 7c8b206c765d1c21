import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_configuration_reference_is_generated_from_the_code():
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "make_config_docs.py"), "--check"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr


def test_results_page_and_readme_table_are_generated_from_the_benchmark_jsons(tmp_path):
    """docs/results.md and README's table are what docs/results/*.json say; a number typed by hand fails."""
    script = ROOT / "scripts" / "make_results_page.py"
    run = subprocess.run([sys.executable, str(script), "--check"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert (ROOT / "docs" / "results" / "accuracy_public.json").is_file()
    # the check can fail: the same script on a copy of the docs with one number changed by hand
    import shutil

    copy = tmp_path / "repo"
    shutil.copytree(ROOT / "docs" / "results", copy / "docs" / "results")
    (copy / "scripts").mkdir()
    shutil.copy(script, copy / "scripts" / "make_results_page.py")
    page = (ROOT / "docs" / "results.md").read_text()
    (copy / "docs" / "results.md").write_text(page.replace("| combined |", "| combined | 99.9 |", 1))
    (copy / "README.md").write_text((ROOT / "README.md").read_text())
    run = subprocess.run([sys.executable, str(copy / "scripts" / "make_results_page.py"), "--check"],
                         capture_output=True, text=True)
    assert run.returncode == 1 and "results.md is stale" in run.stderr
