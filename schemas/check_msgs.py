#!/usr/bin/env python3
"""Check every ROS 2 ``.msg`` file under ``schemas/``.

Each file must sit at ``<root>/<package>/msg/<Type>.msg`` and parse the way ROS 2 (rosidl) parses
``.msg`` files:

* ``#`` starts a comment (everywhere on a line, as rosidl does); blank and comment-only lines
  are ignored; a field or constant line must not be indented;
* a field is ``type name`` with an optional default value after it (``float64 w 1``,
  ``float64[3] v [0, 0, 1]``); defaults are only allowed on primitive types and must fit them;
* a constant is ``type NAME=value`` (spaces around ``=`` allowed) of a primitive, non-array type;
* a type is a primitive (``bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32
  int64 uint64 string wstring``), ``string<=N`` / ``wstring<=N``, ``pkg/Type``, or a bare
  ``Type`` meaning ``Type`` in the same package; any of them may end in ``[]``, ``[N]`` or
  ``[<=N]``. A bare ``Header`` is ``std_msgs/Header`` only in ROS 1: in ROS 2 it means
  ``<this package>/Header``, so write ``std_msgs/Header``.

Every non-primitive type must resolve to a file under the root. Names follow rosidl's patterns.
Problems are printed as ``path:line: message`` and the exit status is 1; on success one summary
line is printed and the exit status is 0.

Usage: ``python3 schemas/check_msgs.py [ROOT]`` (ROOT defaults to this script's folder);
``python3 schemas/check_msgs.py --self-test`` checks that the checker rejects broken files.
Python 3.11+, standard library only.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

PRIMITIVES = frozenset(
    "bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64 string wstring".split()
)
STRINGS = frozenset({"string", "wstring"})
# ROS 1 built-ins that rosidl still accepts only "for compatibility"; ROS 2 files name the message.
ROS1_BUILTINS = {"time": "builtin_interfaces/Time", "duration": "builtin_interfaces/Duration"}

# rosidl_adapter's name patterns.
PACKAGE_NAME = re.compile(r"^(?!.*__)(?!.*_$)[a-z][a-z0-9_]*$")
FIELD_NAME = PACKAGE_NAME
MESSAGE_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
CONSTANT_NAME = re.compile(r"^[A-Z](?:[A-Z0-9_]?[A-Z0-9]+)*$")

# base, optional string bound, optional array suffix.
TYPE_RE = re.compile(
    r"^(?P<base>[A-Za-z0-9_/]+)(?:<=(?P<strbound>[^\[\]]*))?(?:\[(?P<array>[^\]]*)\])?$"
)


class MsgError(Exception):
    """A problem on one line."""


@dataclass
class TypeRef:
    """A parsed field type."""

    text: str
    package: str | None  # None for primitives
    name: str  # primitive name or message name
    string_bound: int | None = None
    array: str | None = None  # None: not an array; "": unbounded; "N"; "<=N"

    @property
    def is_primitive(self) -> bool:
        return self.package is None

    @property
    def full_name(self) -> str:
        return self.name if self.package is None else f"{self.package}/{self.name}"

    def array_limits(self) -> tuple[int | None, bool]:
        """(size, is_upper_bound); size None for an unbounded array."""
        if not self.array:
            return None, False
        if self.array.startswith("<="):
            return int(self.array[2:]), True
        return int(self.array), False


@dataclass
class Reference:
    """A non-primitive type used on a line of a file."""

    path: Path
    line: int
    type: TypeRef
    bare: bool  # written without a package


@dataclass
class MsgFile:
    path: Path
    package: str
    name: str
    references: list[Reference] = field(default_factory=list)
    fields: int = 0
    constants: int = 0


def parse_type(text: str, package: str) -> tuple[TypeRef, bool]:
    """Parse a type string; returns the type and whether it was written without a package."""
    m = TYPE_RE.match(text)
    if not m:
        raise MsgError(f"'{text}' is not a type (expected T, pkg/T, string<=N, with [], [N] or [<=N])")
    base, strbound, array = m.group("base"), m.group("strbound"), m.group("array")
    bound = None
    if strbound is not None:
        if base not in STRINGS:
            raise MsgError(f"'{text}': only string and wstring take an upper bound '<=N'")
        if not strbound.isdigit() or int(strbound) <= 0:
            raise MsgError(f"'{text}': the string bound must be an integer > 0")
        bound = int(strbound)
    if array is not None and array != "":
        n = array[2:] if array.startswith("<=") else array
        if not n.isdigit() or int(n) <= 0:
            raise MsgError(f"'{text}': the array size must be an integer > 0, optionally after '<='")
    if base in ROS1_BUILTINS:
        raise MsgError(f"'{base}' is a ROS 1 built-in type: in ROS 2 write {ROS1_BUILTINS[base]}")
    if base in PRIMITIVES:
        return TypeRef(text, None, base, bound, array), False
    parts = base.split("/")
    if len(parts) == 1:
        pkg, name, bare = package, parts[0], True
    elif len(parts) == 2:
        pkg, name, bare = parts[0], parts[1], False
        if not PACKAGE_NAME.match(pkg):
            raise MsgError(f"'{text}': '{pkg}' is not a valid package name")
    elif len(parts) == 3 and parts[1] == "msg":
        raise MsgError(f"'{text}': .msg files name types as pkg/Type, not pkg/msg/Type (write {parts[0]}/{parts[2]})")
    else:
        raise MsgError(f"'{text}' is not a type name (expected Type or pkg/Type)")
    if not MESSAGE_NAME.match(name):
        raise MsgError(f"'{text}': '{name}' is neither a primitive type nor a message name (CamelCase)")
    return TypeRef(text, pkg, name, None, array), bare


def check_integer(prim: str, value: str) -> None:
    if prim in ("byte", "char"):
        lo, hi = 0, 255
    else:
        unsigned = prim.startswith("u")
        bits = int(prim[4:] if unsigned else prim[3:])
        lo, hi = (0, 2**bits - 1) if unsigned else (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
    try:
        n = int(value)
    except ValueError:
        try:
            n = int(value, 0)
        except ValueError:
            raise MsgError(f"'{value}' is not an integer ({prim})") from None
    if not lo <= n <= hi:
        raise MsgError(f"{value} is out of range for {prim} [{lo}, {hi}]")


def check_scalar(t: TypeRef, value: str) -> None:
    """Check a value for a primitive, non-array type (rosidl's rules)."""
    prim = t.name
    if prim == "bool":
        if value.lower() not in ("true", "false", "1", "0"):
            raise MsgError(f"'{value}' is not a bool (true, false, 1 or 0)")
    elif prim in ("float32", "float64"):
        try:
            float(value)
        except ValueError:
            raise MsgError(f"'{value}' is not a floating-point number ({prim})") from None
    elif prim in STRINGS:
        s = value
        for q in ('"', "'"):
            if len(s) >= 2 and s.startswith(q) and s.endswith(q):
                inner = s[1:-1]
                if re.search(r"(?<!\\)" + q, inner):
                    raise MsgError(f"{value}: inner quotes must be escaped")
                s = inner.replace("\\" + q, q)
                break
        if t.string_bound is not None and len(s) > t.string_bound:
            raise MsgError(f"{value} is longer than {t.string_bound} characters")
    else:
        check_integer(prim, value)


def split_string_array(body: str) -> list[str]:
    """Split the inside of a string array literal, honouring quotes."""
    items, cur, quote, i = [], "", None, 0
    while i < len(body):
        c = body[i]
        if quote:
            cur += c
            if c == "\\" and i + 1 < len(body):
                cur += body[i + 1]
                i += 1
            elif c == quote:
                quote = None
        elif c in "\"'":
            quote = c
            cur += c
        elif c == ",":
            items.append(cur.strip())
            cur = ""
        else:
            cur += c
        i += 1
    if quote:
        raise MsgError("unterminated quote in string array")
    if cur.strip() or items:
        items.append(cur.strip())
    return items


def check_default(t: TypeRef, value: str) -> None:
    if not t.is_primitive:
        raise MsgError(f"a default value is only allowed on primitive types, not {t.full_name}")
    if t.array is None:
        check_scalar(t, value)
        return
    if not (value.startswith("[") and value.endswith("]")):
        raise MsgError(f"the default of an array must be written [a, b, ...], not '{value}'")
    body = value[1:-1]
    items = split_string_array(body) if t.name in STRINGS else ([s.strip() for s in body.split(",")] if body.strip() else [])
    size, upper = t.array_limits()
    if size is not None and not upper and len(items) != size:
        raise MsgError(f"{t.text} needs exactly {size} elements, not {len(items)}")
    if size is not None and upper and len(items) > size:
        raise MsgError(f"{t.text} takes at most {size} elements, not {len(items)}")
    element = TypeRef(t.text, None, t.name, t.string_bound, None)
    for item in items:
        check_scalar(element, item)


def parse_file(path: Path, root: Path, errors: list[str]) -> MsgFile | None:
    rel = path.relative_to(root)
    where = lambda line: f"{path}:{line}"  # noqa: E731
    parts = rel.parts
    if len(parts) != 3 or parts[1] != "msg":
        errors.append(f"{path}: a message file must be at <root>/<package>/msg/<Type>.msg")
        return None
    package, name = parts[0], path.stem
    if not PACKAGE_NAME.match(package):
        errors.append(f"{path}: '{package}' is not a valid ROS 2 package name")
    if not MESSAGE_NAME.match(name):
        errors.append(f"{path}: '{name}' is not a valid message name (CamelCase: ^[A-Z][A-Za-z0-9]*$)")
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        errors.append(f"{path}: not UTF-8 ({e})")
        return None
    if "\r" in text:
        errors.append(f"{path}: has CR characters; .msg files use LF line endings")
    msg = MsgFile(path, package, name)
    names: dict[str, int] = {}
    for lineno, line in enumerate(text.split("\n"), start=1):
        content = line.replace("\t", " ").split("#", 1)[0]
        if not content.strip():
            continue
        if content[0] == " ":
            errors.append(f"{where(lineno)}: a field or constant must start at the beginning of the line")
            continue
        content = content.rstrip()
        type_text, _, rest = content.partition(" ")
        rest = rest.lstrip()
        try:
            if not rest:
                raise MsgError(f"'{content}' is not a field (expected 'type name')")
            t, bare = parse_type(type_text, package)
            if "=" in rest:
                const_name, _, value = rest.partition("=")
                const_name, value = const_name.strip(), value.strip()
                if not t.is_primitive or t.array is not None:
                    raise MsgError(f"constant {const_name}: constants must have a primitive, non-array type, not {type_text}")
                if not CONSTANT_NAME.match(const_name):
                    raise MsgError(f"'{const_name}' is not a valid constant name (UPPER_CASE)")
                if not value:
                    raise MsgError(f"constant {const_name} has no value")
                check_scalar(t, value)
                declared = const_name
                msg.constants += 1
            else:
                field_name, _, default = rest.partition(" ")
                default = default.strip()
                if not FIELD_NAME.match(field_name):
                    raise MsgError(f"'{field_name}' is not a valid field name (snake_case: ^[a-z][a-z0-9_]*$, no '__', no trailing '_')")
                if default:
                    check_default(t, default)
                declared = field_name
                msg.fields += 1
                if not t.is_primitive:
                    msg.references.append(Reference(path, lineno, t, bare))
            if declared in names:
                raise MsgError(f"'{declared}' is declared twice (first on line {names[declared]})")
            names[declared] = lineno
        except MsgError as e:
            errors.append(f"{where(lineno)}: {e}")
    return msg


def check(root: Path) -> tuple[list[str], str]:
    """Check every .msg under root; returns (errors, summary)."""
    errors: list[str] = []
    files = sorted(p for p in root.rglob("*.msg") if p.is_file())
    if not files:
        return [f"{root}: no .msg files found"], ""
    parsed: dict[str, MsgFile] = {}
    for path in files:
        msg = parse_file(path, root, errors)
        if msg is not None:
            parsed[f"{msg.package}/{msg.name}"] = msg
    resolved = 0
    for msg in parsed.values():
        for ref in msg.references:
            full = ref.type.full_name
            if full in parsed:
                resolved += 1
                continue
            expected = root / ref.type.package / "msg" / f"{ref.type.name}.msg"
            hint = ""
            if ref.bare and ref.type.name == "Header" and msg.package != "std_msgs":
                hint = (f"; a bare 'Header' is std_msgs/Header only in ROS 1 — in ROS 2 it means "
                        f"{msg.package}/Header: write std_msgs/Header")
            elif ref.bare:
                hint = f"; a bare type name means the same package ({msg.package}): write pkg/{ref.type.name} for another package"
            errors.append(f"{ref.path}:{ref.line}: type '{ref.type.text}' resolves to {full}, "
                          f"but {expected} does not exist{hint}")
    # A type may not contain itself, directly or through other types.
    graph = {k: sorted({r.type.full_name for r in m.references if r.type.full_name in parsed}) for k, m in parsed.items()}
    state: dict[str, int] = {}

    def visit(node: str, trail: list[str]) -> None:
        state[node] = 1
        for dep in graph[node]:
            if state.get(dep) == 1:
                cycle = trail[trail.index(dep):] + [dep] if dep in trail else [node, dep]
                ref = next(r for r in parsed[node].references if r.type.full_name == dep)
                errors.append(f"{ref.path}:{ref.line}: recursive type: {' -> '.join(cycle)}")
            elif dep not in state:
                visit(dep, trail + [dep])
        state[node] = 2

    for node in graph:
        if node not in state:
            visit(node, [node])
    summary = (f"ok: {len(files)} .msg files in {len({m.package for m in parsed.values()})} packages, "
               f"{sum(m.fields for m in parsed.values())} fields, "
               f"{sum(m.constants for m in parsed.values())} constants, "
               f"{resolved} type references resolved under {root}")
    return errors, summary


SELF_TEST_CASES: dict[str, str] = {
    # case name: file text for pkg_a/msg/Bad.msg; each must produce at least one error
    "missing type": "pkg_b/Missing m\n",
    "bare Header": "Header header\n",
    "pkg/msg/Type": "pkg_a/msg/Good g\n",
    "no name": "int32\n",
    "bad field name": "int32 Foo\n",
    "bad constant name": "int32 foo=1\n",
    "array constant": "int32[2] X=[1, 2]\n",
    "constant of a message": "pkg_a/Good G=1\n",
    "bounded non-string": "int32<=5 x\n",
    "zero array": "int32[0] x\n",
    "bad array": "int32[x] x\n",
    "int range": "uint8 x 256\n",
    "bad bool": "bool b yes\n",
    "bad float": "float64 f 1,5\n",
    "array size": "float64[2] v [1, 2, 3]\n",
    "array bound": "float64[<=1] v [1, 2]\n",
    "default on message": "pkg_a/Good g 1\n",
    "duplicate": "int32 a\nint32 a\n",
    "indented field": "  int32 a\n",
    "ROS 1 time": "time t\n",
    "string bound": "string<=2 s \"abc\"\n",
    "recursion": "pkg_a/Bad b\n",
}


def self_test() -> int:
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "pkg_a" / "msg").mkdir(parents=True)
        good = root / "pkg_a" / "msg" / "Good.msg"
        good.write_text(
            "# comment\nint32 X=1\nuint8 Y = 2 # trailing\nstring S=\"a b\"\n"
            "string<=5[<=3] names\nfloat64[3] v [0, 0, 1]\nfloat64 w 1\nbool flag true\n"
            "string label \"hi\"\nstring[2] pair [\"a,b\", 'c']\n"
            "  # indented comment\nGood2[] others\npkg_a/Good2 other\n"
        )
        (root / "pkg_a" / "msg" / "Good2.msg").write_text("int64[<=4] xs\nwstring<=10 w\n")
        errors, _ = check(root)
        if errors:
            print("self-test: valid files were rejected:", *errors, sep="\n  ", file=sys.stderr)
            failures += 1
        bad = root / "pkg_a" / "msg" / "Bad.msg"
        for case, text in SELF_TEST_CASES.items():
            bad.write_text(text)
            errors, _ = check(root)
            if not any("Bad.msg:" in e for e in errors):
                print(f"self-test: '{case}' was not rejected", file=sys.stderr)
                failures += 1
        bad.unlink()
        (root / "pkg_a" / "msg" / "Crlf.msg").write_bytes(b"int32 a\r\n")
        if not check(root)[0]:
            print("self-test: CRLF was not rejected", file=sys.stderr)
            failures += 1
    if failures:
        print(f"self-test: {failures} failure(s)", file=sys.stderr)
        return 1
    print(f"self-test: ok ({len(SELF_TEST_CASES) + 2} cases)")
    return 0


def main(argv: list[str]) -> int:
    if argv[1:] == ["--self-test"]:
        return self_test()
    if len(argv) > 2 or (len(argv) == 2 and argv[1].startswith("-")):
        print(__doc__, file=sys.stderr)
        return 2
    # Relative to the working directory, so messages name files the way a user would.
    root = Path(argv[1]) if len(argv) == 2 else Path(os.path.relpath(Path(__file__).resolve().parent))
    if not root.is_dir():
        print(f"{root}: not a directory", file=sys.stderr)
        return 2
    errors, summary = check(root)
    if errors:
        for e in errors:
            print(e, file=sys.stderr)
        print(f"check_msgs: {len(errors)} problem(s)", file=sys.stderr)
        return 1
    print(summary)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
