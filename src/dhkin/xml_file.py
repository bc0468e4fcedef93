"""The text of an XML file (URDF, xacro, package.xml) as its bytes say it is written.

XML 1.0 (appendix F) lets a file name its own encoding: a byte-order mark (BOM) first, else the
``encoding`` of its declaration ``<?xml version="1.0" encoding="..."?>``, else UTF-8.
:func:`decode_xml` follows that order:

1. a BOM: UTF-8 (EF BB BF), UTF-32 (00 00 FE FF, FF FE 00 00) or UTF-16 (FE FF, FF FE);
2. UTF-16 without a BOM, recognised by its first character '<' (3C 00 or 00 3C);
3. the declaration's ``encoding`` (any codec Python knows: ISO-8859-1, windows-1252, ...);
4. UTF-8.

The text returned has no BOM, and its declaration (if any) no ``encoding``: it is a Python
string now, and every reader downstream (expat, xacro, urdfdom through Pinocchio) gets it as
UTF-8. Only the first line changes, so line numbers stay those of the file. A name the
declaration gives that Python does not know, a 16- or 32-bit encoding declared for a file whose
bytes are 8-bit text, and bytes that are not text in the encoding found are one-line
:class:`URDFError`s naming the file.
"""

from __future__ import annotations

import codecs
import re
from pathlib import Path

from dhkin.errors import URDFError

#: Byte-order marks, longest first (UTF-32 LE starts like UTF-16 LE).
BOMS: tuple[tuple[bytes, str], ...] = (
    (codecs.BOM_UTF32_BE, "utf-32-be"), (codecs.BOM_UTF32_LE, "utf-32-le"),
    (codecs.BOM_UTF8, "utf-8"), (codecs.BOM_UTF16_BE, "utf-16-be"),
    (codecs.BOM_UTF16_LE, "utf-16-le"))

_DECLARATION = re.compile(r"<\?xml\s[^>]*?\?>")
_ENCODING = re.compile(r"""\sencoding\s*=\s*(["'])([A-Za-z][A-Za-z0-9._\-]*)\1""")
_WIDE = ("utf-16", "utf-32")


def read_xml_file(path: str | Path, what: str = "URDF") -> str:
    """The decoded text of the XML file ``path`` (see the module docstring); ``what`` names the
    kind of file in the errors ("URDF", "xacro", ...)."""
    file = Path(path)
    try:
        data = file.read_bytes()
    except OSError as exc:
        reason = (f"no such {what} file" if isinstance(exc, FileNotFoundError)
                  else exc.strerror or str(exc))
        raise URDFError(f"{file}: cannot read {what} ({reason})", field="file", value=str(file),
                        expected=f"a readable {what} file") from exc
    return decode_xml(data, str(file))


def decode_xml(data: bytes, source: str) -> str:
    """The text of XML bytes, decoded as their BOM or declaration says (module docstring)."""
    encoding, start = _encoding_of(data, source)
    try:
        text = data[start:].decode(encoding)
    except UnicodeDecodeError as exc:
        offset = start + exc.start
        byte = data[offset:offset + 1]
        raise URDFError(f"{source}: not {encoding.upper()} text (byte {byte!r} at "
                        f"offset {offset}); expected XML text in the encoding its declaration "
                        "names (UTF-8 without one)", field="encoding", value=encoding,
                        expected=f"{encoding} text") from None
    return _without_encoding(text)


def _encoding_of(data: bytes, source: str) -> tuple[str, int]:
    """(codec name, bytes to skip) of XML bytes."""
    for bom, name in BOMS:
        if data.startswith(bom):
            return name, len(bom)
    if data.startswith(b"<\x00") and not data.startswith(b"<\x00\x00"):
        return "utf-16-le", 0
    if data.startswith(b"\x00<") and not data.startswith(b"\x00<\x00\x00"):
        return "utf-16-be", 0
    head = data[:200].decode("latin-1")
    declaration = _DECLARATION.match(head)
    found = _ENCODING.search(declaration.group()) if declaration else None
    if found is None:
        return "utf-8", 0
    name = found.group(2)
    try:
        codec = codecs.lookup(name).name
    except LookupError:
        raise URDFError(f"{source}: the XML declaration names encoding {name!r}, which Python "
                        "does not know; expected an encoding such as UTF-8 or ISO-8859-1",
                        field="encoding", value=name, expected="a known encoding") from None
    if codec.startswith(_WIDE):
        raise URDFError(f"{source}: the XML declaration names encoding {name!r}, but the file "
                        "is written in 8-bit text (no byte-order mark, one byte per character); "
                        "expected the declaration to name the file's encoding (e.g. UTF-8)",
                        field="encoding", value=name, expected="the file's own encoding")
    return codec, 0


def _without_encoding(text: str) -> str:
    """``text`` without a leading BOM character and without the declaration's ``encoding``."""
    text = text.removeprefix("\ufeff")
    declaration = _DECLARATION.match(text)
    if declaration is None:
        return text
    plain = _ENCODING.sub("", declaration.group())
    return plain + text[declaration.end():]
