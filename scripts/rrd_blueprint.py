#!/usr/bin/env python3
"""Prints the default viewer layout (blueprint) of a rerun .rrd as JSON, and the annotation
contexts of its recording checked against the keypoints it logs.

- "views": one per view the layout shows: class, name, origin, contents (the content queries),
  the properties logged for it (archetype names) and the container titles above it;
- "viewport": whether the root container is set and auto views are off;
- "annotation": per entity with an AnnotationContext, the keypoint ids it declares, the ids its
  connections use, and the keypoint ids its points ever log. The viewer warns "Keypoint
  connection ... could not be resolved" when a connection names a keypoint a pose lacks, so a
  file without those warnings has no connections, or connections only between ids that every
  pose logs.

Reads the file with rerun-sdk 0.36.3's RrdReader, as scripts/rrd_rows.py does. Used by
tests/viewer.rs; run with the project's .venv python.
"""
import json
import sys

from rerun.experimental import RrdReader


def column(batch, suffix):
    """The values of the column whose name ends with `suffix`, one per row (None if absent)."""
    for name in batch.schema.names:
        if name.endswith(suffix):
            return batch.column(name).to_pylist()
    return None


def first(values):
    """A row's single value (rerun stores each row as a list)."""
    if isinstance(values, list):
        return values[0] if values else None
    return values


def main() -> int:
    if len(sys.argv) != 2:
        print("usage: rrd_blueprint.py FILE.rrd", file=sys.stderr)
        return 2
    reader = RrdReader(sys.argv[1])
    views: dict[str, dict] = {}
    containers: dict[str, dict] = {}
    viewport: dict = {}
    for store in reader.blueprints():
        for chunk in reader.stream(store=store):
            path = chunk.entity_path.lstrip("/")
            batch = chunk.to_record_batch()
            parts = path.split("/")
            if parts[0] == "view" and len(parts) == 2:
                v = views.setdefault(path, {"properties": []})
                for key, suffix in [("class", "ViewBlueprint:class_identifier"),
                                    ("name", "ViewBlueprint:display_name"),
                                    ("origin", "ViewBlueprint:space_origin")]:
                    values = column(batch, suffix)
                    if values:
                        v[key] = first(values[-1])
            elif parts[0] == "view" and len(parts) == 3:
                v = views.setdefault("/".join(parts[:2]), {"properties": []})
                if parts[2] == "ViewContents":
                    values = column(batch, "ViewContents:query")
                    if values:
                        v["contents"] = values[-1]
                else:
                    v["properties"].append(parts[2])
            elif parts[0] == "container":
                c = containers.setdefault(path, {})
                values = column(batch, "ContainerBlueprint:contents")
                if values:
                    c["contents"] = [p.lstrip("/") for p in values[-1]]
                kind = column(batch, "ContainerBlueprint:container_kind")
                if kind:
                    c["kind"] = first(kind[-1])
            elif path == "viewport":
                root = column(batch, "ViewportBlueprint:root_container")
                auto = column(batch, "ViewportBlueprint:auto_views")
                viewport["has_root"] = bool(root and first(root[-1]))
                if auto:
                    viewport["auto_views"] = first(auto[-1])
    parent = {child: path for path, c in containers.items() for child in c.get("contents", [])}
    shown = []
    for path, v in views.items():
        if path not in parent:
            continue  # written but not placed in the layout
        depth, p = 0, path
        while p in parent:
            p, depth = parent[p], depth + 1
        v["path"] = path
        v["depth"] = depth
        shown.append(v)

    declared: dict[str, dict] = {}
    logged: dict[str, set] = {}
    for chunk in reader.stream():
        path = chunk.entity_path.lstrip("/")
        batch = chunk.to_record_batch()
        ctx = column(batch, "AnnotationContext:context")
        if ctx:
            for row in ctx:
                # A row is a list of contexts, each a list of {class_id, class_description}.
                classes = [c for batch_row in row or [] for c in (batch_row or [])]
                for entry in classes:
                    cls = entry["class_description"]
                    kp = cls.get("keypoint_annotations") or []
                    conn = cls.get("keypoint_connections") or []
                    declared[path] = {
                        "keypoints": sorted(k["id"] for k in kp),
                        "connections": sorted(
                            {c["keypoint0"] for c in conn} | {c["keypoint1"] for c in conn}
                        ),
                    }
        ids = column(batch, "Points3D:keypoint_ids")
        if ids:
            per_pose = logged.setdefault(path, {"every": None, "ever": set()})
            for row in ids:
                row = set(row or [])
                per_pose["ever"] |= row
                per_pose["every"] = row if per_pose["every"] is None else per_pose["every"] & row
    annotation = {
        path: {
            **d,
            "logged_ever": sorted(logged.get(path, {}).get("ever", set())),
            "logged_every_pose": sorted(logged.get(path, {}).get("every") or set()),
        }
        for path, d in declared.items()
    }
    json.dump({"views": shown, "viewport": viewport, "annotation": annotation},
              sys.stdout, indent=1, sort_keys=True)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
