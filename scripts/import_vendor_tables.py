"""Import the vendor URDFs of robots/vendor that have no hand-written table as built-in
robots (robots/<name>.yaml), with ``dhkin.import_description``.

Each table cites its vendor file and that file's upstream source (the file's first comment).
Then run scripts/regenerate.py for the xacro/URDF files; `dhkin check --all` checks each table
against its vendor URDF (dhkin.vendors.VENDOR_REFERENCES).

Usage: python scripts/import_vendor_tables.py          (writes the tables, prints the summaries)
       python scripts/import_vendor_tables.py --check  (exit 1 if a committed table differs from
                                                       a fresh import)
       --reference-dir DIR                            (default robots/vendor)
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import replace
from pathlib import Path

from dhkin.files import write_file
from dhkin.importer import ImportResult, import_description
from dhkin.robot import builtin_dir
from dhkin.table_file import table_to_yaml
from dhkin.vendors import IMPORTED, VENDOR_REFERENCES

REPO = Path(__file__).resolve().parents[1]
DEFAULT_REFERENCE_DIR = REPO / "robots" / "vendor"
_UPSTREAM = re.compile(r"<!--\s*source:\s*(.*?)\s*-->", re.DOTALL)


def imported(name: str, reference_dir: Path) -> tuple[ImportResult, str]:
    """The import of one built-in robot and its table file's text."""
    vendor = VENDOR_REFERENCES[name]
    path = reference_dir / vendor.file
    result = import_description(path, base=vendor.base, tip=vendor.tip, name=name)
    upstream = _UPSTREAM.search(path.read_text(encoding="utf-8"))
    cited = f"robots/vendor/{vendor.file}"
    source = result.table.source.replace(str(path), cited)
    if upstream is not None:
        source += f" Upstream (the file's first comment): {' '.join(upstream.group(1).split())}"
    table = replace(result.table, description=IMPORTED[name], source=source)
    result = replace(result, table=table)
    header = (f"Written by scripts/import_vendor_tables.py (dhkin import of {cited}).\n"
              + result.summary())
    return result, table_to_yaml(table, result.units, header=header)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    parser.add_argument("--reference-dir", type=Path, default=DEFAULT_REFERENCE_DIR)
    args = parser.parse_args(argv)
    stale = []
    for name in IMPORTED:
        result, text = imported(name, args.reference_dir)
        target = builtin_dir() / f"{name}.yaml"
        if args.check:
            if not target.is_file() or target.read_text(encoding="utf-8") != text:
                stale.append(name)
            continue
        write_file(target, text, force=True)  # atomic; regenerating replaces
        print(f"{target.relative_to(REPO)}\n  " + result.summary().replace("\n", "\n  "))
    if args.check:
        print(f"{len(stale)} imported table(s) stale" + (f": {stale}" if stale else ""))
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
