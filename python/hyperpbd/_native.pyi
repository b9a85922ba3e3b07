"""Type stubs of hyperpbd's extension module (re-exported by `hyperpbd`)."""

import os
from types import TracebackType
from typing import Literal, Mapping, NotRequired, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

BackendName = Literal["auto", "cpu", "cpu-f64", "gpu", "gpu-f32", "gpu-f64"]
ArrayLike = npt.ArrayLike
Float64Rows = npt.NDArray[np.float64]

class Minimisation(TypedDict):
    """One incremental-potential minimisation (one substep)."""

    iterations: int
    initial_residual: float | None
    final_residual: float | None
    status: str

class StepReport(TypedDict):
    """The last step's report (`Simulation.step`)."""

    max_violation: float
    """Largest constraint violation over all families (0 with none)."""
    residuals: dict[str, float]
    """Per family, in authored order: "constraints[0]", "obstacles[1]", …"""
    active_contacts: int
    threads: int
    """CPU threads the step ran on; 0 on a GPU."""
    retries: int
    """Attempts a guard rejected before the accepted one."""
    kernel_calls: dict[str, int]
    minimisation: list[Minimisation]
    contact_forces: NotRequired[ContactForces]
    """Only after `Simulation.request_contact_forces()`."""

class ContactForces(TypedDict):
    """The last frame's contact forces (impulses over dt)."""

    obstacles: Float64Rows
    """(obstacles, dim): each obstacle's total contact force on the particles."""
    particles: Float64Rows
    """(particles, dim): each particle's total contact force."""

class SweepRow(TypedDict):
    """One world of `sweep`."""

    world: int
    set: dict[str, float]
    positions: Float64Rows
    velocities: Float64Rows
    report: StepReport | None
    backend: str

class SceneError(ValueError):
    """A scene that cannot be simulated."""

    path: str | None
    """The offending field ("particles[3].mass"); None for an unreadable file."""

class StepError(RuntimeError):
    """A step that could not complete; the state is as before that step."""

    frame: int
    """The failed step's number within the `step` call (1-based)."""

class GpuError(RuntimeError):
    """No adapter, a missing feature, device lost, out of memory, a scene
    the GPU kernels cannot run. Never a silent fallback to the CPU."""

class Scene:
    """A validated, immutable scene in R^dim."""

    @staticmethod
    def from_json(text: str) -> Scene:
        """Parses and validates a scene document. Raises SceneError."""
    @staticmethod
    def load(path: Union[str, os.PathLike[str]]) -> Scene:
        """Reads, parses and validates a scene file. Raises SceneError."""
    @staticmethod
    def builtin(name: str) -> Scene:
        """A built-in scene (`Scene.builtin_names()`), as `hyperpbd scene NAME`."""
    @staticmethod
    def builtin_names() -> list[str]:
        """Names `Scene.builtin` accepts."""
    def to_json(self) -> str:
        """The scene as JSON (round-trip exact f64)."""
    @property
    def dim(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def particle_count(self) -> int: ...

class Simulation:
    """A scene running on one backend; numpy float64 (particles, dim) out."""

    def __init__(
        self,
        scene: Scene,
        backend: BackendName = "auto",
        threads: int | None = None,
    ) -> None:
        """Loads `scene` on `backend` ("auto", "cpu", "gpu", "gpu-f64").
        `threads`: CPU threads of the golden path (None: HYPERPBD_THREADS,
        else every core); results are the same bytes for any count.
        Raises SceneError, GpuError, ValueError."""
    def step(self, frames: int = 1) -> StepReport:
        """Advances `frames` steps with the GIL released; the last step's
        report. Raises StepError (state as before the failed step)."""
    @property
    def positions(self) -> Float64Rows:
        """A copy, shape (particles, dim)."""
    @property
    def velocities(self) -> Float64Rows:
        """A copy, shape (particles, dim)."""
    def state(self) -> tuple[Float64Rows, Float64Rows]:
        """(positions, velocities) from one read."""
    def write_state(self, positions: ArrayLike, velocities: ArrayLike | None = None) -> None:
        """Replaces the state; wrong shape or a non-finite value raises
        ValueError and changes nothing."""
    def request_contact_forces(self, on: bool = True) -> None:
        """Every following step reports "contact_forces"; GpuError for a
        GPU scene on the coupled implicit step."""
    def set_forces(self, forces: ArrayLike) -> None:
        """Replaces the constant external forces, shape (particles, dim)."""
    def state_hash(self) -> str:
        """16 hex digits, as `hyperpbd run` prints `state hash`."""
    @property
    def time(self) -> float: ...
    @property
    def frames(self) -> int: ...
    @property
    def backend(self) -> str:
        """"cpu-f64", "gpu-f32" or "gpu-f64"."""
    @property
    def notice(self) -> str | None:
        """What backend="auto" picked and why; None for a named backend."""
    @property
    def threads(self) -> int | None:
        """CPU threads; None on a GPU."""
    @property
    def dim(self) -> int: ...
    @property
    def particle_count(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def closed(self) -> bool: ...
    def close(self) -> None:
        """Releases the backend (a GPU's device) now; idempotent."""
    def __enter__(self) -> Simulation: ...
    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> bool: ...

def sweep(
    scene: Scene,
    axes: Mapping[str, Union[Sequence[float], str]],
    frames: int = 60,
    backend: BackendName = "auto",
    threads: int | None = None,
) -> list[SweepRow]:
    """One world per combination of `axes` values (PATH -> values or
    "LO:HI:COUNT", the last axis fastest), as `hyperpbd sweep` (on a GPU in
    its batches; worlds that cannot share one warn and run one backend
    each)."""
