"""The native module of nekosim (PyO3); use the classes re-exported by ``nekosim``."""

from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

Multiplicity = Union[None, str, int]

class Seen:
    """One point where the robot sees robots."""
    @property
    def at(self) -> Tuple[float, float]:
        """``(x, y)`` in the robot's local frame."""
    @property
    def light(self) -> Optional[int]:
        """The light seen there, when lights are visible."""
    @property
    def multiplicity(self) -> Multiplicity:
        """``None`` without detection, ``"one"``/``"many"`` with weak detection, the number
        of robots there with strong detection."""

class View:
    """What a Look-Compute-Move robot sees, in its local frame, itself at the origin."""
    @property
    def light(self) -> Optional[int]:
        """Its own light, when visible to itself."""
    @property
    def visibility(self) -> Optional[float]:
        """How far it sees, in its own unit (``None``: everything)."""
    @property
    def others(self) -> List[Seen]:
        """The other robots, one entry per point (and light), nearest first."""
    def points(self) -> List[Tuple[float, float]]:
        """The others' points, nearest first."""
    def __len__(self) -> int: ...

class Decision:
    """A destination ``(x, y)`` in the local frame (``None``: stay) and a new light
    (``None``: keep it)."""
    def __init__(self, to: Optional[Tuple[float, float]] = None,
                 light: Optional[int] = None) -> None: ...
    @staticmethod
    def stay() -> "Decision": ...
    @property
    def to(self) -> Optional[Tuple[float, float]]: ...
    @property
    def light(self) -> Optional[int]: ...

class RunCore:
    @property
    def summary(self) -> Dict[str, Any]: ...
    @property
    def log(self) -> List[str]: ...
    def trace_ipc(self) -> bytes: ...
    def positions(self, t: float) -> Tuple[List[int], List[float], List[float]]: ...
    def __len__(self) -> int: ...

class Scenario:
    @property
    def file(self) -> str: ...
    @property
    def text(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @staticmethod
    def load(path: str) -> "Scenario": ...
    @staticmethod
    def from_ron(text: str, name: str = "<string>") -> "Scenario": ...
    def set(self, path: str, value: Union[int, float, bool, str, None]) -> None: ...
    def run_core(self, seed: Optional[int] = None, until: Optional[float] = None,
                 algorithms: Sequence[Tuple[str, Any]] = (),
                 rrd: Optional[str] = None) -> RunCore: ...

_Row = Tuple[int, List[Optional[float]], Optional[str]]

class SweepCore:
    @staticmethod
    def load(path: str) -> "SweepCore": ...
    @staticmethod
    def parse(text: str, name: str, path: str) -> "SweepCore": ...
    @property
    def runs(self) -> int: ...
    def execute(self, jobs: int = 1, shard: Optional[Tuple[int, int]] = None) -> List[_Row]: ...
    def tables(self, rows: List[_Row]) -> Tuple[bytes, bytes]: ...

class CheckCore:
    report: str
    code: int
    def trace_ipc(self) -> bytes: ...
    def __len__(self) -> int: ...

def check_core(model: str, **options: Any) -> CheckCore: ...
