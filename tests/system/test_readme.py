"""The README's Python example runs as written, on the files its own command makes."""

import re
import subprocess
import sys
import warnings

from tests._paths import README


def test_the_readme_python_example_runs_as_written(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)
    assert blocks, "README.md has no Python example"
    subprocess.run([sys.executable, "-m", "encal", "simulate", "--encoders", "1", "--out", str(tmp_path)],
                   check=True, capture_output=True)
    monkeypatch.chdir(tmp_path)
    import matplotlib.pyplot as plt

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the example must run without a warning, e.g. training cut short
        for block in blocks:
            exec(compile(block, str(README), "exec"), {"__name__": "readme"})
    assert (tmp_path / "enc1.json").is_file()
    figure = tmp_path / "enc1_before_after.png"
    plt.figure().savefig(tmp_path / "blank.png")
    assert figure.stat().st_size > 2 * (tmp_path / "blank.png").stat().st_size  # the plot, not an empty canvas
