//! Files that read to their end but are not whole: a chunk removed or repeated, payloads
//! that do not decode. The reader checks what it read against the file's own statistics
//! and says what disagrees; a file compressed with lz4 (which the MCAP format allows)
//! reads like a zstd one.

use std::collections::BTreeMap;
use std::ops::Range;

use mmq_log::read_log;

use crate::common::record_grid;

/// The byte ranges of the top-level chunk records of an MCAP file (opcode 0x06), walking
/// records from the start magic to the data end record (0x0F).
fn chunks(bytes: &[u8]) -> Vec<Range<usize>> {
    let mut at = 8;
    let mut out = Vec::new();
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        let end = at + 9 + len;
        if op == 0x06 {
            out.push(at..end);
        }
        if op == 0x0F {
            break;
        }
        at = end;
    }
    out
}

#[test]
fn a_removed_or_repeated_chunk_is_found_by_the_counts() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("full.mcap");
    record_grid(&path, |c| c.flush_every_steps = 100, 2000, 4);
    let whole = read_log(&path).unwrap();
    assert!(whole.complete && whole.problems.is_empty(), "{:?}", whole.problems);
    let bytes = std::fs::read(&path).unwrap();
    let cs = chunks(&bytes);
    assert!(cs.len() >= 5, "{} chunks", cs.len());
    let mid = cs[cs.len() / 2].clone();

    let removed = dir.path().join("removed.mcap");
    std::fs::write(&removed, [&bytes[..mid.start], &bytes[mid.end..]].concat()).unwrap();
    let log = read_log(&removed).unwrap();
    assert!(log.stop.is_none(), "it still reads to its end: {:?}", log.stop);
    assert!(!log.complete);
    assert!(log.problems[0].contains("a chunk is missing or repeated"), "{:?}", log.problems);
    assert!(log.problems.iter().any(|p| p.starts_with("/rl/decision:")), "{:?}", log.problems);
    let text = mmq_log::summary(&log).to_string();
    assert!(text.contains("DAMAGED") && !text.contains("file:       complete"), "{text}");

    let repeated = dir.path().join("repeated.mcap");
    std::fs::write(&repeated, [&bytes[..mid.end], &bytes[mid.clone()], &bytes[mid.end..]].concat()).unwrap();
    let log = read_log(&repeated).unwrap();
    assert!(!log.complete && log.messages > whole.messages, "{:?}", log.problems);
    assert!(log.problems[0].contains(&format!("{} were read", log.messages)), "{:?}", log.problems);
}

/// Writes a small MCAP file with `compression`, on our decision topic: `payloads` as
/// messages, and a `run` metadata record.
fn foreign_writer(
    path: &std::path::Path,
    compression: Option<mcap::Compression>,
    topic: &str,
    payloads: &[&str],
) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().compression(compression).create(file).unwrap();
    let schema = w.add_schema("mmq.Decision", "jsonschema", b"{}").unwrap();
    let ch = w.add_channel(schema, topic, "json", &BTreeMap::new()).unwrap();
    for (i, p) in payloads.iter().enumerate() {
        let header = mcap::records::MessageHeader {
            channel_id: ch,
            sequence: i as u32,
            log_time: i as u64 * 100_000_000,
            publish_time: i as u64 * 100_000_000,
        };
        w.write_to_known_channel(&header, p.as_bytes()).unwrap();
    }
    let run: BTreeMap<String, String> = [("learner".to_string(), "q".to_string())].into();
    w.write_metadata(&mcap::records::Metadata { name: "run".into(), metadata: run }).unwrap();
    w.finish().unwrap();
}

const DECISION: &str =
    r#"{"t":0,"state":3,"action":1,"action_name":"down","explored":false,"next_state":6,"event":"moved"}"#;

#[test]
fn lz4_chunks_read_like_zstd_ones() {
    let dir = tempfile::tempdir().unwrap();
    let mut counts = Vec::new();
    for (name, c) in
        [("lz4", Some(mcap::Compression::Lz4)), ("zstd", Some(mcap::Compression::Zstd)), ("none", None)]
    {
        let path = dir.path().join(format!("{name}.mcap"));
        foreign_writer(&path, c, "/rl/decision", &[DECISION, DECISION, DECISION]);
        let log = read_log(&path).unwrap();
        assert!(log.stop.is_none(), "{name}: {:?}", log.stop);
        counts.push((name, log.messages, log.topics["/rl/decision"].count));
    }
    assert!(counts.iter().all(|&(_, m, d)| m == 3 && d == 3), "{counts:?}");
}

#[test]
fn payloads_that_do_not_decode_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.mcap");
    foreign_writer(&path, Some(mcap::Compression::Zstd), "/rl/decision", &[DECISION, "{not json", "[1,2]"]);
    let log = read_log(&path).unwrap();
    assert!(!log.complete);
    assert_eq!(log.problems, vec!["/rl/decision: 2 of 3 messages do not decode".to_string()]);
}
