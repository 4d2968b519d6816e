"""Draw the README's picture: run README.md's first ```python block (the trailer) in a temporary directory and
save its modes' figure as docs/_static/readme-modes.png.

    .venv/bin/python docs/readme_figure.py
"""

import os
import re
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "_static" / "readme-modes.png"


def main():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    source = re.search(r"^```python[^\n]*\n(.*?)^```", text, re.S | re.M).group(1)
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as d:
        os.chdir(d)
        try:
            namespace = {"__name__": "__readme__"}
            exec(compile(source, "README.md", "exec"), namespace)
        finally:
            os.chdir(here)
    namespace["modes"].plot(OUT, dpi=80)
    print(f"wrote {OUT.relative_to(ROOT)} ({OUT.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
