"""The FSW's outbox: telemetry held over a burst, published in order, nothing lost."""

from __future__ import annotations

import pytest

from fsw.transport import Outbox


def test_messages_go_out_in_the_order_emitted_when_flushed():
    out: list[tuple[str, object]] = []
    box = Outbox(lambda t, m: out.append((t, m)), limit=10)
    for i in range(7):
        box.put(f"fsw/{i % 3}", i)
    assert out == [] and box.pending == 7
    assert box.flush() == 7
    assert out == [(f"fsw/{i % 3}", i) for i in range(7)]
    assert box.pending == 0 and box.flush() == 0 and box.flushes == 1


def test_a_put_only_holds_and_full_says_when_to_flush():
    # publishing is the driver's, between measurements: a put never publishes, whatever is held
    out: list[object] = []
    flushing = [False]

    def publish(topic: str, msg: object) -> None:
        assert flushing[0], "a put published"
        out.append(msg)

    box = Outbox(publish, limit=4)
    for i in range(10):
        box.put("fsw/budget", i)
        assert box.full == (i >= 3)
    assert box.pending == 10 and box.flushes == 0 and out == []
    flushing[0] = True
    assert box.flush() == 10 and out == list(range(10)) and not box.full


def test_a_core_emitting_into_an_outbox_publishes_nothing_by_itself():
    # the core's stages emit into the outbox; none of its calls publishes (a put inside a stage
    # would charge publishing to that stage's flight budget)
    from fsw.core import FswCore
    from fsw.interface import messages as m
    from sim.stream import generate
    from tools.scenario import load_text_scenario, resolve

    cfg, seed = resolve(load_text_scenario("name: s\nsim:\n  trajectory: {span_days: 0.25}\n"))
    published: list[tuple[str, object]] = []
    box = Outbox(lambda t, msg: published.append((t, msg)), limit=8)
    core = FswCore(cfg.fsw, box.put, run_id="r")
    core.start()
    for msg in generate(cfg.sim, seed=seed).measurements[:200]:
        assert isinstance(msg, m.Measurement)
        core.ingest(msg)
    assert published == [] and box.full and box.pending > 200
    held = box.held()
    box.flush()
    assert published == held


def test_a_put_that_fails_keeps_it_and_what_follows_held():
    out: list[object] = []
    fail = {"once": True}

    def put(topic: str, msg: object) -> None:
        if msg == 2 and fail.pop("once", False):
            raise RuntimeError("link closed")
        out.append(msg)

    box = Outbox(put, limit=100)
    for i in range(5):
        box.put("fsw/weights/magill", i)
    with pytest.raises(RuntimeError):
        box.flush()
    assert out == [0, 1] and box.pending == 3
    box.flush()
    assert out == [0, 1, 2, 3, 4]


def test_an_outbox_holds_at_least_one_message():
    with pytest.raises(ValueError):
        Outbox(lambda t, m: None, limit=0)


def test_held_gives_what_is_held_and_keeps_it_held():
    out: list[tuple[str, object]] = []
    box = Outbox(lambda t, m: out.append((t, m)), limit=10)
    for i in range(3):
        box.put("fsw/budget", i)
    assert box.held() == [("fsw/budget", 0), ("fsw/budget", 1), ("fsw/budget", 2)] and out == []
    assert box.pending == 3 and box.flush() == 3 and box.held() == []
