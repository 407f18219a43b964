"""Declared records whose JSON form has keys Python cannot name, or keys written only when set.

The run summary and the campaign rows were first written as dictionaries: some keys are Python
keywords (``class``) and some appear only when they mean something (``latency_day`` only for a
detection, ``run_id`` only on a ``navbank run`` summary). A :class:`JsonRecord` keeps that exact
JSON form, key order included, while the code reads attributes: ``_json_keys`` maps a field to
its JSON key, ``_omit_when_none`` names the fields left out of the JSON while they are None.
Decoding and validation are :func:`fsw.interface.typed.decode`'s.
"""

from __future__ import annotations

from typing import Any, ClassVar

from fsw.interface import typed


class JsonRecord:
    """Mixin of a frozen dataclass declared with :func:`fsw.interface.typed.spec`."""

    _json_keys: ClassVar[dict[str, str]] = {}
    _omit_when_none: ClassVar[frozenset[str]] = frozenset()

    @classmethod
    def _typed_decode(cls, data: Any, path: str) -> Any:
        if isinstance(data, dict) and cls._json_keys:
            field_of = {key: name for name, key in cls._json_keys.items()}
            data = {field_of.get(k, k): v for k, v in data.items()}
        try:
            return typed.decode(cls, data, path)
        except typed.DecodeError as exc:
            raise cls._in_json_terms(exc, path) from None

    @classmethod
    def _in_json_terms(cls, exc: typed.DecodeError, path: str) -> typed.DecodeError:
        # an error names the file's key (``class``), not the field that holds it
        for name, key in cls._json_keys.items():
            at = f"{path}.{name}" if path else name
            if exc.path == at or exc.path.startswith((at + ".", at + "[")):
                json_at = f"{path}.{key}" if path else key
                return typed.DecodeError(json_at + exc.path[len(at):], exc.expected, exc.got)
        return exc

    def _typed_encode(self, drop_defaults: bool) -> dict:
        out = {}
        for name, value in typed.encode(self, drop_defaults=drop_defaults).items():
            if value is None and name in self._omit_when_none:
                continue
            out[self._json_keys.get(name, name)] = value
        return out

    @classmethod
    def from_json(cls, data: Any) -> Any:
        """The record of JSON-like ``data`` (:class:`fsw.interface.typed.DecodeError` if it does not fit)."""
        return cls._typed_decode(data, "")

    def to_json(self) -> dict:
        """The JSON-like form, keys in declaration order (what the files hold)."""
        return self._typed_encode(False)
