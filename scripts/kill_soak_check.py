#!/usr/bin/env python3
"""Checks what scripts/kill_soak.sh left: every published keyframe is in some map file under its
(map_id, id), no (map_id, id) was published for two frames, and no two files hold the same one.

    scripts/kill_soak_check.py FOLDER

FOLDER holds published.csv (rostopic echo -p /keyframes) and the map files. Each map is read
from a copy (with its write-ahead log), so nothing the soak left is changed. Exit status 1 when
any rule is broken.
"""
import csv
import os
import shutil
import sqlite3
import sys
import tempfile


def published_keyframes(path):
    """(map_id, id) -> set of stamps (ns) it was published with."""
    published = {}
    with open(path, newline="") as file:
        rows = csv.reader(file)
        header = next(rows, None)
        if header is None:
            return published
        column = {name: i for i, name in enumerate(header)}
        for row in rows:
            key = (int(row[column["field.map_id"]]), int(row[column["field.id"]]))
            published.setdefault(key, set()).add(int(row[column["field.header.stamp"]]))
    return published


SIDE_FILES = ("-wal", "-shm", "-vectors", "-graph", "-summaries")


def map_files(folder):
    """The maps: A.db, B3.db, A.db.replaced-TIME, not the files SQLite and the map keep beside."""
    for name in sorted(os.listdir(folder)):
        if ".db" in name and not name.endswith(SIDE_FILES):
            yield os.path.join(folder, name)


def stored_keyframes(path):
    """(map_id, ids) the map at `path` holds, read from a copy with its write-ahead log."""
    with tempfile.TemporaryDirectory() as scratch:
        copy = os.path.join(scratch, "map.db")
        shutil.copyfile(path, copy)
        if os.path.exists(path + "-wal"):
            shutil.copyfile(path + "-wal", copy + "-wal")
        connection = sqlite3.connect(copy)
        try:
            map_id = int(connection.execute(
                "SELECT value FROM meta WHERE key = 'map_id'").fetchone()[0])
            ids = [row[0] for row in connection.execute("SELECT id FROM keyframes")]
        finally:
            connection.close()
    return map_id, ids


def main(folder):
    published = published_keyframes(os.path.join(folder, "published.csv"))
    holders = {}
    problems = []
    files = list(map_files(folder))
    for path in files:
        try:
            map_id, ids = stored_keyframes(path)
        except (sqlite3.Error, TypeError) as error:
            problems.append(f"{os.path.basename(path)}: unreadable ({error})")
            continue
        for keyframe_id in ids:
            holders.setdefault((map_id, keyframe_id), []).append(os.path.basename(path))
    twice_published = {key: stamps for key, stamps in published.items() if len(stamps) > 1}
    missing = sorted(key for key in published if key not in holders)
    held_twice = {key: names for key, names in holders.items() if len(names) > 1}
    for key, stamps in sorted(twice_published.items())[:10]:
        problems.append(f"(map {key[0]}, id {key[1]}) published for {len(stamps)} frames")
    for key in missing[:10]:
        problems.append(f"(map {key[0]}, id {key[1]}) published, in no map file")
    for key, names in sorted(held_twice.items())[:10]:
        problems.append(f"(map {key[0]}, id {key[1]}) in {', '.join(names)}")
    maps_published = len({key[0] for key in published})
    print(f"published: {len(published)} keyframes of {maps_published} maps; "
          f"map files: {len(files)} holding {len(holders)} keyframes")
    print(f"published and in no file: {len(missing)}; published for two frames: "
          f"{len(twice_published)}; in two files: {len(held_twice)}")
    for problem in problems:
        print("  " + problem)
    print("kill soak: " + ("FAILED" if problems else "every published keyframe is in one file"))
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
