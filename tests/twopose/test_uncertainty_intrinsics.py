"""The calibration's uncertainty in every result: the intrinsics as inputs shared by a
trial's views of one camera, propagated for every method, checked by simulation.

The coverage test is the fast version of ``benchmarks/bench_intrinsics_coverage.py``: the
same estimation code (``twopose.solve.estimate``) on projected rather than rendered views, a
calibration's error drawn once per simulated session and shared by its trials.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from recorder.simulate.one_camera import calibrated_cameras, simulate_session
from twopose.camera.model import Intrinsics, project_points
from twopose.methods.specs import Method
from twopose.methods.truth import reported
from twopose.sim.scene import CameraParams, ClutterParams, Scene, SensorParams
from twopose.solve.estimate import EstimateOptions, PoseView
from twopose.solve.session import SessionTrials, estimate_session
from twopose.uncertainty.propagate import (
    INPUT_GROUPS,
    Shared,
    dominant_input,
    propagate,
    uncertainty_columns,
)
from twopose.values.units import Units

F64 = NDArray[np.float64]
NOMINAL = np.array([525.0, 525.0, 320.0, 240.0])
#: The calibration's 1-sigma (px) of fx, fy, cx, cy: about twice OpenCV's fit of its 13
#: sample photographs (0.9-1.1 px), a quick calibration's.
CALIBRATION_SIGMA = np.array([2.0, 2.0, 2.0, 2.0])
GROUND_HEIGHT = 9.625


def test_a_shared_input_is_propagated_jointly_across_its_views() -> None:
    """A linear map of per-view and shared inputs: the covariance is exact, and a shared
    input counts once for all the views of its group (its errors add, not their squares)."""
    rng = np.random.default_rng(3)
    T, N, S = 3, 3, 4
    A = rng.normal(size=(T, 3, N, 9))
    B = rng.normal(size=(T, 3, N, S))
    C = np.zeros((T, N, 9, 9))
    C[..., 0, 0] = C[..., 1, 1] = 0.25
    group = np.array([[0, 0, 1], [0, 0, 0], [0, 1, 1]])  # trial 0: view 2 another camera
    sigma = np.array([2.0, 1.5, 1.0, 0.5])
    Cs = np.zeros((T, 2, S, S))
    Cs[:, 0] = np.diag(sigma**2)  # camera 1 is exact, except in trial 2
    Cs[2, 1] = np.diag((2 * sigma) ** 2)
    shared = Shared(values=np.tile(NOMINAL, (T, N, 1)), group=group, cov=Cs)

    def f(x: F64) -> F64:
        reps = x.shape[0] // T
        own = np.einsum("tinj,tnj->ti", np.tile(A, (reps, 1, 1, 1)), x[..., :9])
        return np.asarray(own + np.einsum("tins,tns->ti", np.tile(B, (reps, 1, 1, 1)), x[..., 9:]))

    out = propagate(f, np.zeros((T, N, 9)), C, shared=shared)
    expected = np.einsum("tinj,tnjk,tlnk->til", A, C, A)
    for t in range(T):
        for g in range(2):
            Jg = B[t][:, group[t] == g].sum(axis=1)  # one error for the group's views
            expected[t] += Jg @ Cs[t, g] @ Jg.T
    np.testing.assert_allclose(out.cov_grid, expected, rtol=1e-6, atol=1e-9)
    assert out.shared_variance is not None
    np.testing.assert_allclose(
        out.variance_by_group.sum(axis=(1, 2)) + out.shared_variance,
        np.trace(out.cov_grid, axis1=1, axis2=2),
        rtol=1e-6,
    )
    # Without the shared inputs, the same call is the per-view propagation alone.
    plain = propagate(
        lambda x: f(np.concatenate([x, np.tile(NOMINAL, (*x.shape[:2], 1))], -1)),
        np.zeros((T, N, 9)),
        C,
    )
    np.testing.assert_allclose(plain.cov_grid, np.einsum("tinj,tnjk,tlnk->til", A, C, A))
    assert plain.shared_variance is None


def test_dominant_input_may_read_intrinsics() -> None:
    by_view = np.zeros((2, 2, 5))
    by_view[:, :, 1] = 0.2  # x translation of both poses: 0.4
    names, share = dominant_input(by_view, np.array([0.6, 0.1]))
    assert INPUT_GROUPS[-1] == "intrinsics"
    assert names == ["intrinsics", "x translation"]
    np.testing.assert_allclose(share, [0.6, 0.8])
    assert dominant_input(by_view)[0] == ["x translation"] * 2  # no shared inputs: as before


# --------------------------------------------------------------------------- coverage


def _session(
    rng: np.random.Generator,
    method: str,
    trials: int,
    *,
    recorded: bool,
    calibration: F64 = CALIBRATION_SIGMA,
) -> tuple[F64, list[str]]:
    """One simulated session: true intrinsics drawn from the calibration's sigma, every
    trial's two poses typed with a 0.04 in placing error, three frames of 0.3 px (0.5 deg)
    noise. Returns the ok trials' within95 and dominant inputs, the views recording the
    nominal intrinsics with (``recorded``) or without the calibration's sigma."""
    fx, fy, cx, cy = NOMINAL + calibration * rng.standard_normal(4)
    true = Intrinsics(width=640, height=480, fx=fx, fy=fy, cx=cx, cy=cy)
    sigma_t, frames = 0.04, 3
    views, truth = [], []
    for _ in range(trials):
        if method == "point":
            p = np.array([rng.uniform(-1, 3), rng.uniform(-2, 1), rng.uniform(7.5, 10.5)])
            a, b = p, p
            truth.append([p, p])
        else:  # a finger from its tip down to the ground
            b = np.array([rng.uniform(0, 3), GROUND_HEIGHT, rng.uniform(7, 10)])
            a = b + np.array([rng.uniform(-2, 2), -6.0, rng.uniform(-4, -2)])
            truth.append([a, b] if method == "line" else [b, b])
        t1 = np.array([rng.uniform(-2, 0), 0.0, rng.uniform(-1, 0)])
        t2 = t1 + np.array([rng.uniform(1, 2.5), 0.0, rng.uniform(-0.5, 0.5)])
        row = []
        for n, t in enumerate((t1, t2)):
            placed = t + sigma_t * rng.standard_normal(3)
            pa, pb = project_points(np.stack([a, b]), true, np.eye(3), placed)
            centroids = 0.5 * (pa + pb) + 0.3 * rng.standard_normal((frames, 2))
            d = pb - pa
            theta = np.full(frames, np.nan)
            if method != "point":
                theta = np.degrees(np.arctan2(d[1], d[0])) + 0.5 * rng.standard_normal(frames)
                theta = (theta + 90.0) % 180.0 - 90.0
            row.append(
                PoseView(
                    pose=n + 1,
                    intrinsics=NOMINAL.copy(),
                    width_height=(640, 480),
                    t_grid=t,
                    r_deg=np.zeros(3),
                    t_sigma=sigma_t,
                    r_sigma_deg=1e-9,
                    centroids=centroids,
                    thetas=theta,
                    found=np.ones(frames, dtype=bool),
                    camera_id="cam0",
                    intrinsics_sigma=calibration.copy() if recorded else np.zeros(4),
                )
            )
        views.append(row)
    ground = (np.array([0.0, 1.0, 0.0]), GROUND_HEIGHT) if method == "ground" else None
    session = SessionTrials(
        method=Method(method),
        units=Units.IN,
        trial_ids=tuple(range(len(views))),
        views=views,
        truth=np.array(truth),
        ground=ground,
    )
    estimate = estimate_session(session, EstimateOptions())
    rep = reported(estimate)
    within = uncertainty_columns(rep.error, rep.cov)["within95"]
    ok = (estimate.estimates.status == "ok") & np.isfinite(within)
    return within[ok], [str(d) for d in rep.dominant[ok]]


def _coverage(method: str, *, recorded: bool) -> tuple[float, int]:
    """Coverage of the 95% regions over 100 sessions of 5 trials."""
    rng = np.random.default_rng(2024)  # the same sessions with and without the sigma
    covered: list[float] = []
    for _ in range(100):
        within, _ = _session(rng, method, 5, recorded=recorded)
        covered += within.tolist()
    return float(np.mean(covered)), len(covered)


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_coverage_holds_with_the_calibrations_sigma_and_not_without(method: str) -> None:
    """500 trials in 100 sessions, each with its own draw of the intrinsics' error."""
    with_sigma, n = _coverage(method, recorded=True)
    without, _ = _coverage(method, recorded=False)
    assert n >= 490
    assert 0.90 <= with_sigma <= 0.99, with_sigma
    # Seeded: points 0.958 against 0.758, lines 0.962 against 0.898, ground 0.964 against
    # 0.878 (the principal point's error moves the estimate across its thin ellipsoid).
    assert without <= with_sigma - 0.05, (with_sigma, without)


def test_dominant_input_names_the_intrinsics_when_they_dominate() -> None:
    """A poor calibration (4% on the focal): the intrinsics dominate some trials."""
    poor = np.array([20.0, 20.0, 10.0, 10.0])
    _, dominant = _session(np.random.default_rng(1), "ground", 20, recorded=True, calibration=poor)
    assert "intrinsics" in dominant


# --------------------------------------------------------------------------- simulator, pipeline


def test_the_simulator_draws_the_intrinsics_from_the_calibrations_sigma() -> None:
    scene = Scene(cameras=(CameraParams(calibration_sigma=(2.0, 2.0, 1.0, 0.0)),))
    rendered, cameras = calibrated_cameras(scene, seed=5)
    assert cameras[0].intrinsics == scene.cameras[0].intrinsics  # recorded: nominal
    assert dict(cameras[0].intrinsics_sigma) == {"fx": 2.0, "fy": 2.0, "cx": 1.0}
    true = rendered.cameras[0]
    assert (true.fx, true.fy, true.cx) != (525.0, 525.0, 320.0)
    assert true.cy == 240.0  # no sigma: exact
    assert calibrated_cameras(scene, seed=5)[0] == rendered  # seeded
    assert calibrated_cameras(scene, seed=6)[0].cameras[0].fx != true.fx  # drawn per session
    plain = Scene()
    assert calibrated_cameras(plain, seed=5)[0] is plain  # no sigma: rendered as before
    assert not calibrated_cameras(plain, seed=5)[1][0].intrinsics_sigma


def test_a_sessions_sigma_reaches_every_trials_covariance(tmp_path: Path) -> None:
    """Rendered, recorded, analysed: the same poses and frames with a calibration's sigma
    give a larger covariance than without (the pipeline carries the camera's sigma)."""
    from analysis.session.pipeline import analyse_session
    from twopose.format.reader import SessionReader

    fast = Scene(
        clutter=ClutterParams(count=0),
        sensor=dataclasses.replace(SensorParams(), supersample=1),
    )
    calibrated = dataclasses.replace(
        fast, cameras=(CameraParams(calibration_sigma=(5.0, 5.0, 5.0, 5.0)),)
    )
    traces = []
    for name, scene in (("exact", fast), ("sigma", calibrated)):
        path = simulate_session(
            tmp_path / f"{name}.mcap", method=Method.POINT, trials=1, frames=2, seed=9, scene=scene
        )
        with SessionReader(path.path) as reader:
            sigma = dict(reader.cameras["cam0"].intrinsics_sigma)
            notes = reader.info.notes
        trials = analyse_session(path.path).trials
        assert (trials["status"] == "ok").all()
        cov = trials[["sigma_x", "sigma_y", "sigma_z"]].to_numpy() ** 2
        traces.append(float(cov.sum()))
        if name == "sigma":
            assert sigma == {"fx": 5.0, "fy": 5.0, "cx": 5.0, "cy": 5.0}
            assert "cam0 rendered with fx=" in notes
        else:
            assert sigma == {}
            assert "rendered with" not in notes
    assert traces[1] > traces[0]
