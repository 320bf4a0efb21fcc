"""Regenerate the figures of the documentation site: run the tutorial (as the tests do) in a
scratch folder and keep the pictures it writes in ``_static/``.

    python docs/site/figures.py
"""

import doctest
import os
import shutil
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

HERE = Path(__file__).resolve().parent
PICTURES = ("pendulum.png", "forced_two_mass.png", "fit.png", "work_precision.png",
            "double_pendulum.gif")


def main() -> int:
    static = HERE / "_static"
    static.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        result = doctest.testfile(str(HERE / "tutorial.rst"), module_relative=False,
                                  optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
        if result.failed:
            return 1
        for name in PICTURES:
            shutil.copy(name, static / name)
            print(f"wrote {static / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
