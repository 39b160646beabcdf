"""README.md stays true: its two set-up commands, CI runs the test command, and the component table is current."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_readme_opens_with_the_two_commands():
    first_block = re.search(r"```bash\n(.*?)```", README, re.S).group(1).strip().splitlines()
    assert first_block == ["pip install . && ghserver serve", 'pip install -e ".[test]" && pytest']


def test_ci_runs_the_readme_test_command():
    assert 'pip install -e ".[test]" && pytest' in (ROOT / ".ci" / "run").read_text()


def test_component_table_is_current():
    table = subprocess.run([sys.executable, "-m", "ghserver", "list", "--markdown"], cwd=ROOT, capture_output=True,
                           text=True, timeout=120, check=True).stdout.strip()
    block = re.search(r"<!-- components:begin -->\n(.*?)<!-- components:end -->", README, re.S).group(1).strip()
    assert block == table, "run `ghserver list --markdown` and paste it between the components markers in README.md"
