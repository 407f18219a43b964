"""JsonRecord: renamed and omitted keys around fsw.interface.typed's decoding."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import pytest

from fsw.interface.typed import DecodeError, spec
from ground.report.json_record import JsonRecord


@dataclass(frozen=True)
class Verdict(JsonRecord):
    _json_keys: ClassVar[dict[str, str]] = {"verdict_class": "class"}
    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"note"})

    verdict_class: str = spec(doc="class")
    score: float | None = spec(None, doc="score")
    note: str | None = spec(None, doc="note")


def test_keyword_keys_and_omitted_fields():
    assert Verdict.from_json({"class": "dynamics"}) == Verdict("dynamics")
    assert Verdict("dynamics").to_json() == {"class": "dynamics", "score": None}
    assert Verdict("none", 1.0, "late").to_json() == {"class": "none", "score": 1.0, "note": "late"}


def test_unknown_and_wrong_keys_are_refused():
    with pytest.raises(DecodeError, match="^class: expected a value"):
        Verdict.from_json({"score": 1.0})
    with pytest.raises(DecodeError, match="^class: expected a string"):
        Verdict.from_json({"class": 3})
    with pytest.raises(DecodeError, match="extra"):
        Verdict.from_json({"class": "none", "extra": 1})
