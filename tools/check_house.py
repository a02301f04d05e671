#!/usr/bin/env python3
"""The house rules that a reviewer would otherwise check by hand (docs/design.md, "Layers").

  check_house.py layers ROOT     every #include of a project file points down the layers
  check_house.py functions ROOT  no function in src/ or host/ is longer than 150 lines, unless the
                                 line above it says why ("// long: ...")

Exits 1 and prints one line per breach, "file:line: what".
"""
import pathlib
import re
import subprocess
import sys

# Lower layers first; a file may include its own layer and any layer before it.
LAYERS = [
    ["src/core"], ["src/gpu"], ["src/io"], ["src/body"], ["src/voxelise"], ["src/sweep"], ["host/reference"],
    ["src/scene"], ["src/edit", "host/choose", "host/paths", "src/compose", "src/propose"], ["src/results"], ["src/pipeline"], ["src/cli"],
]
MAX_LINES = 150


def layer_of(path):
    for rank, folders in enumerate(LAYERS):
        if any(path == f or path.startswith(f + "/") for f in folders):
            return rank
    return None


def sources(root):
    for top in ("src", "host"):
        for p in sorted((root / top).rglob("*")):
            if p.suffix in (".cpp", ".hpp"):
                yield p


def check_layers(root):
    breaches = []
    for p in sources(root):
        rel = p.relative_to(root).as_posix()
        own = layer_of(rel)
        for number, line in enumerate(p.read_text().splitlines(), 1):
            m = re.match(r'\s*#include "([^"]+)"', line)
            if not m or m.group(1).startswith(("shaders/", "embedded/")):  # generated in the build folder
                continue
            target = m.group(1)
            if not (root / target).exists():
                breaches.append(f"{rel}:{number}: includes {target}, which is not a path from the repository root")
                continue
            rank = layer_of(target)
            if own is not None and rank is not None and rank > own:
                breaches.append(f"{rel}:{number}: includes {target}, a layer above ({' '.join(LAYERS[rank])} over {' '.join(LAYERS[own])})")
    return breaches


def check_functions(root):
    files = [str(p) for p in sources(root)]
    tags = subprocess.run(["ctags", "-o", "-", "--c++-kinds=f", "--fields=+ne", "--extras=-F"] + files,
                          capture_output=True, text=True, check=True).stdout
    breaches = []
    for line in tags.splitlines():
        fields = line.split("\t")
        name, path = fields[0], fields[1]
        start, end = re.search(r"\bline:(\d+)", line), re.search(r"\bend:(\d+)", line)
        if name.startswith("__anon") or not (start and end):
            continue
        first, last = int(start.group(1)), int(end.group(1))
        if last - first + 1 <= MAX_LINES:
            continue
        above = pathlib.Path(path).read_text().splitlines()[max(0, first - 2)]
        if "// long:" in above:
            continue
        rel = pathlib.Path(path).resolve().relative_to(root.resolve()).as_posix()
        breaches.append(f"{rel}:{first}: {name} has {last - first + 1} lines (at most {MAX_LINES}; split it into named steps)")
    return breaches


def main():
    if len(sys.argv) != 3 or sys.argv[1] not in ("layers", "functions"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    root = pathlib.Path(sys.argv[2])
    breaches = check_layers(root) if sys.argv[1] == "layers" else check_functions(root)
    for b in breaches:
        print(b)
    print(f"{sys.argv[1]}: {len(breaches)} breach(es)")
    return 1 if breaches else 0


if __name__ == "__main__":
    sys.exit(main())
