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

class RunEnded(BaseException):
    """The run ended while a seed-style algorithm waited for a call's result."""

class MotionResult:
    """How a motion ended."""
    @property
    def outcome(self) -> str:
        """``"arrived"``, ``"collided"``, ``"replaced"``, ``"rejected"`` or ``"crashed"``."""
    @property
    def at(self) -> Tuple[float, float]:
        """Where the robot stands."""
    @property
    def angle(self) -> float:
        """Its heading [deg]."""
    @property
    def arrived(self) -> bool: ...

_Area = Tuple[Tuple[float, float], Tuple[float, float]]

class RobotHandle:
    """The robot as a seed-style algorithm sees it; every call returns when its result is
    there, in virtual time."""
    @property
    def id(self) -> int: ...
    @property
    def count(self) -> int:
        """How many robots the run has."""
    @property
    def world(self) -> Optional[_Area]:
        """``((min_x, min_y), (max_x, max_y))``, ``None`` in an infinite world."""
    @property
    def area(self) -> _Area:
        """Where the seed's random movement draws destinations."""
    def now(self) -> float:
        """The virtual time [s]."""
    def move_to(self, to: Tuple[float, float], move_speed: float,
                turn_speed: float) -> MotionResult:
        """MOVETO: turn the shortest way towards ``to``, then go there."""
    def forward(self, distance: float, move_speed: float) -> MotionResult: ...
    def turn(self, angle: float, turn_speed: float) -> MotionResult:
        """Turn by ``angle`` degrees (positive: anticlockwise)."""
    def sleep(self, duration: float) -> None: ...
    def position(self, error: float = 0.0) -> Tuple[float, float]:
        """The GPS: the robot's own position, perturbed by ``error`` x N(0, 1)."""
    def all_positions(self, error: float = 0.0) -> List[Tuple[int, Tuple[float, float]]]: ...
    def robots_in_view(self, range: float) -> List[Tuple[int, Tuple[float, float]]]: ...
    def proximity(self, range: float) -> List[Tuple[int, float]]:
        """Free distances to the robots within ``range``."""
    def send(self, to: List[int], msg: Any) -> None:
        """Send any value ``json.dumps`` accepts."""
    def receive(self) -> Tuple[Optional[int], Any]:
        """Wait for the next message: ``(sender, message)``."""
    def log(self, text: str) -> None: ...
    def random(self) -> float:
        """Uniform in ``[0, 1)`` from the robot's own seeded stream."""

class ArrowBatch:
    """A record batch handed over through the Arrow PyCapsule interface
    (``pyarrow.record_batch(batch)``)."""
    def __arrow_c_array__(self, requested_schema: Optional[object] = None) -> Tuple[object, object]: ...

class RunCore:
    @property
    def summary(self) -> Dict[str, Any]: ...
    @property
    def log(self) -> List[str]: ...
    def trace(self) -> ArrowBatch: ...
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
    def trace(self) -> ArrowBatch: ...
    def __len__(self) -> int: ...

def check_core(model: str, algorithms: Sequence[Tuple[str, Any]] = (),
               goals: Optional[List[str]] = None, **options: Any) -> CheckCore: ...
