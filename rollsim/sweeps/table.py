"""A sweep's results as a table: one row per cell, in grid order.

Columns: ``cell``, every swept key (named as in the scene, ``link.distance_cm``),
the stage's figures (units in the names), then ``seed``, ``status``,
``error``, ``seconds`` and ``cell_id``. Written as Parquet (pyarrow, typed
columns) and CSV; :func:`to_dataframe` gives a pandas DataFrame where pandas
is installed.
"""

from __future__ import annotations

import csv
import io
import json
from typing import Sequence

from rollsim.sweeps.stages import STAGE_COLUMNS

TRAILING = ("seed", "status", "error", "seconds", "cell_id")


def columns_of(stage: str, swept_keys: Sequence[str]) -> list[str]:
    """The table's columns, in order."""
    return ["cell", *swept_keys, *STAGE_COLUMNS[stage], *TRAILING]


def table_rows(rows: list[dict], cells, stage: str, swept_keys: Sequence[str]) -> list[dict]:
    """One row per cell, in grid order: its swept values, then its figures (None where missing)."""
    by_id = {row["cell_id"]: row for row in rows}
    columns = columns_of(stage, swept_keys)
    table = []
    for cell in cells:
        row = {**by_id.get(cell.id, {"status": "missing"}), **cell.values, "cell": cell.index, "cell_id": cell.id}
        table.append({name: row.get(name) for name in columns})
    return table


def _arrow_type(values: list):
    """The narrowest Arrow type that holds every value of a column (None is null)."""
    import pyarrow as pa

    present = [v for v in values if v is not None]
    if not present:
        return pa.null()
    if all(isinstance(v, bool) for v in present):
        return pa.bool_()
    if all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return pa.int64() if all(-(2**63) <= v < 2**63 for v in present) else pa.float64()
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return pa.float64()
    return pa.string()


def parquet_bytes(rows: list[dict], columns: Sequence[str]) -> bytes:
    """The table as Parquet bytes, each column typed from its values."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays = {}
    for name in columns:
        values = [row[name] for row in rows]
        kind = _arrow_type(values)
        if kind == pa.string():  # a mixed column: text as is, other values as JSON
            values = [v if v is None or isinstance(v, str) else json.dumps(v) for v in values]
        arrays[name] = pa.array(values, type=kind)
    buffer = io.BytesIO()
    pq.write_table(pa.table(arrays), buffer)
    return buffer.getvalue()


def csv_text(rows: list[dict], columns: Sequence[str]) -> str:
    """The table as CSV: floats written exactly (repr), null as empty."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(columns), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else repr(v) if isinstance(v, float) else v) for k, v in row.items()})
    return buffer.getvalue()


def to_dataframe(rows: list[dict], columns: Sequence[str]):
    """A pandas DataFrame of the table, or None where pandas is not installed."""
    try:
        import pandas as pd
    except ImportError:
        return None
    return pd.DataFrame(rows, columns=list(columns))
