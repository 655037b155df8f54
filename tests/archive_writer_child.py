"""Child process for the kill -9 durability test: adds copies of a template run forever.

Usage: python archive_writer_child.py ARCHIVE TEMPLATE.h5 START_INDEX

Prints "ready" once, then the run ID of every run after ``Archive.add`` returned (so a printed
ID is committed). Each copy gets a distinct run ID (start_index, start_index + 1, ...).
"""

from __future__ import annotations

import sys

from bowlrec.archive import Archive
from bowlrec.sinks import RunData
from bowlrec.sinks.hdf5_run import read_run_file


def main() -> None:
    archive = Archive(sys.argv[1])
    stored = read_run_file(sys.argv[2])
    plan = stored.scene.resolve()
    i = int(sys.argv[3])
    print("ready", flush=True)
    while True:
        rid = f"{i:020x}"
        archive.add(RunData(stored.scene, plan, stored.trajectory, rid), wall_time_s=0.0)
        print(rid, flush=True)
        i += 1


if __name__ == "__main__":
    main()
