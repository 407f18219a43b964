"""Flat numeric channels for Foxglove's Plot panel: one number per field, no nested arrays; names
in topics and fields are reduced to letters, digits and '_' so message paths need no quoting.

* ``/plot/residuals/<kind>/<source>``: the normalised pre-fit residual of every filter (``<filter>``
  for one-component kinds, ``<filter>_<k>`` otherwise), one message per measurement;
* ``/plot/bplane/<filter>``: B·R, B·T, their 1σ and the closest-approach σ;
* ``/plot/position_error/<label>``: estimate minus truth in km and the 3σ of the estimate, at
  the epochs where both exist.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import msgspec

from ground.foxglove.records import ChannelSchema, FoxgloveRecord, json_schema

_NUMBER = {"type": "number"}
RESIDUAL_SCHEMA = json_schema("navbank.plot.NormalisedResidual", {"t_s": _NUMBER})
BPLANE_SCHEMA = json_schema("navbank.plot.BPlane", {k: _NUMBER for k in (
    "t_s", "b_dot_r_km", "b_dot_t_km", "b_dot_r_sigma_km", "b_dot_t_sigma_km", "periapsis_sigma_s")})
ERROR_SCHEMA = json_schema("navbank.plot.PositionError", {k: _NUMBER for k in (
    "t_s", "x_km", "y_km", "z_km", "norm_km", "three_sigma_km")})
_ENCODE = msgspec.json.Encoder().encode
_TRUTH_KEPT = 64  # truth samples kept to pair with estimates (estimates come at most a few frames late)


def _rec(topic: str, schema: ChannelSchema, fields: dict[str, float], log_ns: int) -> FoxgloveRecord:
    # msgspec writes the same numbers as json.dumps (shortest round-trip digits; small ones without
    # an exponent) about twenty times faster: one plot message per measurement
    return FoxgloveRecord(topic, schema, _ENCODE(fields), log_ns)


@lru_cache(maxsize=4096)
def _safe(name: str) -> str:
    """A name Foxglove's message paths take unquoted (letters, digits, '_'), e.g. DSS-14 → DSS_14."""
    return "".join(c if c.isalnum() or c == "_" else "_" for c in name)


class PlotBuilder:
    def __init__(self) -> None:
        self._truth: dict[float, tuple[float, ...]] = {}

    def residuals(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        filters = msg.get("filters", [])
        out = []
        for s in msg.get("samples", []):
            fields: dict[str, float] = {"t_s": float(s["t_s"])}
            for name, row in zip(filters, s["normalised"]):
                if len(row) == 1:
                    fields[_safe(name)] = float(row[0])
                else:
                    fields.update({f"{_safe(name)}_{k}": float(v) for k, v in enumerate(row)})
            out.append(_rec(f"/plot/residuals/{_safe(s['kind'])}/{_safe(s['source'])}", RESIDUAL_SCHEMA, fields, log_ns))
        return out

    def bplane(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        cov = msg["covariance_km2"]
        fields = {"t_s": float(msg["t_s"]), "b_dot_r_km": float(msg["b_dot_r_km"]), "b_dot_t_km": float(msg["b_dot_t_km"]),
                  "b_dot_r_sigma_km": math.sqrt(max(float(cov[0][0]), 0.0)),
                  "b_dot_t_sigma_km": math.sqrt(max(float(cov[1][1]), 0.0)),
                  "periapsis_sigma_s": float(msg["periapsis_sigma_s"])}
        return [_rec(f"/plot/bplane/{_safe(msg['filter'])}", BPLANE_SCHEMA, fields, log_ns)]

    def truth(self, msg: dict[str, Any]) -> None:
        self._truth[float(msg["t_s"])] = tuple(float(v) for v in msg["position_km"])
        while len(self._truth) > _TRUTH_KEPT:
            del self._truth[next(iter(self._truth))]

    def estimate(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        truth = self._truth.get(float(msg["t_s"]))
        if truth is None:
            return []
        d = [float(e) - t for e, t in zip(msg["position_km"], truth)]
        fields = {"t_s": float(msg["t_s"]), "x_km": d[0], "y_km": d[1], "z_km": d[2],
                  "norm_km": math.sqrt(sum(v * v for v in d)), "three_sigma_km": 3.0 * float(msg["position_sigma_km"])}
        return [_rec(f"/plot/position_error/{_safe(msg['filter'])}", ERROR_SCHEMA, fields, log_ns)]
