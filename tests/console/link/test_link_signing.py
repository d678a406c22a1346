"""MAVLink 2 signing: a vehicle that requires signed messages (GCS_Signing.cpp: unsigned ones ignored)
is named as such when the console has no key; with --mavlink-key the console signs and is obeyed; a
wrong key is named too."""

from __future__ import annotations

import argparse

import pytest

from console.link.base import RunStatus
from console.link.mavlink import MavlinkConfig
from mav_emulator_events import use_mavlink2
from mav_helpers import config, eventually, vehicle
from planner.mission import MissionSegment, SegmentKind

KEY = "morphonavi test key"


@pytest.fixture(autouse=True)
def _mavlink2() -> None:
    use_mavlink2()  # signing is MAVLink 2 (ArduPilot speaks it by default)


def _takeoff(link):
    return link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))


def test_a_vehicle_requiring_signing_is_named_when_the_console_has_no_key() -> None:
    with vehicle(config(retries=1), faults={"signing_passphrase": KEY}) as (link, emu):
        assert eventually(lambda: any("signing required: set a key with --mavlink-key" in w
                                      for w in link.latest_state().warnings))
        run = _takeoff(link)
        assert run.wait(60.0) is RunStatus.FAILED
        print("said:", run.error)
        assert "no COMMAND_ACK" in run.error and "signing required: the vehicle signs its messages and ignores " \
               "unsigned commands: set a key with --mavlink-key" in run.error, run.error
        assert emu.record.unsigned_ignored > 0 and emu.mode == "STABILIZE"


def test_with_the_key_the_console_signs_and_the_vehicle_obeys() -> None:
    with vehicle(config(signing_key=KEY), faults={"signing_passphrase": KEY}) as (link, emu):
        ignored = emu.record.unsigned_ignored
        run = _takeoff(link)
        assert run.wait(60.0) is RunStatus.DONE, run.error
        assert emu.record.unsigned_ignored == ignored  # everything we sent was signed
        assert not any("signing required" in w for w in link.latest_state().warnings)


def test_a_wrong_key_is_named() -> None:
    with vehicle(config(retries=1, signing_key="not the vehicle's key"), faults={"signing_passphrase": KEY}) \
            as (link, emu):
        run = _takeoff(link)
        assert run.wait(60.0) is RunStatus.FAILED
        assert "signing key mismatch" in run.error and "--mavlink-key" in run.error, run.error


def test_the_key_is_configured_on_the_cli_and_validated() -> None:
    from console.cli.console_cmd import add_console_parser, link_options

    parser = argparse.ArgumentParser()
    add_console_parser(parser.add_subparsers())
    args = parser.parse_args(["console", "--robot", "mavlink:udpin:127.0.0.1:14550", "--mavlink-key", KEY])
    assert link_options(args)["config"].signing_key == KEY
    with pytest.raises(SystemExit):
        parser.parse_args(["console", "--robot", "mavlink:udpin:127.0.0.1:14550", "--mavlink-key", " "])
    with pytest.raises(ValueError, match="signing_key"):
        MavlinkConfig(signing_key="")
    from console.link.mavlink_transport import signing_secret
    assert signing_secret("ab" * 32) == bytes.fromhex("ab" * 32) and len(signing_secret(KEY)) == 32
