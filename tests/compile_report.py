"""Sum what tests/conftest.py's EXPLORER_COMPILE_LOG recorded: Numba's compile seconds per test and file.

    EXPLORER_COMPILE_LOG=/tmp/clog python -m pytest ...;  python tests/compile_report.py /tmp/clog
"""

import json
import sys
from collections import defaultdict
from pathlib import Path


def main(folder: str, top: int = 40) -> None:
    per_test: dict[str, float] = defaultdict(float)
    per_function: dict[str, float] = defaultdict(float)
    for f in Path(folder).glob("compile-*.json"):
        data = json.loads(f.read_text())
        for k, v in data["seconds"].items():
            per_test[k] += v
        for k, v in data.get("functions", {}).items():
            if k.startswith("explorer_gen_"):  # a module generated per topology: one line for them all
                k = "<generated per topology>." + k.split(".", 1)[1]
            per_function[k] += v
    per_file: dict[str, float] = defaultdict(float)
    for k, v in per_test.items():
        per_file[k.split("::")[0]] += v
    print(f"compile seconds in all: {sum(per_test.values()):.1f}")
    for name, table in (("file", per_file), ("function (outermost compiled)", per_function), ("test", per_test)):
        print(f"\nby {name}:")
        for k, v in sorted(table.items(), key=lambda kv: -kv[1])[:top]:
            print(f"{v:8.1f}  {k}")


if __name__ == "__main__":
    main(sys.argv[1], *(int(a) for a in sys.argv[2:3]))
