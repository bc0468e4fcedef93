"""Text that reaches the generated xacro and URDF: which names may be written as they are, which
free text XML can hold, and how free text is written into comments.

**Names** (robot, joints, links, the ``prefix`` of :func:`dhkin.urdf.generate`) are written into
XML attributes that xacro evaluates, and the robot name also becomes the xacro macro's name (an
element name, ``<xacro:NAME .../>``) and part of file names. A robot name is therefore restricted
to ``[A-Za-z_][A-Za-z0-9_-]*`` (ASCII letters, digits, '_' and '-', starting with a letter or '_'):
a valid XML name, a valid ROS frame name apart from the '-', nothing xacro reads as an expression
(``${...}``, ``$(...)``), nothing that needs escaping and nothing a shell or a file system
misreads; nor may it be one of xacro's own directives (:data:`XACRO_DIRECTIVES`:
``<xacro:include .../>`` would not call a macro named "include"). A joint or link name (only ever
an attribute value) may in addition join such names with single '/' characters, as ROS
namespaces do (``wx250s/gripper_link``; not first, not last, not doubled), and is written as it
is in both directions: import keeps it, export writes it. Anything else is rejected, never
altered.

**Free text** (a table's description and source, the table's file name) is kept exactly, in
XML comments, which neither XML nor xacro interprets, so ``<``, ``&``, ``]]>``, quotes,
``${...}`` and non-ASCII text stay as written. XML forbids only a few things in a comment, and
:func:`comment_body` escapes them with a backslash that "takes the next character literally":

* ``\\`` is written ``\\\\``;
* a '-' that follows a '-' is written ``\\-`` (a comment may not contain ``--``), so
  ``10 degrees -- no closed form`` reads ``10 degrees -\\- no closed form``;
* the ':' of ``xacro:`` is written ``xacro\\:`` (a comment containing ``xacro:eval-comments``
  would make xacro drop it and evaluate the comments that follow).

:func:`comment_text` undoes this exactly. Characters that XML 1.0 cannot hold at all (control
characters other than tab and line feed, lone surrogates, U+FFFE, U+FFFF) and the carriage return
(which an XML parser turns into a line feed) cannot be kept: :func:`text_problem` names them, and
the table loader rejects such text.
"""

from __future__ import annotations

import re

from dhkin.errors import InputError

#: A robot name: ASCII letters, digits, '_' and '-', starting with a letter or '_' (module doc).
NAME_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*")
#: A joint or link name: robot-name parts joined by single '/' (ROS namespaces; module doc).
FRAME_NAME_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*(?:/[A-Za-z_][A-Za-z0-9_\-]*)*")

#: The robot name rule in words, for error messages.
ROBOT_NAME_RULE = ("a name of letters, digits, '_' or '-' starting with a letter or '_' "
                   "(ASCII only)")
#: The joint and link name rule in words, for error messages.
NAME_RULE = ("a name of letters, digits, '_' or '-' starting with a letter or '_' (ASCII only), "
             "or such names joined by '/'")

#: xacro's directives (``<xacro:NAME>``): a robot name, which becomes the macro's name, may not
#: be one of them.
XACRO_DIRECTIVES: tuple[str, ...] = ("arg", "attribute", "call", "element", "if", "include",
                                     "insert_block", "macro", "property", "unless")

#: Characters XML 1.0 cannot hold, and the carriage return (a parser turns it into a line feed).
_NOT_KEPT = re.compile("[\x00-\x08\x0b-\x1f\ud800-\udfff\ufffe\uffff]")

_ESCAPED = re.compile(r"\\|(?<=-)-|(?<=xacro):")


def name_problem(value: object, *, macro: bool = False) -> str | None:
    """What is wrong with ``value`` as a joint or link name (``"expected ..., got ..."``), or
    None if it is one.

    ``macro=True``: as a robot name (no '/', and not one of xacro's directives: the robot name
    becomes the macro's name).
    """
    pattern, rule = (NAME_PATTERN, ROBOT_NAME_RULE) if macro else (FRAME_NAME_PATTERN, NAME_RULE)
    if not isinstance(value, str) or pattern.fullmatch(value) is None:
        return f"expected {rule}, got {value!r}"
    if macro and value in XACRO_DIRECTIVES:
        return (f"expected a name other than xacro's directives {list(XACRO_DIRECTIVES)} "
                f"(it names the xacro macro), got {value!r}")
    return None


def prefix_problem(value: object) -> str | None:
    """What is wrong with ``value`` as the ``prefix`` of every joint and link name, or None: the
    empty string, or text that makes a name of any name it is put before (``left_``, ``arm1/``).
    """
    if value == "":
        return None
    if not isinstance(value, str) or FRAME_NAME_PATTERN.fullmatch(value + "x") is None:
        return f"expected '' or text that makes names of names ({NAME_RULE}), got {value!r}"
    return None


def text_problem(value: object) -> str | None:
    """What is wrong with ``value`` as free text (``"expected ..., got ..."``), or None if XML can
    hold it exactly: a string without control characters other than tab and line feed."""
    if not isinstance(value, str):
        return f"expected text, got {value!r}"
    found = _NOT_KEPT.search(value)
    if found is not None:
        return (f"expected text without control characters other than tab and line feed "
                f"(XML cannot hold them exactly), got {found.group()!r} at character "
                f"{found.start()} of {value!r}")
    return None


def comment_body(text: str) -> str:
    """``text`` escaped for the inside of an XML comment (see the module doc); ``text`` must pass
    :func:`text_problem`. Write it as ``<!-- LABEL: BODY -->``: spaces around it keep a final
    '-' from touching the closing ``-->``."""
    problem = text_problem(text)
    if problem is not None:
        raise InputError(f"text: {problem}", field="text", value=text,
                         expected="text XML can hold exactly")
    return _ESCAPED.sub(lambda match: "\\" + match.group(), text)


def comment_text(body: str) -> str:
    """The text that :func:`comment_body` escaped into ``body`` (a backslash takes the next
    character literally)."""
    if re.search(r"(?<!\\)(?:\\\\)*\\$", body):
        raise InputError(f"body: expected an escaped comment body, got a final lone backslash "
                         f"in {body!r}", field="body", value=body,
                         expected="an escaped comment body")
    return re.sub(r"\\(.)", r"\1", body, flags=re.DOTALL)
