"""The web console against a model, over HTTP, on random sequences of what an operator does
(hypothesis): set up (point, line, ground; with and without ground truth; a refused form
first), type poses (on target, looking away from it so that no frame finds it, the same
pose twice in a trial, rotations, values the form must refuse), capture, accept, accept
anyway, redo, undo (at pose 1 too), note, quit, reload the page, and stop the server.

The console runs in-process (Starlette's TestClient runs its lifespan, so the recording
thread is the real one, with the synthetic camera rendering the typed pose). After every
step: no answer is a 5xx, ``/api/state`` is strict JSON (no NaN or infinity) and shows
what the model says (phase, what it waits for, trial, pose, the trial's accepted poses,
the pose form). A simulated kill -9 (the file copied as it is on disk, closed by
``twopose-record recover``) and the closed file at the end both replay, through the
session reader and the analysis, to exactly the poses the model says were accepted.
"""

from __future__ import annotations

import functools
import json
import re
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Concatenate, ParamSpec, TypeVar

import httpx2
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    invariant,
    precondition,
    rule,
    run_state_machine_as_test,
)
from starlette.testclient import TestClient
from typer.testing import CliRunner

import analysis
from recorder.cli.app import app
from recorder.console.server import ConsoleOptions, console_app
from recorder.console.state import ConsoleSession
from tests.helpers import SMALL_SCENE
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials, read_notes

Vec3 = tuple[float, float, float]
Pose = tuple[Vec3, Vec3]  # typed (t_grid, r_deg)
Accepted = dict[int, dict[int, Pose]]  # trial -> pose -> typed pose

SIZE = (320, 240)
FOCAL, PRINCIPAL = "262.5", "160, 120"
FRAMES = 2
TIMEOUT_S = 20.0
HOST = "http://127.0.0.1:8765"  # the Host a browser on loopback sends

# Typed poses where every frame finds the target (every method), and where none does:
# the camera turned away from it, or placed far to the side of it.
ON_TARGET: tuple[Vec3, ...] = ((0, 0, 0), (1, 0, 0), (-1, 0, -1), (2, 0, 1), (0.5, 0, -2))
ROTATIONS: tuple[Vec3, ...] = ((0, 0, 0), (0, 0, 10), (5, 0, 0))
OFF_TARGET: tuple[Pose, ...] = (
    ((0, 0, 0), (0, 180, 0)),
    ((1, 0, 0), (0, -90, 0)),
    ((150, 0, 0), (0, 0, 0)),
    ((-150, 0, 0), (0, 0, 0)),
)
# Pose forms the console must refuse (400) in inches and centimetres alike.
BAD_POSES: tuple[dict[str, str], ...] = (
    {"x": "9999", "y": "0", "z": "0"},
    {"x": "0", "y": "-9999", "z": "0"},
    {"x": "nan", "y": "0", "z": "0"},
    {"x": "inf", "y": "0", "z": "0"},
    {"x": "0", "y": "0", "z": "1e400"},
    {"x": "", "y": "0", "z": "0"},
    {"x": "abc", "y": "0", "z": "0"},
    {"x": "0", "y": "0", "z": "0", "rotation": "0, 200, 0"},
    {"x": "0", "y": "0", "z": "0", "rotation": "1, 2"},
    {"x": "0", "y": "0", "z": "0", "rotation": "nan, 0, 0"},
    {},
)
TRUTH = {
    "point": ("0.5, 1.5, 11",),
    "line": ("1.91, 9.625, 8.375", "0.5, 2, 7"),
    "ground": ("1.91, 9.625, 8.375",),
}
OFF_GROUND = "1.91, 9, 8.375"  # a method 2 point 0.625 above the ground plane
# Setup forms refused whatever the method (over a valid form), and per method.
BAD_SETUPS: tuple[dict[str, str], ...] = (
    {"method": ""},
    {"method": "plane"},
    {"units": "furlongs"},
    {"focal": "-5"},
    {"focal": "abc"},
    {"principal": "900, 900"},
    {"principal": "160"},
    {"truth1": "1, 2"},
    {"truth1": "nan, 0, 0"},
    {"truth1": "0, 0, 99999"},
)
BAD_FOR = {
    "point": ({"truth1": "0, inf, 0"},),
    "line": (
        {"truth1": TRUTH["line"][0], "truth2": ""},
        {"truth1": TRUTH["line"][0], "truth2": TRUTH["line"][0]},
    ),
    "ground": (
        {"ground_height": ""},
        {"ground_height": "0"},
        {"truth1": OFF_GROUND, "keep_off_ground": ""},
    ),
}
NOTE_TEXT = st.text(
    st.characters(categories=["L", "N", "P", "Zs"], exclude_characters="\x85"), max_size=30
)
SUMMARY = re.compile(
    r"(?P<trials>\d+) trials? \((?P<complete>\d+) complete\), (?P<captures>\d+) captures? "
    r"\((?P<accepted>\d+) accepted, (?P<discarded>\d+) discarded"
)

RUNS = {"examples": 0, "captures": 0, "none_found": 0, "recovered": 0, "finished": 0}

P = ParamSpec("P")
R = TypeVar("R")


def _step(
    f: Callable[Concatenate[ConsoleModel, P], R],
) -> Callable[Concatenate[ConsoleModel, P], R]:
    """A step of the machine: counted, and marked broken until it returns (so that the
    teardown does not pile a second failure on a step's own)."""

    @functools.wraps(f)
    def run(self: ConsoleModel, *args: P.args, **kwargs: P.kwargs) -> R:
        self.broken = True
        result = f(self, *args, **kwargs)
        self.broken = False
        self.steps += 1
        return result

    return run  # type: ignore[return-value]  # functools.wraps' type hides the signature


def _strict_json(text: str) -> Any:
    def refuse(constant: str) -> Any:
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


def _vec(text: str) -> Vec3:
    x, y, z = (float(p) for p in text.replace(",", " ").split())
    return (x, y, z)


def _fmt(v: Vec3) -> str:
    return ", ".join(f"{x:g}" for x in v)


def _pose_form(pose: Pose, rotation_style: int) -> dict[str, str]:
    """The pose form as the page sends it; a zero rotation left out or typed."""
    t, r = pose
    form = {"x": f"{t[0]:g}", "y": f"{t[1]:g}", "z": f"{t[2]:g}"}
    if any(r) or rotation_style == 1:
        form["rotation"] = _fmt(r)
    elif rotation_style == 2:
        form["rotation"] = ""
    return form


def _replay(path: Path) -> tuple[Accepted, dict[int, tuple[Vec3, ...] | None], set[int]]:
    """The session as the analysis is handed it: per trial the accepted captures' typed
    poses (each with all its frames), each trial's ground truth, and the trials."""
    accepted: Accepted = {}
    truths: dict[int, tuple[Vec3, ...] | None] = {}
    with SessionReader(path) as reader:
        for trial in iter_trials(reader):
            truths[trial.trial] = (
                None if trial.ground_truth is None else tuple(trial.ground_truth.points_grid)
            )
            for pc in trial.poses:
                assert pc.complete, f"trial {trial.trial}: an incomplete capture is measured"
                assert len(pc.frames) == FRAMES, f"trial {trial.trial}: {len(pc.frames)} frames"
                pose = (tuple(pc.entry.t_grid), tuple(pc.entry.r_deg))
                accepted.setdefault(trial.trial, {})[pc.entry.pose] = pose  # type: ignore[assignment]
    return accepted, truths, set(truths)


def _notes(path: Path) -> tuple[dict[int, tuple[str, ...]], tuple[str, ...]]:
    with SessionReader(path) as reader:
        notes = read_notes(reader)
    return notes.by_trial, notes.session


def _recover(broken: Path, fixed: Path) -> None:
    result = CliRunner().invoke(app, ["recover", str(broken), "-o", str(fixed)])
    assert result.exit_code == 0, result.output


class _CountingSession(ConsoleSession):
    """The console's session, counting each time the recorder starts to wait for the
    page: a step is over when the recorder waits again (a note leaves ``waiting`` as it
    was, so the state alone cannot say the note was taken)."""

    waits = 0

    def update(self, **fields: Any) -> None:
        super().update(**fields)
        if fields.get("waiting"):
            with self.lock:
                self.waits += 1


class ConsoleModel(RuleBasedStateMachine):
    """The console (system under test) beside a plain model of the procedure."""

    def __init__(self) -> None:
        super().__init__()
        RUNS["examples"] += 1
        self.dir = Path(tempfile.mkdtemp(prefix="twopose-console-"))
        self.out = self.dir / "s.mcap"
        self.client: TestClient | None = None
        self.session: _CountingSession | None = None
        self.broken = False
        self.steps = 0
        self.min_steps = 0
        self.finished = False
        self.history: list[str] = []  # every request and its answer, for a failure's report
        # The model
        self.phase = "setup"
        self.waiting = ""
        self.method = ""
        self.truth: tuple[Vec3, ...] = ()
        self.trial = self.pose = self.n_poses = 0
        self.trials_begun = 0
        self.complete_trials = 0
        self.captures = 0
        self.typed: dict[int, Pose] = {}  # this trial: pose -> last typed
        # What the pose form may show: "new" (nothing), "retype" (after redo or undo: the
        # values of the pose being retyped), "revisit" (a pose typed before in this trial,
        # reached again by accepting: nothing, or its own last values)
        self.form = "new"
        self.current: tuple[Pose, str] | None = None  # the capture to decide: pose, shortfall
        self.accepted: Accepted = {}
        self.notes: dict[int, list[str]] = {}

    # -- talking to the console
    def _request(self, method: str, path: str, body: Any = None) -> httpx2.Response:
        assert self.client is not None
        try:
            answer = self.client.get(path) if method == "GET" else self.client.post(path, json=body)
        except Exception as err:  # the app raised: a 500 in a real server
            self.history.append(f"{method} {path} {body!r} -> raised {type(err).__name__}")
            raise AssertionError(
                f"{method} {path} {body!r} raised in the server: {type(err).__name__}: {err}\n"
                + "\n".join(self.history[-30:])
            ) from err
        shown = answer.text[:200] if path != "/" else answer.headers.get("content-type")
        self.history.append(f"{method} {path} {body!r} -> {answer.status_code} {shown}")
        assert answer.status_code < 500, "\n".join(self.history[-30:])
        return answer

    def _state(self) -> dict[str, Any]:
        answer = self._request("GET", "/api/state")
        assert answer.status_code == 200, answer.text
        state: dict[str, Any] = _strict_json(answer.text)
        return state

    def _post(self, path: str, body: Any, ok: bool) -> httpx2.Response:
        """POST, expecting 200 (``ok``) or a refusal (400 with a message)."""
        answer = self._request("POST", path, body)
        want = 200 if ok else 400
        assert answer.status_code == want, (
            f"{path} {body!r}: expected {want}, got {answer.status_code} {answer.text}\n"
            + "\n".join(self.history[-30:])
        )
        if not ok:
            assert _strict_json(answer.text)["error"]
        return answer

    def _settle(self, since: int) -> dict[str, Any]:
        """Wait until the recorder is where the model is (it waits again for the page
        after the step, or the session is finished); a timeout fails the test."""
        assert self.session is not None
        deadline = time.monotonic() + TIMEOUT_S
        while True:
            state = self._state()
            assert state["phase"] != "failed", f"the recording failed: {state['message']}"
            if self.phase == "done":
                if state["phase"] == "done":
                    return state
            elif (state["phase"], state["waiting"]) == (self.phase, self.waiting) and (
                self.session.waits > since
            ):
                return state
            assert time.monotonic() < deadline, (
                f"the console never got to {self.phase}/{self.waiting} in {TIMEOUT_S} s; "
                f"it shows {state['phase']}/{state['waiting']!r}: {state['message']}\n"
                + "\n".join(self.history[-30:])
            )
            time.sleep(0.01)

    @property
    def _waits(self) -> int:
        assert self.session is not None
        return self.session.waits

    # -- setup
    @initialize(
        method=st.sampled_from(["point", "line", "ground"]),
        truth=st.sampled_from(["none", "truth", "keep_off_ground"]),
        units=st.sampled_from(["in", "cm"]),
        refused=st.none() | st.integers(0, 100),
        operator=st.sampled_from(["Ada", "", "Zoë Ó'Brien"]),
        n_poses=st.integers(2, 3),
        min_steps=st.integers(0, 20),
    )
    @_step
    def set_up(
        self,
        method: str,
        truth: str,
        units: str,
        refused: int | None,
        operator: str,
        n_poses: int,
        min_steps: int,
    ) -> None:
        """Start the console, load the page, send a refused form (maybe), then a good one."""
        self.min_steps, self.n_poses = min_steps, n_poses
        scene = self.dir / "scene.toml"
        scene.write_text(SMALL_SCENE)
        given: dict[str, Any] = {
            "method": None, "units": None, "intrinsics": None, "intrinsics_sigma": {},
            "focal": None, "principal": None, "ground_height": None, "ground_truth": [],
            "operator": None,
        }  # fmt: skip
        options = ConsoleOptions(
            source=f"synthetic:{scene}", given=given, frames=FRAMES, poses=n_poses, size=SIZE
        )
        self.session = _CountingSession(self.out, dict(given, size=SIZE))
        self.client = TestClient(console_app(self.session, options), base_url=HOST)
        self.client.__enter__()
        self._reload()
        assert self._state()["phase"] == "setup"
        form = {
            "method": method, "units": units, "focal": FOCAL, "principal": PRINCIPAL,
            "ground_height": "9.625", "truth1": "", "truth2": "", "keep_off_ground": "",
            "operator": operator,
        }  # fmt: skip
        if truth != "none":
            form |= dict(zip(("truth1", "truth2"), TRUTH[method], strict=False))
        if truth == "keep_off_ground" and method == "ground":
            form |= {"truth1": OFF_GROUND, "keep_off_ground": "on"}
        if refused is not None:
            bad = (*BAD_SETUPS, *BAD_FOR[method])
            self._post("/api/setup", form | bad[refused % len(bad)], ok=False)
            assert self._state()["phase"] == "setup"
        self._post("/api/setup", form, ok=True)
        self.method = method
        self.truth = tuple(_vec(form[k]) for k in ("truth1", "truth2") if form[k])
        if method != "line":
            self.truth = self.truth[:1]
        self.phase, self.waiting, self.trial, self.pose = "recording", "pose", 1, 1
        self.trials_begun = 1
        state = self._settle(0)
        assert (state["method"], state["units"]) == (method, units)

    def _reload(self) -> None:
        answer = self._request("GET", "/")
        assert answer.status_code == 200
        assert answer.headers["content-type"].startswith("text/html")

    def _ending_allowed(self) -> bool:
        return not self.finished and self.steps >= self.min_steps

    # -- the operator's events
    @precondition(lambda self: not self.finished)
    @rule(setup=st.sampled_from([{"method": "point"}, {"method": "line", "truth1": "1, 2"}]))
    @_step
    def set_up_again(self, setup: dict[str, str]) -> None:
        """A setup once the session runs is refused, whatever it says."""
        self._post("/api/setup", setup, ok=False)

    @precondition(lambda self: not self.finished)
    @rule(
        centre=st.sampled_from(ON_TARGET),
        rotation=st.sampled_from(ROTATIONS),
        rotation_style=st.integers(0, 2),
    )
    @_step
    def type_pose_on_target(self, centre: Vec3, rotation: Vec3, rotation_style: int) -> None:
        self._type_pose((centre, rotation), rotation_style, "ok")

    @precondition(lambda self: not self.finished)
    @rule(pose=st.sampled_from(OFF_TARGET))
    @_step
    def type_pose_looking_away(self, pose: Pose) -> None:
        """The target is in none of the frames: accept is refused, redo or undo it."""
        self._type_pose(pose, 0, "none")

    @precondition(lambda self: not self.finished and bool(self.typed))
    @rule(rotation_style=st.integers(0, 2))
    @_step
    def type_the_previous_pose_again(self, rotation_style: int) -> None:
        """The same pose typed twice in a trial (no baseline between them)."""
        earlier = self.typed.get(self.pose - 1) or self.typed[max(self.typed)]
        off = earlier in OFF_TARGET
        self._type_pose(earlier, rotation_style, "none" if off else "ok")

    @precondition(lambda self: not self.finished)
    @rule(form=st.sampled_from(BAD_POSES))
    @_step
    def type_a_refused_pose(self, form: dict[str, str]) -> None:
        """Out of range, not a number, missing: refused, and nothing changes."""
        self._post("/api/pose", form, ok=False)

    def _type_pose(self, pose: Pose, rotation_style: int, shortfall: str) -> None:
        """Type the pose and capture it (the form's button does both)."""
        waiting = self.phase == "recording" and self.waiting == "pose"
        since = self._waits
        self._post("/api/pose", _pose_form(pose, rotation_style), ok=waiting)
        if not waiting:
            return
        if self.pose == 1 and self.trial > self.trials_begun:
            self.trials_begun = self.trial
        self.typed[self.pose] = pose
        self.current, self.waiting = (pose, shortfall), "decision"
        self.captures += 1
        RUNS["captures"] += 1
        RUNS["none_found"] += shortfall == "none"
        state = self._settle(since)
        assert state["shortfall"] == shortfall, (pose, state["shortfall"], state["frames"])
        assert state["capture"]["n_frames"] == FRAMES

    @precondition(lambda self: not self.finished)
    @rule(decision=st.sampled_from(["accept", "accept_anyway", "redo", "undo", "later"]))
    @_step
    def decide(self, decision: str) -> None:
        deciding = self.phase == "recording" and self.waiting == "decision"
        ok = deciding and decision in ("accept", "accept_anyway", "redo", "undo")
        if ok and decision == "undo":
            ok = self.pose > 1  # nothing to undo at the trial's first pose
        if ok and decision.startswith("accept"):
            assert self.current is not None
            shortfall = self.current[1]
            ok = shortfall == "ok" or (shortfall == "few" and decision == "accept_anyway")
        since = self._waits
        self._post("/api/decide", {"decision": decision}, ok=ok)
        if not ok:
            if deciding and decision != "later":  # refused next to the button pressed
                assert self._state()["refusal"].get("control") == decision
            return
        assert self.current is not None
        if decision.startswith("accept"):
            self.accepted.setdefault(self.trial, {})[self.pose] = self.current[0]
            if self.pose == self.n_poses:  # the trial is complete: the next one waits
                self.complete_trials += 1
                self.trial, self.pose, self.typed = self.trial + 1, 1, {}
            else:
                self.pose += 1
            self.form = "revisit" if self.pose in self.typed else "new"
        elif decision == "redo":
            self.form = "retype"
        else:
            del self.accepted[self.trial][self.pose - 1]
            self.pose -= 1
            self.form = "retype"
        self.current, self.waiting = None, "pose"
        self._settle(since)

    @precondition(lambda self: not self.finished)
    @rule(text=NOTE_TEXT)
    @_step
    def note(self, text: str) -> None:
        ok = self.phase == "recording" and self.waiting == "decision" and bool(text.strip())
        since = self._waits
        self._post("/api/note", {"text": text}, ok=ok)
        if ok:
            self.notes.setdefault(self.trial, []).append(text.strip())
            self._settle(since)

    @precondition(lambda self: not self.finished)
    @rule()
    @_step
    def reload(self) -> None:
        """The operator reloads the page: it loads, and the state is still the truth."""
        self._reload()

    @precondition(lambda self: self._ending_allowed())
    @rule()
    @_step
    def quit(self) -> None:
        ok = self.phase == "recording"
        self._post("/api/decide", {"decision": "quit"}, ok=ok)
        if ok:
            self.phase, self.waiting, self.current = "done", "", None
            self._settle(self._waits)

    @precondition(lambda self: not self.finished and self.out.exists())
    @rule()
    @_step
    def kill_9_now(self) -> None:
        """What a kill -9 would leave now: the file as it is on disk, closed by recover,
        holds exactly what was accepted so far."""
        copy, fixed = self.dir / "copy.mcap", self.dir / "fixed.mcap"
        copy.unlink(missing_ok=True)
        fixed.unlink(missing_ok=True)
        shutil.copyfile(self.out, copy)
        _recover(copy, fixed)
        RUNS["recovered"] += 1
        replayed, _, _ = _replay(fixed)
        assert replayed == self._accepted(), "\n".join(self.history[-30:])

    @precondition(lambda self: self._ending_allowed())
    @rule(quit_first=st.booleans())
    @_step
    def stop_the_server(self, quit_first: bool) -> None:
        """Quit (or not), stop the server, and check the file it leaves."""
        if quit_first and self.phase == "recording":
            self._post("/api/decide", {"decision": "quit"}, ok=True)
            self.phase, self.waiting = "done", ""
            self._settle(self._waits)
        self._finish()

    @precondition(lambda self: self.finished)
    @rule()
    @_step
    def read_again(self) -> None:
        """After the end, the file reads the same every time (and a session stopped
        before its first capture stays without one)."""
        if self.captures == 0:
            assert not self.out.exists()
            return
        assert _replay(self.out)[0] == self._accepted()

    # -- the invariant
    @invariant()
    def the_state_is_json_and_the_truth(self) -> None:
        if self.client is None or self.finished:
            return
        state = self._state()
        assert (state["phase"], state["waiting"]) == (self.phase, self.waiting), state["message"]
        if self.phase != "recording":
            return
        assert (state["trial"], state["pose"]) == (self.trial, self.pose), state["message"]
        listed = {
            row["pose"]: (tuple(row["t"]), tuple(row["r_deg"]))
            for row in state["poses"]
            if row["state"] == "accepted"
        }
        assert listed == self.accepted.get(self.trial, {}), state["poses"]
        if self.waiting == "pose":
            form = state["pose_form"]
            shown = (tuple(form["t"]), tuple(form["r_deg"])) if "t" in form else None
            own = self.typed.get(self.pose)
            choices: dict[str, list[object]] = {
                "new": [None],
                "retype": [own],
                "revisit": [None, own],
            }
            allowed = choices[self.form]
            assert shown in allowed, (self.form, self.pose, shown, self.typed)

    # -- the end
    def _accepted(self) -> Accepted:
        return {t: dict(poses) for t, poses in self.accepted.items() if poses}

    def _finish(self) -> None:
        """Stop the server (its lifespan ends the recording), then check the file."""
        assert self.client is not None
        assert self.session is not None
        self.finished = True
        self.client.__exit__(None, None, None)
        RUNS["finished"] += 1
        if self.captures == 0:  # nothing typed: no file is left
            assert not self.out.exists()
            assert "nothing was recorded" in self.session.summary
            return
        replayed, truths, trials = _replay(self.out)
        assert replayed == self._accepted(), "\n".join(self.history[-30:])
        want_truth = self.truth or None
        assert truths == dict.fromkeys(range(1, self.trials_begun + 1), want_truth), truths
        by_trial, session_notes = _notes(self.out)
        assert by_trial == {t: tuple(n) for t, n in self.notes.items()}
        assert session_notes == ()
        fixed = self.dir / "final-recovered.mcap"  # recover takes a closed file as it is
        _recover(self.out, fixed)
        assert _replay(fixed)[0] == replayed
        result = analysis.run([self.out], None, scene=False)
        assert result.errors.empty, result.errors.to_dict("records")
        assert sorted(result.trials["trial"]) == sorted(trials)
        ok = result.trials[result.trials["status"] == "ok"]
        for trial in ok["trial"].astype(int):
            assert len(replayed.get(trial, {})) >= 2, trial
        counts = SUMMARY.search(self.session.summary)
        assert counts is not None, self.session.summary
        assert int(counts["trials"]) == self.trials_begun, self.session.summary
        assert int(counts["complete"]) == self.complete_trials, self.session.summary
        assert int(counts["captures"]) == self.captures, self.session.summary
        n_accepted = sum(len(p) for p in self.accepted.values())
        assert int(counts["accepted"]) == n_accepted, self.session.summary
        assert int(counts["discarded"]) == self.captures - n_accepted, self.session.summary

    def teardown(self) -> None:
        try:
            if self.client is not None and not self.finished:
                if self.broken:  # a step failed: only stop the server
                    self.finished = True
                    self.client.__exit__(None, None, None)
                else:
                    self._finish()
        finally:
            shutil.rmtree(self.dir, ignore_errors=True)


def _run_machine(examples: int, steps: int, *, derandomize: bool) -> dict[str, int]:
    before = dict(RUNS)
    run_state_machine_as_test(
        ConsoleModel,
        settings=settings(
            max_examples=examples,
            stateful_step_count=steps,
            deadline=None,
            derandomize=derandomize,
            database=None,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
        ),
    )
    return {k: RUNS[k] - before[k] for k in RUNS}


def _assert_it_explored(ran: dict[str, int], examples: int) -> None:
    assert ran["examples"] >= examples, ran
    assert ran["captures"] >= 10, ran
    assert ran["none_found"] > 0, ran  # captures that found nothing were made
    assert ran["recovered"] > 0, ran
    assert ran["finished"] >= examples, ran


def test_the_console_matches_its_model() -> None:
    """The default run: the same sequences every time (derandomized), so what it explores
    is known; the slow run below draws new ones."""
    ran = _run_machine(12, 50, derandomize=True)  # the quick loop's share (make test <= 5 min)
    _assert_it_explored(ran, 12)


@pytest.mark.slow
def test_the_console_matches_its_model_on_new_sequences() -> None:
    # 30 new sequences (~28 s of CI's 20 min). Fresh draws vary in how many captures they
    # reach (6 in 43 examples once, 10+ usually): draw another batch, at most two more, until
    # the exploration bound is met, so a rare draw neither fails CI nor lowers the bound.
    ran = _run_machine(30, 60, derandomize=False)
    for _ in range(2):
        if ran["captures"] >= 10 and ran["recovered"] > 0 and ran["none_found"] > 0:
            break
        more = _run_machine(30, 60, derandomize=False)
        ran = {k: ran[k] + more[k] for k in ran}
    _assert_it_explored(ran, 30)
