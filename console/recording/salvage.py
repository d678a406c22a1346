"""Read what is readable of a damaged MCAP file, chunk by chunk, and say what was lost.

One flipped byte in a compressed chunk makes the LZ4 frame (or its CRC) fail, and a reader that reads
the file as one stream refuses the whole file. :func:`salvage` instead walks the data section record
by record with the ``mcap`` library's record classes:

- each Chunk is decompressed and its CRC checked on its own (:func:`mcap.stream_reader.breakup_chunk`);
  a chunk that fails is counted with its time span and skipped;
- a record whose framing is damaged (a length that runs past the file) is skipped by jumping to the
  next chunk: its offset from the summary's chunk index when the summary is readable, else the next
  byte position where a plausible chunk header starts;
- schemas and channels come from the chunks and, when readable, from the summary section (so the
  messages of a good chunk are decoded even when the chunk that first declared their channel is lost);
- a file without a footer (a console that was killed) is read up to where it ends.

The result is the readable messages in log-time order (the index the reader rebuilds from them) and
a :class:`SalvageReport`: chunks found, chunks unreadable, the recording's time span and the time lost
(the union of the unreadable chunks' spans), e.g. ``2 of 40 chunks unreadable: 12.3 s of 95.0 s lost``.
Times are nanoseconds since the epoch (MCAP log times).
"""

from __future__ import annotations

import mmap
import struct
from dataclasses import dataclass, field
from io import BytesIO
from typing import Any, BinaryIO

MAGIC = b"\x89MCAP0\r\n"
_CHUNK, _DATA_END, _FOOTER, _SCHEMA, _CHANNEL, _MESSAGE = 0x06, 0x0F, 0x02, 0x03, 0x04, 0x05
_COMPRESSIONS = ("", "lz4", "zstd")
_FOOTER_LEN = 1 + 8 + 8 + 8 + 4  # opcode, length, summary_start, summary_offset_start, summary_crc


@dataclass
class SalvageReport:
    """What a salvage read found.

    Attributes:
        chunks: Chunks in the file (found in the data section, or listed by its summary).
        bad_chunks: ``(start ns, end ns, why)`` of every chunk that could not be read.
        start, end: First and last message time of the whole file [ns] (readable or not), 0 if none.
        truncated: The file has no footer (it was not finished).
        skipped_bytes: Bytes of damaged framing jumped over to reach the next chunk.
    """

    chunks: int = 0
    bad_chunks: list[tuple[int, int, str]] = field(default_factory=list)
    start: int = 0
    end: int = 0
    truncated: bool = False
    skipped_bytes: int = 0

    @property
    def span_s(self) -> float:
        """The recording's length [s]."""
        return max(0.0, (self.end - self.start) / 1e9)

    @property
    def lost_s(self) -> float:
        """Time covered by unreadable chunks [s] (overlaps counted once)."""
        spans = sorted((max(a, self.start), min(b, self.end)) for a, b, _ in self.bad_chunks if b >= a)
        total, cur_a, cur_b = 0, None, None
        for a, b in spans:
            if cur_b is None or a > cur_b:
                if cur_b is not None and cur_a is not None:
                    total += cur_b - cur_a
                cur_a, cur_b = a, b
            else:
                cur_b = max(cur_b, b)
        if cur_a is not None and cur_b is not None:
            total += cur_b - cur_a
        return total / 1e9

    @property
    def damaged(self) -> bool:
        """Whether anything was lost or skipped (a cut-off end included)."""
        return bool(self.bad_chunks) or self.skipped_bytes > 0 or self.truncated

    def summary(self) -> str:
        """One line for the operator: ``2 of 40 chunks unreadable: 12.3 s of 95.0 s lost``."""
        parts = []
        if self.bad_chunks:
            parts.append(f"{len(self.bad_chunks)} of {self.chunks} chunks unreadable: {self.lost_s:.1f} s of "
                         f"{self.span_s:.1f} s lost")
        elif self.skipped_bytes:
            parts.append(f"{self.skipped_bytes} damaged bytes skipped between chunks; all {self.chunks} chunks readable")
        if self.truncated:
            parts.append(f"the file ends early (not finished): {self.span_s:.1f} s readable up to its end")
        return "; ".join(parts) if parts else f"all {self.chunks} chunks readable"


def _u64(b: Any, at: int) -> int:
    return struct.unpack_from("<Q", b, at)[0]


def _chunk_header(buf: Any, off: int, end: int) -> tuple[int, int, int] | None:
    """``(record length, message start ns, message end ns)`` when a plausible Chunk record starts at
    ``off`` (opcode, lengths inside the file, known compression), else ``None``."""
    if off + 9 + 8 + 8 + 8 + 4 + 4 > end or buf[off] != _CHUNK:
        return None
    length = _u64(buf, off + 1)
    body = off + 9
    if body + length > end or length < 8 + 8 + 8 + 4 + 4 + 8:
        return None
    t0, t1 = _u64(buf, body), _u64(buf, body + 8)
    clen = struct.unpack_from("<I", buf, body + 28)[0]
    if clen > 8 or t1 < t0 or body + 32 + clen + 8 > end:
        return None
    comp = bytes(buf[body + 32: body + 32 + clen])
    if comp.decode("ascii", "replace") not in _COMPRESSIONS:
        return None
    data_len = _u64(buf, body + 32 + clen)
    if 32 + clen + 8 + data_len != length:
        return None
    return length, t0, t1


def _summary(buf: Any, size: int) -> tuple[list[Any], list[Any], list[Any]] | None:
    """``(schemas, channels, chunk indexes)`` from the summary section, or ``None`` if unreadable."""
    from mcap.records import Channel, ChunkIndex, Schema
    from mcap.stream_reader import StreamReader

    if size < 2 * len(MAGIC) + _FOOTER_LEN or bytes(buf[size - len(MAGIC):size]) != MAGIC:
        return None
    foot = size - len(MAGIC) - _FOOTER_LEN
    if buf[foot] != _FOOTER:
        return None
    start = _u64(buf, foot + 9)
    if not len(MAGIC) <= start < foot:
        return None
    schemas, channels, indexes = [], [], []
    try:
        for r in StreamReader(BytesIO(bytes(buf[start:size])), skip_magic=True).records:  # to the footer
            if isinstance(r, Schema):
                schemas.append(r)
            elif isinstance(r, Channel):
                channels.append(r)
            elif isinstance(r, ChunkIndex):
                indexes.append(r)
    except Exception:  # noqa: BLE001 - a damaged summary: walk the data section without it
        return None
    return schemas, channels, indexes


def salvage(f: BinaryIO) -> tuple[list[tuple[Any, Any, Any]], SalvageReport]:
    """``([(schema, channel, message) ...] in log-time order, report)`` of an MCAP file opened for
    reading in binary mode (read through a memory map: nothing is copied but the chunks)."""
    from mcap.data_stream import ReadDataStream
    from mcap.records import Channel, Chunk, Message, Schema
    from mcap.stream_reader import breakup_chunk

    report = SalvageReport()
    f.seek(0, 2)
    size = f.tell()
    if size <= len(MAGIC):
        report.truncated = True
        return [], report
    buf = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        summary = _summary(buf, size)
        report.truncated = summary is None and bytes(buf[size - len(MAGIC):size]) != MAGIC
        schemas: dict[int, Any] = {}
        channels: dict[int, Any] = {}
        indexed: list[Any] = []
        if summary is not None:
            schemas = {s.id: s for s in summary[0]}
            channels = {c.id: c for c in summary[1]}
            indexed = sorted(summary[2], key=lambda c: c.chunk_start_offset)
        # where the data section ends when its DataEnd record is damaged: after the last indexed chunk
        data_end = max((c.chunk_start_offset + c.chunk_length for c in indexed), default=size)
        messages: list[Any] = []
        seen_offsets: set[int] = set()
        times: list[int] = []

        def take(records: list[Any]) -> None:
            for r in records:
                if isinstance(r, Schema):
                    schemas.setdefault(r.id, r)
                elif isinstance(r, Channel):
                    channels.setdefault(r.id, r)
                elif isinstance(r, Message):
                    messages.append(r)

        def next_chunk(after: int) -> int | None:
            for c in indexed:
                if c.chunk_start_offset > after and c.chunk_start_offset not in seen_offsets:
                    return int(c.chunk_start_offset)
            limit = size - 9
            i = after + 1
            while i < limit:
                j = buf.find(bytes([_CHUNK]), i, limit)
                if j < 0:
                    return None
                if _chunk_header(buf, j, size) is not None:
                    return j
                i = j + 1
            return None

        prev_end: int | None = None  # end time of the last chunk read, to size a gap of damaged framing
        gap_open = False  # damaged bytes were skipped since that chunk (no index to say which chunk)
        pos = len(MAGIC)
        while pos + 9 <= size:
            op, length = buf[pos], _u64(buf, pos + 1)
            body = pos + 9
            if op == _CHUNK:
                head = _chunk_header(buf, pos, size)
                if head is None:  # a damaged chunk header: its span is only known from the index
                    nxt = next_chunk(pos)
                    if nxt is None:
                        break
                    report.skipped_bytes += nxt - pos
                    gap_open = not indexed
                    pos = nxt
                    continue
                seen_offsets.add(pos)
                report.chunks += 1
                _, t0, t1 = head
                times += [t0, t1]
                if gap_open:  # a chunk whose framing was destroyed lay between the previous one and this
                    report.chunks += 1
                    report.bad_chunks.append((prev_end if prev_end is not None else t0, t0, "damaged framing"))
                    gap_open = False
                prev_end = t1
                try:
                    chunk = Chunk.read(ReadDataStream(BytesIO(bytes(buf[body: body + length]))))
                    take(breakup_chunk(chunk, validate_crc=True))
                except Exception as exc:  # noqa: BLE001 - LZ4 / zstd / CRC / record errors: this chunk only
                    report.bad_chunks.append((t0, t1, f"{type(exc).__name__}: {exc}"))
                pos = body + length
                continue
            if op == _DATA_END or op == _FOOTER or (indexed and pos >= data_end):
                break
            if body + length > size or op == 0 or op > 0x10:  # damaged framing: jump to the next chunk
                nxt = next_chunk(pos)
                if nxt is None:
                    if body + length > size:
                        report.truncated = report.truncated or summary is None
                    break
                report.skipped_bytes += nxt - pos
                gap_open = not indexed
                pos = nxt
                continue
            if op in (_SCHEMA, _CHANNEL, _MESSAGE):  # records outside chunks (an unchunked writer)
                stream = ReadDataStream(BytesIO(bytes(buf[body: body + length])))
                try:
                    take([Schema.read(stream) if op == _SCHEMA else Channel.read(stream) if op == _CHANNEL
                          else Message.read(stream, length)])
                except Exception:  # noqa: BLE001 - a damaged record: skipped
                    pass
            pos = body + length
        # chunks the index lists but the walk never reached (their header was destroyed)
        for c in indexed:
            if c.chunk_start_offset not in seen_offsets:
                report.chunks += 1
                report.bad_chunks.append((int(c.message_start_time), int(c.message_end_time), "chunk header damaged"))
                times += [int(c.message_start_time), int(c.message_end_time)]
        times += [m.log_time for m in messages]
        if times:
            report.start, report.end = min(times), max(times)
        out = [(schemas.get(channels[m.channel_id].schema_id), channels[m.channel_id], m)
               for m in messages if m.channel_id in channels]
        out.sort(key=lambda x: x[2].log_time)
        return out, report
    finally:
        buf.close()


__all__ = ["SalvageReport", "salvage"]
