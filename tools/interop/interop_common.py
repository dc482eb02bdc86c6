"""Shared by check_mcap_ros2.py and check_rosbags.py: targets, expected files, .msg field types,
and the field-by-field comparison. Each checker only reads and decodes with its own library."""

import json
import math
import re
import struct
import sys
import traceback
from pathlib import Path

PRIMITIVES = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
              "int64", "uint64", "float32", "float64", "string", "wstring"}
SEPARATOR = re.compile(r"^={80}[ \t\r]*$", re.M)


class Mismatch(Exception):
    """A difference between the file and its .expected.json (the message says where)."""


# ---- targets -------------------------------------------------------------------------------

def expected_path(target: Path) -> Path:
    """X.mcap -> X.expected.json; rosbag2 directory D -> D.expected.json beside D."""
    stem = target.name if target.is_dir() else target.name.removesuffix(".mcap")
    return target.parent / f"{stem}.expected.json"


def bag_files(bag: Path) -> list[Path]:
    """The MCAP files of a rosbag2 directory, in metadata.yaml order."""
    from ruamel.yaml import YAML  # pinned with rosbags; only needed for directories
    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    if info.get("storage_identifier") != "mcap":
        raise Mismatch(f"metadata.yaml storage_identifier is {info.get('storage_identifier')!r}, not 'mcap'")
    files = [bag / name for name in info["relative_file_paths"]]
    if not files:
        raise Mismatch("metadata.yaml lists no relative_file_paths")
    for f in files:
        if f.suffix != ".mcap" or not f.is_file():
            raise Mismatch(f"metadata.yaml lists {f.name}, which is not an existing .mcap file")
    return files


def load_expected(target: Path) -> dict:
    path = expected_path(target)
    if not path.is_file():
        raise Mismatch(f"no {path.name} beside it")

    def no_constants(name):
        raise Mismatch(f"{path.name}: {name} is not JSON (write NaN as null)")
    data = json.loads(path.read_text(), parse_constant=no_constants)
    if not isinstance(data.get("messages"), list):
        raise Mismatch(f'{path.name}: no "messages" list')
    return data


# ---- .msg definitions ------------------------------------------------------------------------

def norm_type(name: str, package: str | None = None) -> str:
    """'pkg/msg/Type' and 'pkg/Type' -> 'pkg/Type'; 'Type' inside package pkg -> 'pkg/Type'."""
    parts = name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return f"{parts[0]}/{parts[2]}"
    if len(parts) == 2:
        return name
    if len(parts) == 1 and package:
        return f"{package}/{name}"
    raise ValueError(f"cannot resolve message type name {name!r}")


def parse_msgdef(schema_name: str, text: str) -> dict:
    """Field lists of a ros2msg schema (root + 'MSG: pkg/Type' blocks):
    {'pkg/Type': [(field, base_type, is_array)]}, base_type a primitive or 'pkg/Type'."""
    defs = {}
    for i, block in enumerate(SEPARATOR.split(text)):
        lines = block.splitlines()
        if i == 0:
            name = schema_name
        else:
            while lines and not lines[0].strip():
                lines.pop(0)
            if not lines or not lines[0].startswith("MSG:"):
                raise ValueError(f"schema {schema_name}: dependency block {i} has no 'MSG:' line")
            name = lines.pop(0)[4:].strip()
        name = norm_type(name)
        package = name.split("/")[0]
        fields = []
        for line in lines:
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            m = re.match(r"(\S+)\s+(\w+)\s*(=)?", line)
            if not m:
                raise ValueError(f"schema {schema_name}: cannot parse {line!r} in {name}")
            typ, field, constant = m.groups()
            if constant:
                continue
            base = re.sub(r"<=\d+$", "", typ.split("[")[0])
            if base not in PRIMITIVES:
                base = norm_type(base, package)
            fields.append((field, base, typ.endswith("]")))
        defs[name] = fields
    return defs


# ---- decoded objects -> plain values -------------------------------------------------------------

def to_plain(v):
    """Any reader's decoded message -> dict/list/int/float/str/bool, generically."""
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, (bytes, bytearray, memoryview)):
        return list(bytes(v))
    if hasattr(v, "tolist"):  # numpy arrays and scalars, array.array
        return to_plain(v.tolist())
    if isinstance(v, (list, tuple)):
        return [to_plain(x) for x in v]
    if isinstance(v, dict):
        return {k: to_plain(x) for k, x in v.items()}
    if hasattr(v, "__dataclass_fields__"):  # rosbags
        return {k: to_plain(getattr(v, k)) for k in v.__dataclass_fields__}
    slots = [s for cls in type(v).__mro__ for s in getattr(cls, "__slots__", ())]
    if slots:  # mcap_ros2
        return {k: to_plain(getattr(v, k)) for k in slots}
    if hasattr(v, "__dict__"):
        return {k: to_plain(x) for k, x in vars(v).items() if not k.startswith("_")}
    raise TypeError(f"cannot convert {type(v).__name__} to a plain value")


# ---- comparison ---------------------------------------------------------------------------

def show(v) -> str:
    if isinstance(v, float) and math.isnan(v):
        return "NaN"
    text = json.dumps(v) if not isinstance(v, float) else repr(v)
    return text if len(text) <= 80 else text[:77] + "..."


def float32(x: float) -> float:
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


def floats_equal(e, g, is_float32: bool) -> bool:
    if type(g) not in (int, float):
        return False
    if e is None:  # NaN is written as null
        return math.isnan(g)
    if type(e) not in (int, float) or math.isnan(g):
        return False
    e = float32(e) if is_float32 else float(e)
    if math.isinf(e) or math.isinf(g):
        return e == g
    return abs(e - g) <= max(1e-9, 1e-6 * abs(e))


def compare_value(e, g, base: str, defs: dict, path: str) -> None:
    if base not in PRIMITIVES:
        return compare_message(e, g, base, defs, path)
    if base in ("float32", "float64"):
        ok = floats_equal(e, g, base == "float32")
    elif base == "bool":
        ok = type(e) is bool and type(g) is bool and e == g
    elif base in ("string", "wstring"):
        ok = isinstance(e, str) and e == g
    else:
        ok = type(e) is int and type(g) is int and e == g
    if not ok:
        raise Mismatch(f"{path}: expected {show(e)}, got {show(g)}")


def compare_message(e, g, typ: str, defs: dict, path: str) -> None:
    if typ not in defs:
        raise Mismatch(f"{path}: the schema does not define {typ}")
    if not isinstance(e, dict):
        raise Mismatch(f"{path}: expected JSON is {show(e)}, not an object for {typ}")
    if not isinstance(g, dict):
        raise Mismatch(f"{path}: the reader gave {show(g)}, not a {typ} object")
    extra = sorted(set(e) - {f for f, _, _ in defs[typ]})
    if extra:
        raise Mismatch(f"{path}: expected JSON has keys that {typ} does not have: {show(extra)}")
    for field, base, is_array in defs[typ]:
        p = f"{path}.{field}"
        if field not in e:
            raise Mismatch(f"{p}: missing from the expected JSON")
        if field not in g:
            raise Mismatch(f"{p}: missing from the decoded message")
        if not is_array:
            compare_value(e[field], g[field], base, defs, p)
            continue
        if not isinstance(e[field], list) or not isinstance(g[field], list):
            raise Mismatch(f"{p}: expected {show(e[field])}, got {show(g[field])} (both must be lists)")
        if len(e[field]) != len(g[field]):
            raise Mismatch(f"{p}: expected {len(e[field])} elements, got {len(g[field])}")
        for k, (ek, gk) in enumerate(zip(e[field], g[field])):
            compare_value(ek, gk, base, defs, f"{p}[{k}]")


def compare(expected: dict, got: list[dict], metadata, log_time_order: bool) -> None:
    """got: [{topic, schema, log_time, publish_time (None: not exposed), message, defs}].
    metadata: [(name, {k: v})] in file order, or None when the reader does not expose it."""
    want = expected["messages"]
    if log_time_order:  # the reader merges by log time; ties keep file order
        want = sorted(want, key=lambda m: m.get("log_time", 0))
    if len(got) != len(want):
        raise Mismatch(f"expected {len(want)} messages, the reader gave {len(got)}")
    if not got:
        raise Mismatch("no messages: a check that checks nothing fails")
    per_topic: dict[str, int] = {}
    for n, (w, g) in enumerate(zip(want, got)):
        k = per_topic[g["topic"]] = per_topic.get(g["topic"], -1) + 1
        where = f"{g['topic']}[{k}] (message {n} of {len(got)})"
        for key in ("topic", "schema", "log_time", "publish_time"):
            if g[key] is not None and w.get(key) != g[key]:
                raise Mismatch(f"{where}: {key}: expected {show(w.get(key))}, got {show(g[key])}")
        try:
            compare_message(w.get("message"), g["message"], norm_type(g["schema"]), g["defs"],
                            f"{g['topic']}[{k}]")
        except Mismatch as err:
            raise Mismatch(f"{err} (message {n} of {len(got)})") from None
    if metadata is not None:
        want_meta = [(m["name"], m["metadata"]) for m in expected.get("metadata", [])]
        listed = {name for name, _ in want_meta}
        # rosbag2 writers add a 'rosbag2' record (metadata.yaml text): checked only if listed.
        got_meta = [(name, data) for name, data in metadata if name != "rosbag2" or name in listed]
        if got_meta != want_meta:
            raise Mismatch(f"metadata records: expected {show(want_meta)}, got {show(got_meta)}")


# ---- driver ---------------------------------------------------------------------------------

def run(reader_name: str, read, log_time_order: bool) -> None:
    """For each command-line target: read(target) -> (messages, metadata); compare; print a line."""
    targets = [Path(a) for a in sys.argv[1:]]
    if not targets:
        sys.exit(f"usage: {sys.argv[0]} FILE.mcap|ROSBAG2_DIR ...")
    failed = 0
    for target in targets:
        try:
            expected = load_expected(target)
            messages, metadata = read(target)
            compare(expected, messages, metadata, log_time_order)
            print(f"ok {reader_name} {target}: {len(messages)} messages", flush=True)
        except Mismatch as err:
            failed += 1
            print(f"FAIL {reader_name} {target}: {err}", flush=True)
        except Exception as err:  # a reader that cannot read the file is a failure, not a crash
            failed += 1
            print(f"FAIL {reader_name} {target}: {type(err).__name__}: {err}", flush=True)
            traceback.print_exc(limit=-3, file=sys.stderr)
    sys.exit(1 if failed else 0)
