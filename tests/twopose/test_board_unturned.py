"""A board whose captures are not turned (a new user's r7 H2): the corner detector's error
in the shapes of a turn, which a turned capture's own turn and perspective modes take, went
into the mount's rotation every capture shares, stated 3-6 of its sigmas off a true 0. Each
capture now carries them (:func:`twopose.rig.board.roll_mode`, ``perspective_modes``)."""

from __future__ import annotations

import numpy as np

from twopose.rig.board import (
    PERSPECTIVE_PRIOR,
    ROLL_PRIOR,
    fit_board_rig,
    perspective_modes,
    roll_mode,
)
from twopose.sim.layout import BOARD_POSES, board_corners
from twopose.sim.scene import load_scene

K = np.array([525.0, 525.0, 320.0, 240.0])
POSES = np.concatenate([np.array(BOARD_POSES, dtype=np.float64)] * 2)  # 16 captures
X = board_corners(load_scene(None, board={"present": True}).board)


def _observed(t_true: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The corners from unturned cameras at ``t_true`` (a perfect rig), with the rendered
    detector's error: white (0.016 px near, 0.028 px far) and, per capture, the
    perspective patterns at 3 and the roll's at 1 of those sigmas RMS (measured on
    rendered boards against their true poses)."""
    p = X[None] - t_true[:, None]
    u = np.stack([K[0] * p[..., 0] / p[..., 2] + K[2], K[1] * p[..., 1] / p[..., 2] + K[3]], -1)
    k = np.tile(K, (len(u), 1))
    far = X[:, 2].mean() - t_true[:, 2] > 40
    white = np.where(far, 0.028, 0.016)[:, None, None]
    shapes = np.concatenate([perspective_modes(u, k), roll_mode(u, k)[:, None]], axis=1)
    size = rng.standard_normal((len(u), 3)) * [PERSPECTIVE_PRIOR, PERSPECTIVE_PRIOR, ROLL_PRIOR]
    shaped = np.einsum("cm,cmkj->ckj", size, shapes)
    return u + white * (rng.standard_normal(u.shape) + shaped)


def test_an_unturned_boards_mount_rotation_is_stated_as_known_as_it_is() -> None:
    """Four unturned boards of 16 captures, the true mount 0: its three angles' errors over
    their stated sigmas have an RMS near 1 (1.03; on the old fit 2.10: the detector's shaped
    error read as the mount's)."""
    z = []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        placed = POSES + 0.1 * rng.standard_normal(POSES.shape)
        fit = fit_board_rig(
            X, _observed(placed, rng), POSES, np.zeros_like(POSES), K, t_sigma=1 / 16
        )
        z.append(fit.rig.mount_rotation_deg / fit.sigma[:3])
    rms = float(np.sqrt(np.mean(np.square(z))))
    assert rms < 1.5, np.round(z, 2)
