#!/usr/bin/env python3
"""Validate mmq MCAP logs with the official `mcap` Python package.

For each file given:
  * every record is read strictly (start and end magic, chunk and data-section CRCs);
  * the summary section is present and its per-channel message counts match the messages;
  * every channel is JSON with a `jsonschema` schema, and every message validates against
    its channel's schema (the `jsonschema` package); foxglove.Grid data is base64 of the
    size its strides say; a top-level `timestamp` equals the message's log_time (except
    SceneUpdate, whose entities carry the run's start); log times never go back on a topic;
  * the "run" metadata record (with a seed) and the world.toml and config.toml
    attachments are there.
Prints per-topic message counts and exits non-zero on any problem.

Usage: python3 tools/validate_mcap.py FILE.mcap [FILE.mcap ...]
Needs: pip install -r tools/requirements.txt
"""

import argparse
import base64
import json
import sys
from collections import Counter, defaultdict

try:
    import jsonschema
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader
except ImportError as e:  # pragma: no cover - environment problem
    print(f"validate_mcap: missing package ({e}); run: pip install -r tools/requirements.txt", file=sys.stderr)
    sys.exit(2)

MAX_REPORTS = 20


class Problems:
    def __init__(self, path):
        self.path = path
        self.items = []
        self.per_kind = Counter()

    def add(self, kind, message):
        self.per_kind[kind] += 1
        if self.per_kind[kind] <= MAX_REPORTS:
            self.items.append(f"{self.path}: {kind}: {message}")

    def __len__(self):
        return sum(self.per_kind.values())


def check_grid(msg, problems, where):
    try:
        data = base64.b64decode(msg["data"], validate=True)
    except Exception as e:  # noqa: BLE001 - any decoding failure is a problem
        problems.add("grid", f"{where}: data is not base64 ({e})")
        return
    row, cell, cols = msg["row_stride"], msg["cell_stride"], msg["column_count"]
    if row <= 0 or len(data) % row != 0:
        problems.add("grid", f"{where}: {len(data)} data bytes are not whole rows of {row}")
    if cell * cols > row:
        problems.add("grid", f"{where}: {cols} cells of {cell} bytes do not fit a row of {row}")
    sizes = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 8: 8}
    for f in msg["fields"]:
        if f["offset"] + sizes.get(f["type"], 0) > cell:
            problems.add("grid", f"{where}: field {f['name']} does not fit a cell of {cell} bytes")


def validate(path, quiet=False):
    problems = Problems(path)
    # 1. Strict record-by-record read: magic, CRCs, record framing.
    try:
        with open(path, "rb") as f:
            for _ in StreamReader(f, validate_crcs=True).records:
                pass
    except Exception as e:  # noqa: BLE001 - report whatever the reader refused
        problems.add("records", f"strict read failed: {type(e).__name__}: {e}")

    counts = Counter()
    validators = {}
    last_time = {}
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        try:
            summary = reader.get_summary()
        except Exception as e:  # noqa: BLE001
            summary = None
            problems.add("summary", f"cannot read the summary: {e}")
        if summary is None:
            problems.add("summary", "no summary section (was the file finished?)")
        try:
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                topic = channel.topic
                counts[topic] += 1
                where = f"{topic} #{counts[topic]} (log_time {message.log_time})"
                if channel.message_encoding != "json":
                    problems.add("encoding", f"{topic}: message encoding {channel.message_encoding!r}, not json")
                    continue
                if schema is None or schema.encoding != "jsonschema":
                    problems.add("encoding", f"{topic}: schema is not jsonschema")
                    continue
                v = validators.get(schema.id)
                if v is None:
                    try:
                        s = json.loads(schema.data)
                        cls = jsonschema.validators.validator_for(s, default=jsonschema.Draft202012Validator)
                        cls.check_schema(s)
                        v = validators[schema.id] = cls(s)
                    except Exception as e:  # noqa: BLE001
                        problems.add("schema", f"{schema.name}: invalid JSON schema ({e})")
                        validators[schema.id] = v = False
                try:
                    msg = json.loads(message.data)
                except ValueError as e:
                    problems.add("json", f"{where}: not JSON ({e})")
                    continue
                if v:
                    for err in v.iter_errors(msg):
                        path_s = "/".join(str(p) for p in err.absolute_path)
                        problems.add("validation", f"{where} ({schema.name}) at /{path_s}: {err.message}")
                if schema.name == "foxglove.Grid":
                    check_grid(msg, problems, where)
                ts = msg.get("timestamp") if isinstance(msg, dict) else None
                if ts is not None and schema.name != "foxglove.SceneUpdate":
                    ns = ts.get("sec", 0) * 1_000_000_000 + ts.get("nsec", 0)
                    if ns != message.log_time:
                        problems.add("time", f"{where}: timestamp {ns} ns differs from log_time")
                if message.log_time < last_time.get(topic, 0):
                    problems.add("time", f"{where}: log_time goes back (previous {last_time[topic]})")
                last_time[topic] = message.log_time
        except Exception as e:  # noqa: BLE001
            problems.add("messages", f"reading messages failed: {type(e).__name__}: {e}")

        if summary is not None:
            if summary.statistics is not None:
                by_id = summary.statistics.channel_message_counts
                for cid, ch in summary.channels.items():
                    if by_id.get(cid, 0) != counts.get(ch.topic, 0):
                        problems.add(
                            "summary",
                            f"{ch.topic}: summary counts {by_id.get(cid, 0)} messages, {counts.get(ch.topic, 0)} read",
                        )
            else:
                problems.add("summary", "no statistics record")
        try:
            metadata = {m.name: m.metadata for m in reader.iter_metadata()}
            attachments = {a.name for a in reader.iter_attachments()}
        except Exception as e:  # noqa: BLE001
            metadata, attachments = {}, set()
            problems.add("summary", f"cannot read metadata or attachments: {e}")
        if "seed" not in metadata.get("run", {}):
            problems.add("metadata", "no 'run' metadata record with a seed")
        for name in ("world.toml", "config.toml"):
            if name not in attachments:
                problems.add("attachments", f"no {name} attachment")

    if not quiet:
        print(f"{path}: {sum(counts.values())} messages")
        for topic in sorted(counts):
            print(f"  {topic:<24} {counts[topic]}")
    for line in problems.items:
        print(line, file=sys.stderr)
    hidden = len(problems) - len(problems.items)
    if hidden > 0:
        print(f"{path}: ... and {hidden} more problems", file=sys.stderr)
    print(f"{path}: {'OK' if len(problems) == 0 else f'{len(problems)} problems'}")
    return len(problems)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", help="MCAP files to validate")
    ap.add_argument("-q", "--quiet", action="store_true", help="do not print per-topic counts")
    args = ap.parse_args()
    bad = 0
    for path in args.files:
        try:
            bad += validate(path, args.quiet)
        except OSError as e:
            print(f"{path}: cannot read: {e}", file=sys.stderr)
            bad += 1
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
