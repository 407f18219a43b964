"""Foxglove's view of a run: well-known-schema channels made on the ground from the ICD messages.

The ICD channels (JSON + JSON Schema) stay the record; :class:`~ground.foxglove.view.FoxgloveView`
adds, from the same messages, a 3-D scene in metres (``foxglove.SceneUpdate``,
``foxglove.FrameTransform``), status and anomaly events as ``foxglove.Log`` and flat numeric
channels for the Plot panel. The schemas and encodings come from the ``foxglove-sdk`` package.
"""
