"""``twopose-analyze rig`` on board sessions: the rig's constants from a checkerboard standing
at a measured place (:mod:`twopose.rig.board`), in one call.

Each accepted, complete capture of a board session gives one observation: the board's
corners found in each of its frames (``cv2.findChessboardCorners``, put in the board's own
order), averaged over the frames that found it. A capture in which no frame found the whole
board is left out, and said. The captures of several board sessions are fitted together
(each keeps its own board placement and intrinsics; one unit for all), combined in an order
of their content, not of the command line; a session named twice counts once.

A simulated board session records what the simulator drew (``/simulation/truth``, kind
``board``): where each capture's laptop really stood. Where every capture used has it, the
calibration carries the placing the simulator realised (:attr:`BoardCalibration.true_placing`,
its RMS over the captures' components), to set the measured placing sigma against.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from analysis.rig.fit import RigFit
from twopose.arrays import F64
from twopose.camera.model import Intrinsics, rotation_from_angles_deg
from twopose.detect.checkerboard import find_board
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.simulation import SimulationTruth
from twopose.format.trials import PoseCapture, iter_trials
from twopose.methods.specs import spec_of
from twopose.rig.board import FITTED, BoardRigFit, board_order, fit_board_rig
from twopose.rig.constants import RIG_PARAMETERS, RigConstants
from twopose.values.units import Units

__all__ = ["BoardCalibration", "BoardCaptures", "calibrate_board", "is_board_session"]

Note = Callable[[str], None]


@dataclass(frozen=True, kw_only=True)
class BoardCaptures:
    """A board session's captures, ready for :func:`twopose.rig.board.fit_board_rig`.

    Per usable capture (C of them): the board's corners in the grid frame ``corners_grid``
    (C, K, 3), the corners found (C, K, 2, pixels, averaged over the frames that found the
    board), the typed pose ``t_typed`` and ``r_typed_deg`` (C, 3) and the camera's
    ``intrinsics`` (C, 4: fx, fy, cx, cy). ``t_sigma`` is the largest typed translation
    resolution, ``r_sigma_deg`` (C,) each capture's typed rotation resolution; ``cameras``
    the session's cameras the captures were taken with; ``left_out`` says which captures
    found no board, and why.
    """

    session: str
    units: Units
    corners_grid: F64
    observed_px: F64
    t_typed: F64
    r_typed_deg: F64
    intrinsics: F64
    t_sigma: float
    r_sigma_deg: F64
    cameras: tuple[Intrinsics, ...]
    left_out: tuple[str, ...] = ()
    #: who placed the board (the session entry's operator; "": not named)
    operator: str = ""
    #: A simulated session's true placing error per capture (C, 3; where the laptop really
    #: stood minus where it was typed, session units, from ``/simulation/truth``); None
    #: when a capture has no truth (a recorded session, or one simulated before it was
    #: written).
    true_placing: F64 | None = None

    def fingerprint(self) -> str:
        """What the fit reads from the session (a copy of a file has the same)."""
        digest = hashlib.sha256()
        for a in (self.corners_grid, self.observed_px, self.t_typed, self.r_typed_deg):
            digest.update(np.ascontiguousarray(a).tobytes())
        return digest.hexdigest()


@dataclass(frozen=True, kw_only=True)
class BoardCalibration:
    """The rig from board sessions: the fit as ``rig`` writes it (:class:`RigFit`), the
    board fit itself (corner RMS, counts, warnings against the priors), and the sessions
    that informed it, in the order given."""

    fit: RigFit
    board: BoardRigFit
    sessions: tuple[str, ...]
    #: The placing the simulator drew, RMS over every used capture's three components
    #: (session units; None: not every session records its truth, as no recorded one does).
    true_placing: float | None = None


def is_board_session(path: str | Path) -> bool:
    """Whether ``path`` is a board session (it calibrates the rig; it reconstructs nothing)."""
    with SessionReader(path) as reader:
        return not spec_of(reader.info.method).measures


def read_board_session(path: str | Path) -> BoardCaptures:
    """The usable captures of one board session (see the module docstring)."""
    session = str(path)
    with SessionReader(path) as reader:
        info = reader.info
        if info.board is None:
            raise InputValueError(f"{session} is not a board session (its method is {info.method})")
        board = info.board
        rows: list[tuple[F64, PoseCapture]] = []
        placed: list[F64 | None] = []
        left_out: list[str] = []
        for record in iter_trials(reader):
            for pose in record.poses:
                where = f"{session}: trial {record.trial}, pose {pose.entry.pose}"
                if not pose.complete:
                    left_out.append(f"{where}: no complete capture")
                    continue
                corners = _mean_corners(pose, board.inner_corners)
                if corners is None:
                    left_out.append(f"{where}: the whole board was found in none of its frames")
                    continue
                rows.append((corners, pose))
                placed.append(_true_placing(record.simulation_truth, pose))
    if not rows:
        raise InputValueError(f"{session}: no capture found the whole board; nothing to fit")
    grid = board.corners_grid()
    return BoardCaptures(
        session=session,
        units=info.units,
        corners_grid=np.stack([grid] * len(rows)),
        observed_px=np.stack([c for c, _ in rows]),
        t_typed=np.array([p.entry.t_grid for _, p in rows], dtype=np.float64),
        r_typed_deg=np.array([p.entry.r_deg for _, p in rows], dtype=np.float64),
        intrinsics=np.array([_k(p) for _, p in rows], dtype=np.float64),
        t_sigma=max(p.entry.translation_resolution for _, p in rows),
        r_sigma_deg=np.array([p.entry.rotation_resolution_deg for _, p in rows]),
        cameras=tuple(dict.fromkeys(p.camera.intrinsics for _, p in rows)),
        left_out=tuple(left_out),
        operator=info.operator.strip(),
        true_placing=None if any(e is None for e in placed) else np.array(placed),
    )


def _true_placing(truth: SimulationTruth | None, pose: PoseCapture) -> F64 | None:
    """Where the laptop of ``pose`` really stood minus its typed place (session units), from
    the trial's simulated truth: the true camera pose with the rig's constants undone
    (:meth:`twopose.rig.RigConstants.placed_poses`); None without a truth of that pose."""
    true = next((p for p in truth.poses if p.pose == pose.entry.pose), None) if truth else None
    if truth is None or true is None:
        return None
    rig = RigConstants() if truth.rig is None else RigConstants.from_vector(truth.rig)
    t_placed, _ = rig.placed_poses(true.t_grid, rotation_from_angles_deg(true.r_deg))
    return np.asarray(t_placed - np.asarray(pose.entry.t_grid), dtype=np.float64)


def _k(pose: PoseCapture) -> tuple[float, float, float, float]:
    k = pose.camera.intrinsics
    return (k.fx, k.fy, k.cx, k.cy)


def _mean_corners(pose: PoseCapture, inner_corners: tuple[int, int]) -> F64 | None:
    """The board's corners (K, 2) averaged over the frames that found all of them."""
    size = (pose.camera.intrinsics.width, pose.camera.intrinsics.height)
    found = []
    for frame in pose.frames:
        corners = find_board(frame.decode(size), inner_corners, window_px=None)
        if corners is not None:
            found.append(board_order(corners, inner_corners))
    return np.mean(found, axis=0) if found else None


def calibrate_board(
    paths: Sequence[str | Path], groups: Sequence[str] | None = None, on_note: Note | None = None
) -> BoardCalibration:
    """``twopose-analyze rig`` on board sessions: the constants a board determines (or the
    ``groups`` given), by maximum likelihood over every corner of every usable capture."""
    note = on_note or (lambda _text: None)
    parts: dict[str, BoardCaptures] = {}
    for path in paths:
        part = read_board_session(path)
        for why in part.left_out:
            note(f"left out {why}")
        key = part.fingerprint()
        if key in parts:
            note(f"{part.session}: the same captures as {parts[key].session}; counted once")
            continue
        parts[key] = part
    units = {p.units for p in parts.values()}
    if len(units) > 1:
        raise InputValueError(
            f"board sessions in {' and '.join(sorted(units))}: a rig's camera offset is a "
            "length in one unit; calibrate it with sessions in one unit"
        )
    ordered = [parts[k] for k in sorted(parts)]  # the content's order, not the command line's

    def stacked(name: str) -> F64:
        return np.concatenate([getattr(p, name) for p in ordered])

    board = fit_board_rig(
        stacked("corners_grid"),
        stacked("observed_px"),
        stacked("t_typed"),
        stacked("r_typed_deg"),
        stacked("intrinsics"),
        units=Units(units.pop()),
        t_sigma=max(p.t_sigma for p in ordered),
        r_sigma_deg=stacked("r_sigma_deg"),
        groups=FITTED if groups is None else tuple(groups),
    )
    cameras = tuple(dict.fromkeys(c for p in ordered for c in p.cameras))
    board = dataclasses.replace(board, rig=dataclasses.replace(board.rig, cameras=cameras))
    used = {p.session for p in ordered}
    sessions = tuple(dict.fromkeys(str(p) for p in paths if str(p) in used))
    if board.placing is not None:  # measured by these sessions, named as the rig file's
        named = ", ".join(Path(s).name for s in sessions)
        hands = tuple(dict.fromkeys(p.operator for p in ordered if p.operator))  # whose
        board = dataclasses.replace(
            board, placing=dataclasses.replace(board.placing, measured_by=named, operators=hands)
        )
    truths = [p.true_placing for p in ordered]
    true_placing = (
        None
        if any(t is None for t in truths)
        else float(np.sqrt(np.mean(np.concatenate([t for t in truths if t is not None]) ** 2)))
    )
    return BoardCalibration(
        fit=as_rig_fit(board), board=board, sessions=sessions, true_placing=true_placing
    )


def as_rig_fit(board: BoardRigFit) -> RigFit:
    """The board's fit in the form every rig file is written from (:func:`analysis.rig.
    rig_toml`): its chi-square is the corners' (whitened by their RMS), the ground height
    error is fixed (a board does not see the ground)."""
    n_params = len(board.free)
    dof = max(2 * board.n_corners - n_params, 1)
    fixed = {"ground_height_error": "a board does not see the ground"}
    fixed |= {
        name: "not asked for (--constant)"
        for group in FITTED
        for name in RIG_PARAMETERS[group]
        if name not in board.free
    }
    return RigFit(
        constants=board.rig,
        sigma=board.sigma,
        free=board.free,
        fixed=fixed,
        chi2=float(dof),  # the corners' noise is estimated from their residuals
        dof=dof,
        press=float("nan"),
    )
