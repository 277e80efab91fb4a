#!/usr/bin/env python3
"""Reads a session log's frames.parquet with pyarrow and checks it against its frames.csv
(`vlf cave --log DIR`, docs/guide/studies.md):

    python3 tools/study/parquet_check.py DIR

The Parquet parts read as one table with frames.csv's columns, in its order, and every Parquet
row equals the CSV row of the same position, value for value at the column's type (a float32
column against the CSV's text rounded to float32; an empty CSV cell against null). The Parquet
may have fewer rows than the CSV (after a SIGKILL, rows the CSV's buffer wrote before its
flush), never other ones. Prints one JSON line: {"parquet_rows": N, "csv_rows": M, "parts": P};
exits non-zero, naming the first difference, otherwise. Needs pyarrow (`bash tools/setup.sh
test` installs it).
"""

import csv
import json
import pathlib
import struct
import sys

try:
    import pyarrow as pa
    import pyarrow.parquet as pq
except Exception as e:
    sys.exit(f"parquet_check.py: cannot load pyarrow ({e}): `bash tools/setup.sh test` installs it (or `python3 -m pip install pyarrow`)")


def f32(text):
    return struct.unpack("f", struct.pack("f", float(text)))[0]


def expected(cell, kind):
    if pa.types.is_string(kind):
        return cell
    if cell == "":
        return None
    if pa.types.is_float32(kind):
        return f32(cell)
    if pa.types.is_floating(kind):
        return float(cell)
    if pa.types.is_integer(kind):
        return int(cell)
    return cell


def main():
    log = pathlib.Path(sys.argv[1])
    table = pq.read_table(log / "frames.parquet")
    with open(log / "frames.csv", newline="") as f:
        rows = list(csv.reader(f))
    header, rows = rows[0], rows[1:]
    if table.column_names != header:
        sys.exit(f"parquet_check.py: columns differ:\n parquet {table.column_names}\n csv     {header}")
    if table.num_rows > len(rows):
        sys.exit(f"parquet_check.py: {table.num_rows} Parquet rows, {len(rows)} in the CSV")
    kinds = [f.type for f in table.schema]
    for i, got in enumerate(table.to_pylist()):
        for name, kind, cell in zip(header, kinds, rows[i]):
            if got[name] != expected(cell, kind):
                sys.exit(f"parquet_check.py: row {i} column {name}: Parquet {got[name]!r}, CSV {cell!r}")
    parts = len(list((log / "frames.parquet").glob("part-*.parquet")))
    print(json.dumps({"parquet_rows": table.num_rows, "csv_rows": len(rows), "parts": parts}))


if __name__ == "__main__":
    main()
