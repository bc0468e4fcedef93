"""The project stands on its own: the vendor references, seeds and data it needs are inside it.

The vendor URDFs ship in ``robots/vendor`` (in the repository and in the installed package), each
with its provenance (first comment: repository @ commit) and its licence listed; no file of the
package, the tests, the scripts or the robots names the folder outside the repository they were
copied from (the workspace's ``shared`` folder beside the repository).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import dhkin
from dhkin.builtin import builtin_dir
from dhkin.vendors import VENDOR_REFERENCES, vendor_dir, vendor_file

from .conftest import REFERENCE_URDFS, REPO

#: A path out of the repository into the workspace's shared folder: ``../shared`` (either
#: slash), or ``... .parent / "shared"`` built with pathlib.
OUTSIDE = re.compile(r"""\.\.[/\\]shared\b|\.parents?(?:\[\d+\])?\s*/\s*["']shared["']""")

#: What must stand on its own: the package, the tests (their data included), the scripts, the
#: built-in robots and their vendor references.
SELF_CONTAINED = ("src", "tests", "scripts", "robots")

#: provenance of a vendor file: "github.com/OWNER/REPO @ <40 hex digits>" in its first comment.
PROVENANCE = re.compile(r"github\.com/[\w.-]+/[\w.-]+ @ [0-9a-f]{40}")


def _text_files(folder: Path) -> list[Path]:
    return [p for p in sorted(folder.rglob("*")) if p.is_file() and "__pycache__" not in p.parts
            and p.suffix not in (".png", ".pyc", ".so")]


def test_the_pattern_finds_what_it_must() -> None:
    """The pattern matches the forms a path out of the repository takes, and not lookalikes."""
    for text in ('Path("../shared/reference")', "see ..\\shared\\seeds", 'REPO.parent / "shared"',
                 "Path(__file__).parents[3] / 'shared' / 'reference'"):
        assert OUTSIDE.search(text), text
    for text in ("shared among the CPUs", "robots/vendor/ur5.urdf", "a shared helper"):
        assert not OUTSIDE.search(text), text


@pytest.mark.parametrize("folder", SELF_CONTAINED)
def test_no_file_names_the_folder_outside_the_repository(folder: str) -> None:
    named = []
    for path in _text_files(REPO / folder):
        if path == Path(__file__).resolve():
            continue  # this file holds the examples the pattern must find (test above)
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        named += [f"{path.relative_to(REPO)}:{text.count(chr(10), 0, m.start()) + 1}: "
                  f"{m.group(0)}" for m in OUTSIDE.finditer(text)]
    assert not named, "files that need a folder outside the repository:\n" + "\n".join(named)


def test_every_vendor_reference_ships_with_its_provenance() -> None:
    """Each vendor URDF of a built-in robot is in robots/vendor; its first comment names its
    upstream repository and commit."""
    for name, listed in VENDOR_REFERENCES.items():
        path = REFERENCE_URDFS / listed.file
        assert path.is_file(), f"{name}: {path} is missing"
    for path in sorted(REFERENCE_URDFS.glob("*.urdf")):
        text = path.read_text(encoding="utf-8")
        first_comment = text[text.index("<!--"):text.index("-->")]
        assert text.lstrip().startswith(("<?xml", "<!--")) and "<robot" not in first_comment
        assert text.index("<!--") < text.index("<robot"), f"{path.name}: no comment first"
        assert PROVENANCE.search(first_comment), f"{path.name}: no repository @ commit"


def test_every_vendor_file_has_its_licence_listed() -> None:
    """robots/vendor/README.md lists every vendor URDF with a licence whose text ships in
    robots/vendor/LICENSES."""
    readme = (REFERENCE_URDFS / "README.md").read_text(encoding="utf-8")
    licences = readme.split("## Licences", 1)[1]
    rows = [line for line in licences.splitlines() if line.startswith("| `")]
    listed: dict[str, str] = {}
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        for file in re.findall(r"`([\w.-]+\.urdf)`", cells[0]):
            listed[file] = cells[1]
    assert sorted(listed) == sorted(p.name for p in REFERENCE_URDFS.glob("*.urdf"))
    texts = {p.stem for p in (REFERENCE_URDFS / "LICENSES").glob("*.txt")}
    assert texts == {"Apache-2.0", "BSD-3-Clause"}
    for file, licence in listed.items():
        assert licence.split()[0] in ("Apache-2.0", "BSD-3-Clause", "BSD"), (file, licence)


def test_the_package_finds_the_vendor_references_from_its_own_folder() -> None:
    """dhkin.vendors.vendor_dir() is robots/vendor beside the built-in tables, in the installed
    package as in the repository, and holds the repository's files byte for byte."""
    assert vendor_dir() == builtin_dir() / "vendor"
    for name, listed in VENDOR_REFERENCES.items():
        shipped = vendor_file(name)
        assert shipped is not None and shipped.is_file(), f"{name}: not shipped"
        assert shipped.read_bytes() == (REFERENCE_URDFS / listed.file).read_bytes(), name
    assert vendor_file("planar_2r") is None


def test_the_seed_document_the_tests_read_is_in_the_repository() -> None:
    from .conftest import SEED_DOCUMENTS

    assert [p.name for p in SEED_DOCUMENTS.glob("000_*.txt")] == ["000_19689723ac6296f2.txt"]
    assert "000_19689723ac6296f2.txt" in (SEED_DOCUMENTS / "README.md").read_text("utf-8")


def test_builtin_tables_cite_the_shipped_vendor_files() -> None:
    """A table whose numbers come from a vendor file cites it where it ships."""
    for name, listed in VENDOR_REFERENCES.items():
        assert f"robots/vendor/{listed.file}" in dhkin.load(name).table.source, name
