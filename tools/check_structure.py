#!/usr/bin/env python3
"""The house plan's rules, checked on src/ (ARCHITECTURE.md says why each holds).

  1. No import cycle between the crate's top-level modules (test code aside).
  2. `trim` and `export` (and their commands) import no renderer module (`crate::render`).
  3. No function over 120 lines outside tests.
  4. `src/cmd/` (the thin command layer): no command's file over 300 lines (the whole layer grows
     with the number of commands; each stays thin).
  5. Every error variant that wraps another error keeps it as its `source` (`#[source]`,
     `#[from]`, a field named `source`, or `#[error(transparent)]`), and no library function
     returns `Result<_, String>` (the clap value parsers in `src/cmd/` aside).

Reads the sources as rustfmt leaves them (one item per line, closing braces at the item's
indentation). Prints each breach with file:line and exits 1 if there is any; `--list` also prints
the longest functions and the module graph.

    python3 tools/check_structure.py [--list] [SRC_DIR]
"""

import re
import sys
from pathlib import Path

MAX_FN_LINES = 120
MAX_CMD_FILE_LINES = 300
RENDER_FREE = ("trim", "export", "cmd/trim.rs", "cmd/export.rs")

FN_RE = re.compile(r"^(\s*)(pub(\([a-z]+\))? )?(const )?(async )?(unsafe )?fn ([a-z_0-9]+)")
CRATE_RE = re.compile(r"\bcrate::([a-z_0-9]+)")
ERROR_TYPE_RE = re.compile(r"(\bError\b|[A-Za-z]+Error\b|\bReadIssue\b)")


def is_test_file(path: Path) -> bool:
    return path.name in ("tests.rs",) or path.name.endswith("_tests.rs")


def strip_tests(lines):
    """The lines with `#[cfg(test)]` items blanked (so line numbers stay)."""
    out = list(lines)
    i = 0
    while i < len(out):
        if out[i].strip() == "#[cfg(test)]":
            indent = len(out[i]) - len(out[i].lstrip())
            j = i + 1
            while j < len(out) and out[j].strip().startswith("#["):
                j += 1
            if j < len(out) and out[j].rstrip().endswith(";"):
                end = j
            else:
                end = j + 1
                closing = " " * indent + "}"
                while end < len(out) and out[end].rstrip() != closing:
                    end += 1
            for k in range(i, min(end + 1, len(out))):
                out[k] = ""
            i = end + 1
            continue
        i += 1
    return out


def top_module(src: Path, path: Path) -> str:
    rel = path.relative_to(src)
    first = rel.parts[0]
    return first[:-3] if first.endswith(".rs") else first


def functions(lines):
    """(name, first line, line count) of every function, nested ones included."""
    for i, line in enumerate(lines):
        m = FN_RE.match(line)
        if not m:
            continue
        indent = m.group(1)
        j = i
        # A declaration without a body (trait method) ends with `;` before any `{`.
        while j < len(lines) and "{" not in lines[j] and not lines[j].rstrip().endswith(";"):
            j += 1
        if j >= len(lines) or lines[j].rstrip().endswith(";") and "{" not in lines[j]:
            continue
        if lines[j].rstrip().endswith("}") and lines[j].count("{") == lines[j].count("}"):
            yield m.group(7), i + 1, j - i + 1
            continue
        end = j + 1
        while end < len(lines) and lines[end].rstrip() != indent + "}":
            end += 1
        yield m.group(7), i + 1, end - i + 1


def error_enums(text: str, path: Path):
    """Breaches of rule 5 in one file's (test-stripped) text."""
    problems = []
    lines = text.split("\n")
    for i, line in enumerate(lines):
        if "thiserror::Error" not in line or not line.strip().startswith("#[derive"):
            continue
        j = i + 1
        while j < len(lines) and not re.match(r"\s*pub(\([a-z]+\))? (enum|struct) ", lines[j]):
            j += 1
        if j >= len(lines):
            continue
        indent = len(lines[j]) - len(lines[j].lstrip())
        end = j + 1
        while end < len(lines) and lines[end].rstrip() != " " * indent + "}":
            end += 1
        attrs = []
        for k in range(j + 1, end):
            s = lines[k].strip()
            if s.startswith("#["):
                attrs.append(s)
                continue
            if s.startswith("//") or not s:
                continue
            transparent = any("transparent" in a for a in attrs)
            # A tuple variant `Name(Type)` or a field `name: Type,`.
            tuple = re.match(r"([A-Z][A-Za-z0-9]*)\((.*)\),?$", s)
            field = re.match(r"(pub )?([a-z_0-9]+): (.+),$", s)
            if tuple and not transparent:
                for ty in tuple.group(2).split(","):
                    ty = ty.strip()
                    if ERROR_TYPE_RE.search(ty) and not ty.startswith("#[from]") and not ty.startswith("#[source]"):
                        problems.append(f"{path}:{k + 1}: error variant `{tuple.group(1)}` wraps `{ty}` without #[source]/#[from]")
            elif field and not transparent:
                name, ty = field.group(2), field.group(3)
                if ERROR_TYPE_RE.search(ty) and name != "source" and not any(
                    a.startswith("#[source]") or a.startswith("#[from]") for a in attrs
                ):
                    problems.append(f"{path}:{k + 1}: error field `{name}: {ty}` is not its variant's #[source]")
            if not s.startswith("#["):
                attrs = [] if (tuple or field or s.endswith("},") or s.endswith(",") or s.endswith("{")) else attrs
    return problems


def main() -> int:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    listing = "--list" in sys.argv
    src = Path(args[0]) if args else Path(__file__).resolve().parent.parent / "src"
    problems = []
    graph = {}
    longest = []
    for path in sorted(src.rglob("*.rs")):
        rel = path.relative_to(src).as_posix()
        if is_test_file(path):
            continue
        lines = strip_tests(path.read_text(encoding="utf-8").split("\n"))
        code = [l for l in lines if not l.lstrip().startswith("//")]
        module = top_module(src, path)
        for l in code:
            for target in CRATE_RE.findall(l):
                if (src / f"{target}.rs").exists() or (src / target).is_dir():
                    if target != module:
                        graph.setdefault(module, set()).add(target)
                    if target == "render" and any(rel == r or rel.startswith(r + "/") for r in RENDER_FREE):
                        problems.append(f"src/{rel}: imports the renderer (`crate::render`)")
        for name, line, count in functions(lines):
            longest.append((count, f"src/{rel}:{line}", name))
            if count > MAX_FN_LINES:
                problems.append(f"src/{rel}:{line}: fn {name} is {count} lines (at most {MAX_FN_LINES} outside tests)")
        text = "\n".join(lines)
        problems += error_enums(text, Path("src") / rel)
        # `src/cmd/` is the edge: clap value parsers there return `Result<_, String>` by design.
        if not rel.startswith("cmd/"):
            for k, l in enumerate(lines):
                if not FN_RE.match(l):
                    continue
                end = k
                while end < len(lines) and "{" not in lines[end] and not lines[end].rstrip().endswith(";"):
                    end += 1
                signature = " ".join(x.strip() for x in lines[k:end + 1])
                if re.search(r"->\s*Result<.*,\s*String,?\s*>", signature):
                    problems.append(f"src/{rel}:{k + 1}: returns `Result<_, String>`: give the error a type with a source")
    cmd_files = {p: len(p.read_text(encoding="utf-8").split("\n")) - 1 for p in (src / "cmd").rglob("*.rs")}
    cmd_lines = sum(cmd_files.values())
    for p, n in sorted(cmd_files.items()):
        if n > MAX_CMD_FILE_LINES:
            problems.append(f"src/{p.relative_to(src)}: {n} lines (at most {MAX_CMD_FILE_LINES}: a command parses, calls the library, maps the outcome)")

    # Cycles in the top-level module graph (Tarjan's strongly connected components).
    index, low, stack, on_stack, sccs = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                sccs.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    for comp in sccs:
        edges = [f"{a} -> {b}" for a in comp for b in sorted(graph.get(a, ())) if b in comp]
        problems.append(f"import cycle between modules {comp}: {', '.join(edges)}")

    if listing:
        print("longest functions:")
        for count, where, name in sorted(longest, reverse=True)[:15]:
            print(f"  {count:4d}  {where}  {name}")
        print(f"src/cmd/: {cmd_lines} lines")
        print("module graph:")
        for v in sorted(graph):
            print(f"  {v} -> {', '.join(sorted(graph[v]))}")
    for p in problems:
        print(p)
    if problems:
        print(f"check_structure: {len(problems)} problem(s)")
        return 1
    print(f"check_structure: ok (no cycle, no renderer in trim/export, functions <= {MAX_FN_LINES} lines, src/cmd/ {cmd_lines} lines in {len(cmd_files)} files of at most {MAX_CMD_FILE_LINES}, error sources kept)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
