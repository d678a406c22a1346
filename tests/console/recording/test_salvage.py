"""A damaged recording is replayed chunk by chunk (console/recording/salvage.py, replay.py, `replay --salvage`):
one flipped byte in a compressed chunk, a damaged chunk header, a damaged summary, a cut-off end; what is
readable is replayed and the loss is said in seconds."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from console.recording import recording_schemas as rs
from console.recording.replay import Recording, ReplayError

T0 = 1_700_000_000_000_000_000  # [ns]
STEP = 250_000_000  # a progress message every 0.25 s
N = 381  # 0 .. 95.0 s


def _progress(k: int) -> bytes:
    return json.dumps({"state": "running", "segment": k // 40, "fraction": (k % 40) / 40,
                       "message": f"step {k:04d} " + "x" * 200}).encode()


def write_recording(path: Path, chunk_size: int = 2400) -> Path:
    """A 95 s MorphoNavi recording: the session info, then a progress message every 0.25 s, LZ4 chunks."""
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=chunk_size, compression=CompressionType.LZ4)
        w.start(profile="", library="test")
        channels = {}
        for topic in (rs.SESSION_INFO, rs.PROGRESS):
            sid = w.register_schema(topic, "jsonschema", b'{"type":"object"}')
            channels[topic] = w.register_channel(topic, "json", sid)
        info = {"workspace": {"min": [0, 0, 0], "max": [4, 4, 3], "resolution": 0.1}, "margin": 0.3, "start": [1, 1, 0]}
        w.add_message(channels[rs.SESSION_INFO], log_time=T0, data=json.dumps(info).encode(), publish_time=T0)
        for k in range(N):
            w.add_message(channels[rs.PROGRESS], log_time=T0 + k * STEP, data=_progress(k), publish_time=T0 + k * STEP)
        w.finish()
    return path


def _chunks(path: Path) -> list:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)


def _flip(path: Path, offset: int, out: Path) -> Path:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0xFF
    out.write_bytes(bytes(data))
    return out


def _data_offset(c) -> int:
    """A byte in the middle of a chunk's compressed records."""
    return c.chunk_start_offset + c.chunk_length - c.compressed_size // 2 - 1


@pytest.fixture(scope="module")
def good(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_recording(tmp_path_factory.mktemp("salvage") / "run.mcap")


@pytest.mark.parametrize("chunk", [0, 3, 17, 30])
def test_any_single_flipped_byte_in_a_chunk_is_caught(good: Path, tmp_path: Path, chunk: int) -> None:
    # LZ4 decodes some flips silently (a changed literal): the chunk's CRC still catches them
    c = _chunks(good)[chunk]
    path = _flip(good, _data_offset(c), tmp_path / "flip.mcap")
    with pytest.raises(ReplayError, match="corrupt MCAP file"):
        Recording(path)
    rec = Recording(path, salvage=True)
    assert rec.salvage_note.startswith(f"1 of {len(_chunks(good))} chunks unreadable: "), rec.salvage_note
    assert rec.count(rs.PROGRESS) < N and rec.info is not None  # the channels come from the summary if need be
    # chunk 0 held the session's settings: replayed in the default workspace, said so
    assert ("the session's settings were lost with them" in rec.salvage_note) == (chunk == 0)


def test_one_flipped_byte_loses_only_its_chunk(good: Path, tmp_path: Path) -> None:
    chunks = _chunks(good)
    assert 30 <= len(chunks) <= 60, len(chunks)
    bad = [chunks[5], chunks[20]]
    path = _flip(good, _data_offset(bad[0]), tmp_path / "one.mcap")
    path = _flip(path, _data_offset(bad[1]), tmp_path / "two.mcap")
    with pytest.raises(ReplayError, match=r"corrupt MCAP file \(.*\); --salvage replays what is readable"):
        Recording(path)
    full, rec = Recording(good), Recording(path, salvage=True)
    assert rec.salvaged and not full.salvaged
    lost = sum((c.message_end_time - c.message_start_time) for c in bad) / 1e9
    note = rec.salvage_note
    assert note == f"2 of {len(chunks)} chunks unreadable: {lost:.1f} s of 95.0 s lost", note
    # the readable chunks are all there, the lost ones are not, and the rest replays as recorded
    lost_times = {t for c in bad for t in full.times(rs.PROGRESS) if c.message_start_time <= t <= c.message_end_time}
    assert set(rec.times(rs.PROGRESS)) == set(full.times(rs.PROGRESS)) - lost_times and lost_times
    for t in (T0 + 3 * STEP, T0 + 300 * STEP, rec.end):
        assert rec.state_at(t).run == full.state_at(t).run
    assert rec.start == full.start and rec.end == full.end


def test_a_damaged_chunk_header_and_a_damaged_summary(good: Path, tmp_path: Path) -> None:
    chunks = _chunks(good)
    full = Recording(good)
    # the length field of chunk 7: the ordinary reader jumps to chunks by the summary's index and reads it all
    header = _flip(good, chunks[7].chunk_start_offset + 3, tmp_path / "header.mcap")
    assert Recording(header, salvage=True).count(rs.PROGRESS) == N
    # with the summary damaged too, the framing is lost at chunk 7: the walk scans for the next chunk header
    data = bytearray(header.read_bytes())
    data[chunks[-1].chunk_start_offset + chunks[-1].chunk_length + 20] ^= 0xFF  # in the summary section
    data[-8 - 29 + 9] ^= 0xFF  # the footer's summary start
    both = tmp_path / "both.mcap"
    both.write_bytes(bytes(data))
    with pytest.raises(ReplayError, match="corrupt MCAP file"):
        Recording(both)
    rec = Recording(both, salvage=True)
    lost = {t for t in full.times(rs.PROGRESS) if chunks[7].message_start_time <= t <= chunks[7].message_end_time}
    assert set(rec.times(rs.PROGRESS)) == set(full.times(rs.PROGRESS)) - lost
    # its span is the gap between the chunks around it (a little more than its own)
    span = (chunks[8].message_start_time - chunks[6].message_end_time) / 1e9
    assert rec.salvage_note == f"1 of {len(chunks)} chunks unreadable: {span:.1f} s of 95.0 s lost", rec.salvage_note


def test_a_cut_off_file_says_it_ends_early(good: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(good.read_bytes()[: int(good.stat().st_size * 0.6)])
    with pytest.raises(ReplayError, match="truncated"):
        Recording(cut)
    rec = Recording(cut, salvage=True)
    assert "the file ends early (not finished)" in rec.salvage_note
    assert 0 < rec.count(rs.PROGRESS) < N


def test_replay_salvage_prints_what_was_lost(good: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from console.cli.morphonavi import main
    from console.cli.replay_cmd import open_replay

    chunks = _chunks(good)
    path = _flip(good, _data_offset(chunks[3]), tmp_path / "flipped.mcap")
    with pytest.raises(ReplayError):  # (checked first: a replay that opens would serve until stopped)
        Recording(path)
    assert main(["replay", str(path), "--port", "0"]) == 2  # refused without --salvage, naming it
    err = capsys.readouterr().err
    assert "corrupt MCAP file" in err and "--salvage" in err and "Traceback" not in err
    app = open_replay(path, port=0, salvage=True)
    try:
        assert app.recording.salvage_note.startswith(f"1 of {len(chunks)} chunks unreadable: ")
        app.seek(app.recording.duration)
        assert app.session.run.message.startswith("step 0380")
    finally:
        app.stop()
