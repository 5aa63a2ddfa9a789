# Type stubs of the extension module; the documented API is riskscore/__init__.py.
from typing import Any, Dict, List, Optional, Tuple, Union, final

import numpy as np
import pyarrow as pa

__all__ = ["ssm", "computed_columns", "read_events", "write_events", "evaluate", "Model", "__version__"]

__version__: str

_BadRows = List[Tuple[int, Optional[str], str]]
# A threshold: a number (numpy scalars too: the extension reads any float-like), or a word.
_Threshold = Union[float, np.floating[Any], np.integer[Any], str]

def computed_columns() -> List[str]: ...
def ssm(table: pa.Table, keep_input: bool = False) -> Tuple[pa.Table, _BadRows, int]: ...
def read_events(dir: str) -> Tuple[pa.Table, pa.Table, List[str], List[str], int]: ...
def write_events(dir: str, events: pa.Table, frames: pa.Table, overwrite: bool = False) -> None: ...
def evaluate(
    events: str,
    models: List[str],
    threshold_all: Optional[_Threshold] = None,
    thresholds_by_name: Dict[str, _Threshold] = ...,
    skip_bad_events: bool = False,
) -> Tuple[str, List[str], List[str], int, List[str]]: ...

# A pyo3 class without `subclass`: Python cannot derive from it.
@final
class Model:
    @staticmethod
    def load(path: str) -> Model: ...
    @staticmethod
    def from_bytes(blob: bytes) -> Model: ...
    def to_bytes(self) -> bytes: ...
    @property
    def path(self) -> Optional[str]: ...
    @property
    def info(self) -> Dict[str, object]: ...
    def _score(self, table: pa.Table) -> Tuple[pa.Array, _BadRows, int]: ...
    def _in_domain(self, table: pa.Table) -> Tuple[pa.Array, _BadRows, int]: ...
