"""Records as pandas DataFrames: a run's trace and a check's counterexample arrive from Rust as
one Arrow record batch each, and become DataFrames with the same column types."""

from typing import Any, Optional

import pandas as pd
import pyarrow as pa

# Integers and booleans stay integers and booleans where a column has nulls (the fields of
# other kinds of records).
_SCALARS = {pa.int64(): pd.Int64Dtype(), pa.bool_(): pd.BooleanDtype()}


def _dtype(t: pa.DataType) -> Optional[Any]:
    # Arrays and nested values stay typed in Arrow's memory (pandas' ArrowDtype): a cell becomes
    # a Python list or dict only when it is read, not one object per cell up front.
    if pa.types.is_list(t) or pa.types.is_struct(t):
        return pd.ArrowDtype(t)
    return _SCALARS.get(t)


def table(batch: Any) -> pa.Table:
    """The record batch ``batch`` (an object with ``__arrow_c_array__``) as a pyarrow table,
    without a copy."""
    return pa.Table.from_batches([pa.record_batch(batch)])


def frame(t: pa.Table) -> pd.DataFrame:
    """Table ``t`` as a DataFrame: ``Int64``, ``float64``, ``boolean`` and ``str`` columns, and
    Arrow-backed list and struct columns."""
    return t.to_pandas(types_mapper=_dtype)
