"""The Zenoh options shared by `navbank sim`, `fsw`, `ground log` and `replay`."""

from __future__ import annotations

import argparse

from fsw.transport import TransportConfig
from tools.commands.transport_args import add_transport_arguments, transport_config_from_args


def _parse(*argv: str) -> TransportConfig:
    p = argparse.ArgumentParser()
    add_transport_arguments(p)
    return transport_config_from_args(p.parse_args(list(argv)))


def test_cli_arguments_round_trip():
    cfg = _parse("--connect", "tcp/127.0.0.1:7447", "--no-gossip")
    assert cfg.connect == ("tcp/127.0.0.1:7447",) and not cfg.gossip and cfg.listen == ("tcp/127.0.0.1:0",)


def test_no_options_give_the_default_configuration():
    assert _parse() == TransportConfig()


def test_client_mode_listen_and_timeout():
    cfg = _parse("--client", "--connect", "tcp/127.0.0.1:7447", "--listen", "tcp/127.0.0.1:7500",
                 "--listen", "tcp/127.0.0.1:7501", "--connect-timeout", "2.5", "--zenoh-config", "z.json5")
    assert cfg.mode == "client" and cfg.listen == ("tcp/127.0.0.1:7500", "tcp/127.0.0.1:7501")
    assert cfg.connect_timeout_s == 2.5 and cfg.config_file == "z.json5"
