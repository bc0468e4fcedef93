"""Regenerate the committed xacro/URDF artefacts of every built-in robot in robots/.

Usage: python scripts/regenerate.py          (writes the files)
       python scripts/regenerate.py --check  (exit 1 if any committed file differs)
"""

from __future__ import annotations

import argparse
import sys

from dhkin.files import write_file
from dhkin.robot import builtin_dir, builtin_names, load
from dhkin.urdf import generate


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    args = parser.parse_args()
    folder = builtin_dir()
    stale = []
    for name in builtin_names():
        for file_name, text in generate(load(name).table).as_dict().items():
            path = folder / file_name
            current = path.read_text(encoding="utf-8") if path.is_file() else None
            if current == text:
                continue
            stale.append(path)
            if not args.check:
                write_file(path, text, force=True)  # atomic; regenerating replaces
    verb = "stale" if args.check else "written"
    for path in stale:
        print(f"{verb}: {path}")
    print(f"{len(stale)} file(s) {verb}")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
