#!/usr/bin/env python3
"""Decode every message of an MCAP file with the ROS 2 readers of the Python world.

Usage: read_mcap.py FILE.mcap

Reads FILE with the PyPI packages `mcap` (the reader) and `mcap-ros2-support` (the
ROS 2 decoder: it parses the `ros2msg` schema texts and decodes the CDR messages), as a
user of Foxglove's Python tools would, and prints one JSON object on stdout:

    {"profile", "library",
     "schemas":    [{"name", "encoding"}],
     "channels":   [{"topic", "schema", "message_encoding", "metadata"}],
     "metadata":   {record name: {key: value}},
     "statistics": {"message_count", "channel_message_counts": {topic: n}},
     "messages":   [{"topic", "schema", "log_time", "publish_time", "sequence", "msg"}],
     "errors":     ["<topic> #<sequence>: <why it did not decode>"],
     "reencoded":  {"identical": n, "different": ["<topic> #<sequence>"], "available": bool}}

`msg` is the decoded message as plain JSON (NaN and infinities as the strings "nan",
"inf", "-inf"). "reencoded" encodes each decoded message again with mcap-ros2-support's
own CDR encoder and compares the bytes with the file's: an independent check that the
Rust encoder writes what the Python one writes.

Used by crates/fbgforge-publish/tests/mcap_roundtrip.rs when FBGFORGE_PYTHON names a
Python with those packages.
"""

import json
import math
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

try:  # A private module of mcap-ros2-support: the re-encoding check is optional.
    from mcap_ros2._dynamic import serialize_dynamic
except ImportError:  # pragma: no cover
    serialize_dynamic = None


def plain(value):
    """A decoded ROS 2 message (or field) as JSON-ready values."""
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    slots = getattr(type(value), "__slots__", None)
    if slots:
        return {name: plain(getattr(value, name)) for name in slots}
    return repr(value)


def main(path):
    out = {
        "schemas": [],
        "channels": [],
        "metadata": {},
        "messages": [],
        "errors": [],
        "reencoded": {
            "identical": 0,
            "different": [],
            "available": serialize_dynamic is not None,
        },
    }
    factory = DecoderFactory()
    decoders = {}
    encoders = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        out["profile"] = header.profile
        out["library"] = header.library
        summary = reader.get_summary()
        for schema in sorted(summary.schemas.values(), key=lambda s: s.id):
            out["schemas"].append({"name": schema.name, "encoding": schema.encoding})
        for channel in sorted(summary.channels.values(), key=lambda c: c.id):
            schema = summary.schemas.get(channel.schema_id)
            out["channels"].append(
                {
                    "topic": channel.topic,
                    "schema": schema.name if schema else None,
                    "message_encoding": channel.message_encoding,
                    "metadata": dict(channel.metadata),
                }
            )
        stats = summary.statistics
        out["statistics"] = {
            "message_count": stats.message_count,
            "channel_message_counts": {
                summary.channels[cid].topic: n
                for cid, n in stats.channel_message_counts.items()
            },
        }
        for record in reader.iter_metadata():
            out["metadata"][record.name] = dict(record.metadata)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            where = f"{channel.topic} #{message.sequence}"
            try:
                if channel.id not in decoders:
                    decoders[channel.id] = factory.decoder_for(
                        channel.message_encoding, schema
                    )
                decoder = decoders[channel.id]
                if decoder is None:
                    raise ValueError(
                        f"no decoder for {channel.message_encoding} / {schema.encoding}"
                    )
                decoded = decoder(message.data)
            except Exception as e:  # noqa: BLE001 - every failure is reported
                out["errors"].append(f"{where}: {type(e).__name__}: {e}")
                continue
            out["messages"].append(
                {
                    "topic": channel.topic,
                    "schema": schema.name,
                    "log_time": message.log_time,
                    "publish_time": message.publish_time,
                    "sequence": message.sequence,
                    "msg": plain(decoded),
                }
            )
            if serialize_dynamic is not None:
                if schema.id not in encoders:
                    encoders[schema.id] = serialize_dynamic(
                        schema.name, schema.data.decode()
                    )[schema.name]
                if encoders[schema.id](decoded) == message.data:
                    out["reencoded"]["identical"] += 1
                else:
                    out["reencoded"]["different"].append(where)
    json.dump(out, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
