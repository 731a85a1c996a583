#!/usr/bin/env python3
"""Prints the temporal row count per entity path of a rerun .rrd as JSON (static rows separately),
plus the entity paths of its blueprint store (the default viewer layout), if it has one.

Reads the file back with rerun-sdk 0.36.3's RrdReader, so a file that the viewer cannot decode
fails here too. Used by tests/dataflow.rs; run with the project's .venv python.
"""
import json
import sys

from rerun.experimental import RrdReader


def main() -> int:
    if len(sys.argv) != 2:
        print("usage: rrd_rows.py FILE.rrd", file=sys.stderr)
        return 2
    temporal: dict[str, int] = {}
    static: dict[str, int] = {}
    blueprint: dict[str, int] = {}
    reader = RrdReader(sys.argv[1])
    for chunk in reader.stream():
        target = static if chunk.is_static else temporal
        path = chunk.entity_path.lstrip("/")
        target[path] = target.get(path, 0) + chunk.num_rows
    for store in reader.blueprints():
        for chunk in reader.stream(store=store):
            path = chunk.entity_path.lstrip("/")
            blueprint[path] = blueprint.get(path, 0) + chunk.num_rows
    json.dump(
        {"temporal": temporal, "static": static, "blueprint": blueprint},
        sys.stdout,
        indent=1,
        sort_keys=True,
    )
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
