"""The pointing panel's push stream (``GET /api/pointing``, Server-Sent Events): what the
operator's page reads, in order, and what a foreign page gets (nothing)."""

from __future__ import annotations

import json
import threading
import time
from typing import Any

from starlette.testclient import TestClient

from recorder.console.pointing_server import pointing_app
from recorder.live.pointing import Ellipse95, PointingEstimate
from recorder.live.pointing_feed import IDLE_WORDS, PointingFeed

ORIGIN = "http://127.0.0.1:8765"


def estimate(seq: int, *, ok: bool = True) -> PointingEstimate:
    """A pair's estimate as the live pointing makes it (its numbers made up)."""
    return PointingEstimate(
        seq=seq, t_capture_ns=10**12 + seq * 33_333_333, t_ns=float(10**12 + seq * 33_333_333),
        skew_ns=0, status="ok" if ok else "near_singular",
        words="ok" if ok else "near-singular: line-floor angle 3.10 deg < 10",
        point=(0.1 * seq, 8.0) if ok else None, point_3d=(0.1 * seq, 9.6, 8.0) if ok else None,
        region=Ellipse95(major=0.2, minor=0.1, angle_deg=30.0) if ok else None,
        track=((0.0, 0.1 * seq, 8.0),) if ok else (), done_ns=10**12, cpu_ns=4_000_000,
    )  # fmt: skip


def events(client: TestClient, feed: PointingFeed, act: Any) -> list[dict[str, Any]]:
    """The stream's events while ``act`` runs on a thread (the feed closed after it)."""

    def run() -> None:
        while feed.readers == 0:
            time.sleep(0.01)
        act()
        feed.close()

    thread = threading.Thread(target=run)
    thread.start()
    with client.stream("GET", "/api/pointing") as answer:
        assert answer.status_code == 200
        assert answer.headers["content-type"].startswith("text/event-stream")
        lines = [line for line in answer.iter_lines() if line.startswith("data: ")]
    thread.join()
    return [json.loads(line.removeprefix("data: ")) for line in lines]


def test_the_page_reads_the_status_then_every_pair_in_order() -> None:
    feed = PointingFeed()
    with TestClient(pointing_app(feed, threading.Event()), base_url=ORIGIN) as client:
        assert client.get("/").status_code == 200  # the page: the token's cookie set

        def act() -> None:
            feed.start({"about": "ground, seen on the floor from above (in)", "units": "in"})
            feed.publish([estimate(k) for k in range(5)] + [estimate(5, ok=False)])
            feed.stop("the cameras' streams ended")

        got = events(client, feed, act)
        clock = client.get("/api/clock").json()["t_ns"]
    assert got[0] == {"kind": "status", "running": False, "words": IDLE_WORDS,
                      "sent_ns": got[0]["sent_ns"]}  # fmt: skip
    assert got[1]["running"] is True
    pairs = [e for e in got if e["kind"] == "estimate"]
    assert [e["seq"] for e in pairs] == list(range(6))
    assert pairs[0]["region"] == {"major": 0.2, "minor": 0.1, "angle_deg": 30.0}
    assert pairs[5]["point"] is None
    assert pairs[5]["region"] is None
    assert pairs[5]["words"].startswith("near-singular")
    assert got[-1] == {**got[1], "running": False, "words": "the cameras' streams ended",
                       "sent_ns": got[-1]["sent_ns"]}  # fmt: skip
    sent = [e["sent_ns"] for e in got]
    assert sent == sorted(sent)
    assert sent[-1] <= clock  # one monotonic clock


def test_a_reader_that_falls_behind_is_told_how_many_it_missed() -> None:
    feed = PointingFeed(capacity=4)
    feed.publish([estimate(k) for k in range(3)])
    seen, first, missed = feed.after(0, 0.1)
    assert (seen, [m["seq"] for m in first], missed) == (3, [0, 1, 2], 0)
    feed.publish([estimate(k) for k in range(3, 10)])
    seen, later, missed = feed.after(3, 0.1)
    assert (seen, [m["seq"] for m in later], missed) == (10, [6, 7, 8, 9], 3)
    assert feed.after(10, 0.05) == (10, [], 0)  # nothing new: the wait ends empty


def test_a_foreign_page_gets_nothing_of_the_stream() -> None:
    feed = PointingFeed()
    with TestClient(pointing_app(feed, threading.Event()), base_url=ORIGIN) as client:
        client.get("/")  # the operator's page: its cookie
        stranger = TestClient(client.app, base_url=ORIGIN)  # another site: no cookie
        for path in ("/api/pointing", "/api/clock"):
            assert stranger.get(path).status_code == 403
            for origin in ("http://evil.example:8765", "null", "http://127.0.0.1:9999"):
                assert client.get(path, headers={"Origin": origin}).status_code == 403
            for site in ("cross-site", "same-site"):
                assert client.get(path, headers={"Sec-Fetch-Site": site}).status_code == 403
            assert client.get(path, headers={"Host": "rebind.evil.example:8765"}).status_code == 403
        assert feed.readers == 0  # no stream was opened for any of them
