"""Zenoh transport of the ICD: every navbank process talks through this package.

The measured Zenoh pitfalls (NOTES-zenoh-mcap.md) are handled once, each in the module of its job:

* :mod:`~fsw.transport.session` — joining the network: loopback peers, failed connects as
  errors, the mesh of a local run (:class:`TransportConfig`, :func:`open_session`, :func:`mesh_configs`);
* :mod:`~fsw.transport.credentials` — a run's credentials (checked when loaded) and the mutual
  TLS and access-control list they configure;
* :mod:`~fsw.transport.wire` — what a sample carries: JSON with the schema name, a sequence number;
* :mod:`~fsw.transport.pubsub` — typed publishers (RELIABLE, BLOCK) and bounded-FIFO subscribers
  that count gaps and serve a progress queryable;
* :mod:`~fsw.transport.flow` — readiness, credit windows and the end-of-stream drain;
* :mod:`~fsw.transport.commands` — the telecommand queryable and its sender;
* :mod:`~fsw.transport.outbox` — telemetry held over a burst of input and published back to back;
* :mod:`~fsw.transport.lifecycle` — the steps every process goes through, in their order.

``from fsw import transport as tp`` then ``tp.Publisher(...)``: the public names are here.
"""

from fsw.transport.commands import CommandServer, declare_command_server, send_command, send_command_payload
from fsw.transport.credentials import CredentialsError, RunCredentials, load_credentials
from fsw.transport.flow import (COMPLETE, INCARNATION, PROGRESS, RESUMED_FROM, ROLES, ConsumerRestarted, CreditWindow,
                                drain, query_progress, wait_for_consumers)
from fsw.transport.lifecycle import REPLY_LINGER_S, ProcessLifecycle, StopFlag
from fsw.transport.outbox import Outbox
from fsw.transport.pubsub import Publisher, Received, Subscriber, TopicPublisher, end_of_run_counts
from fsw.transport.session import TransportConfig, TransportError, free_tcp_ports, mesh_configs, open_session, zenoh_config
from fsw.transport.wire import sequence_attachment

__all__ = [
    "COMPLETE",
    "INCARNATION",
    "PROGRESS",
    "RESUMED_FROM",
    "REPLY_LINGER_S",
    "ROLES",
    "CommandServer",
    "ConsumerRestarted",
    "CreditWindow",
    "CredentialsError",
    "RunCredentials",
    "load_credentials",
    "Outbox",
    "ProcessLifecycle",
    "StopFlag",
    "TopicPublisher",
    "Publisher",
    "Received",
    "Subscriber",
    "TransportConfig",
    "TransportError",
    "declare_command_server",
    "drain",
    "end_of_run_counts",
    "free_tcp_ports",
    "mesh_configs",
    "open_session",
    "query_progress",
    "send_command",
    "send_command_payload",
    "sequence_attachment",
    "wait_for_consumers",
    "zenoh_config",
]
