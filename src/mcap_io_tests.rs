//! MCAP writing and recovering reads, on files synthesised here.

use super::*;
use crate::ros::geometry_msgs::Point;
use crate::ros::tf2_msgs::TFMessage;

fn point(i: u64) -> Point {
    #[expect(clippy::cast_precision_loss, reason = "small test indices")]
    let v = i as f64;
    Point {
        x: v,
        y: -v,
        z: 0.5,
    }
}

/// A bag with `n` points on /a and a TF message every tenth, in chunks of `chunk` bytes.
fn write_bag(path: &Path, n: u64, compression: Compression, chunk: u64) {
    let mut w = BagWriter::create(
        path,
        WriteConfig {
            compression,
            chunk_size_bytes: chunk,
            writer_thread: false,
        },
    )
    .unwrap();
    w.write_metadata(
        "autoact",
        [("action".to_string(), "wave".to_string())].into(),
    )
    .unwrap();
    for i in 0..n {
        w.write("/a", 1_000 + i, &point(i)).unwrap();
        if i % 10 == 0 {
            w.write("/tf", 1_000 + i, &TFMessage::default()).unwrap();
        }
    }
    w.finish().unwrap();
}

/// Byte ranges of the top-level chunk records (opcode 0x06) of an MCAP file.
fn chunk_ranges(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut at = mcap::MAGIC.len();
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let len = usize::try_from(u64::from_le_bytes(
            bytes[at + 1..at + 9].try_into().unwrap(),
        ))
        .unwrap();
        if op == 0x06 {
            out.push((at, at + 9 + len));
        }
        if op == 0x02 {
            break; // footer
        }
        at += 9 + len;
    }
    out
}

fn read_all(path: &Path) -> (Vec<BagMessage>, Vec<ReadIssue>) {
    let reader = BagReader::open(path).unwrap();
    let mut msgs = Vec::new();
    let mut issues = Vec::new();
    for item in reader.messages() {
        match item {
            Ok(m) => msgs.push(m),
            Err(i) => issues.push(i),
        }
    }
    (msgs, issues)
}

#[test]
fn written_bags_read_back_in_order_with_schemas_and_metadata() {
    for compression in [Compression::Zstd, Compression::Lz4, Compression::None] {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        write_bag(&path, 500, compression, 4096);
        let reader = BagReader::open(&path).unwrap();
        assert_eq!(
            reader.header(),
            Some(("ros2".to_string(), LIBRARY.to_string()))
        );
        assert_eq!(
            reader.metadata(),
            vec![(
                "autoact".to_string(),
                [("action".to_string(), "wave".to_string())].into()
            )]
        );
        let (msgs, issues) = read_all(&path);
        assert!(issues.is_empty(), "{issues:?}");
        assert_eq!(msgs.len(), 550);
        let points: Vec<&BagMessage> = msgs.iter().filter(|m| m.channel.topic == "/a").collect();
        for (i, m) in points.iter().enumerate() {
            let p: Point = crate::ros::cdr::decode(&m.data).unwrap();
            assert_eq!(p, point(i as u64));
            assert_eq!(m.index_on_channel, i as u64);
            assert_eq!(m.channel.schema_name(), "geometry_msgs/msg/Point");
            assert_eq!(m.channel.message_encoding, "cdr");
            assert_eq!(m.channel.schema.as_ref().unwrap().encoding, "ros2msg");
        }
        assert!(
            chunk_ranges(reader.bytes()).len() > 3,
            "{compression:?}: several chunks"
        );
    }
}

#[test]
fn stats_count_each_topic_and_a_topic_keeps_its_type() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mcap");
    let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
    for i in 0..3 {
        w.write("/a", 10 + i, &point(i)).unwrap();
    }
    w.write("/tf", 5, &TFMessage::default()).unwrap();
    let e = w.write("/a", 20, &TFMessage::default()).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "cannot write a tf2_msgs/msg/TFMessage on /a in {}: the topic already carries geometry_msgs/msg/Point",
            path.display()
        )
    );
    let stats = w.finish().unwrap();
    assert_eq!(
        stats.topics,
        [
            ("/a".to_string(), ("geometry_msgs/msg/Point".to_string(), 3)),
            ("/tf".to_string(), ("tf2_msgs/msg/TFMessage".to_string(), 1)),
        ]
        .into()
    );
    assert_eq!(stats.time_range, Some((5, 12)));
    let (msgs, issues) = read_all(&path);
    assert!(issues.is_empty(), "{issues:?}");
    assert_eq!(msgs.len(), 4, "the refused message is not in the file");
}

#[test]
fn same_input_gives_byte_identical_files() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.mcap"), dir.path().join("b.mcap"));
    write_bag(&a, 300, Compression::Zstd, 4096);
    write_bag(&b, 300, Compression::Zstd, 4096);
    assert_eq!(std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
}

#[test]
fn a_corrupt_chunk_costs_only_its_own_messages() {
    for compression in [Compression::None, Compression::Zstd] {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        write_bag(&path, 500, compression, 4096);
        let (good, _) = read_all(&path);
        let mut bytes = std::fs::read(&path).unwrap();
        let chunks = chunk_ranges(&bytes);
        let (_, end) = chunks[1];
        // Flip bytes near the end of the chunk's record data.
        bytes[end - 20] ^= 0x5a;
        bytes[end - 21] ^= 0x33;
        std::fs::write(&path, &bytes).unwrap();
        let (msgs, issues) = read_all(&path);
        assert_eq!(issues.len(), 1, "{compression:?}: {issues:?}");
        let issue = issues[0].to_string();
        assert!(
            issue.contains("chunk 2") && issue.contains("x.mcap") && issue.contains("skipped"),
            "{issue}"
        );
        assert!(
            msgs.len() < good.len() && msgs.len() > good.len() / 2,
            "{} of {}",
            msgs.len(),
            good.len()
        );
        // Messages after the bad chunk are still there, in order.
        assert_eq!(
            msgs.last().map(|m| m.log_time),
            good.last().map(|m| m.log_time)
        );
    }
}

#[test]
fn a_truncated_file_yields_everything_before_the_cut() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mcap");
    write_bag(&path, 500, Compression::Zstd, 4096);
    let bytes = std::fs::read(&path).unwrap();
    let chunks = chunk_ranges(&bytes);
    let (start, end) = chunks[3];
    std::fs::write(&path, &bytes[..usize::midpoint(start, end)]).unwrap();
    let (msgs, issues) = read_all(&path);
    assert_eq!(issues.len(), 1);
    assert!(
        matches!(&issues[0], ReadIssue::Truncated { messages_read, .. } if *messages_read == msgs.len() as u64),
        "{issues:?}"
    );
    assert!(issues[0].to_string().contains("cut short"), "{}", issues[0]);
    assert!(!msgs.is_empty());
}

#[test]
fn empty_and_foreign_files_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.mcap");
    std::fs::write(&empty, b"").unwrap();
    assert!(matches!(BagReader::open(&empty), Err(McapIoError::Empty(p)) if p == empty));
    let foreign = dir.path().join("foreign.mcap");
    std::fs::write(&foreign, b"not an mcap at all").unwrap();
    let err = BagReader::open(&foreign).unwrap_err().to_string();
    assert!(
        err.contains("foreign.mcap") && err.contains("not an MCAP file"),
        "{err}"
    );
    let missing = dir.path().join("missing.mcap");
    assert!(
        BagReader::open(&missing)
            .unwrap_err()
            .to_string()
            .contains("missing.mcap")
    );
}

#[test]
fn header_only_garbage_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mcap");
    write_bag(&path, 50, Compression::Zstd, 1024);
    let bytes = std::fs::read(&path).unwrap();
    // Every truncation length: no panic, never more messages than the whole file.
    for cut in (mcap::MAGIC.len()..bytes.len()).step_by(7) {
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let (msgs, _) = read_all(&path);
        assert!(msgs.len() <= 55);
    }
}

/// Writes and seeks as the MCAP writer does (a write larger than the buffer, a seek back over
/// buffered bytes to patch a header, on to the end); returns every position reported.
fn write_and_seek(w: &mut (impl Write + Seek)) -> Vec<u64> {
    let mut positions = Vec::new();
    w.write_all(b"header--").unwrap();
    positions.push(w.stream_position().unwrap());
    w.write_all(&vec![7u8; 200 * 1024]).unwrap();
    positions.push(w.stream_position().unwrap());
    positions.push(w.seek(SeekFrom::Start(2)).unwrap());
    w.write_all(b"XY").unwrap();
    positions.push(w.stream_position().unwrap());
    positions.push(w.seek(SeekFrom::End(0)).unwrap());
    w.write_all(b"tail").unwrap();
    positions.push(w.seek(SeekFrom::Current(-3)).unwrap());
    w.write_all(b"!").unwrap();
    positions.push(w.stream_position().unwrap());
    positions.push(w.seek(SeekFrom::End(0)).unwrap());
    w.flush().unwrap();
    positions
}

#[test]
fn file_sink_tracks_its_position_through_writes_and_seeks() {
    // Against an in-memory cursor, whose position is exact: the same positions, the same bytes.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sink.bin");
    let mut sink = FileSink::new(File::create(&path).unwrap());
    let mut cursor = std::io::Cursor::new(Vec::new());
    assert_eq!(write_and_seek(&mut sink), write_and_seek(&mut cursor));
    drop(sink);
    assert_eq!(std::fs::read(&path).unwrap(), cursor.into_inner());
}

/// Per chunk of a finished file: (chunk start, chunk end, messages its message indexes list).
fn indexed_chunks(bytes: &[u8]) -> Vec<(usize, usize, u64)> {
    let mut out: Vec<(usize, usize, u64)> = Vec::new();
    let mut at = mcap::MAGIC.len();
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let len = usize::try_from(u64::from_le_bytes(
            bytes[at + 1..at + 9].try_into().unwrap(),
        ))
        .unwrap();
        match op {
            0x06 => out.push((at, at + 9 + len, 0)),
            0x07 => {
                let entries = u32::from_le_bytes(bytes[at + 11..at + 15].try_into().unwrap());
                out.last_mut().unwrap().2 += u64::from(entries) / 16;
            }
            0x0F => break, // data end
            _ => {}
        }
        at += 9 + len;
    }
    out
}

/// Where the data-end record starts: the file without its summary ends here.
fn data_end(bytes: &[u8]) -> usize {
    let (_, end, _) = *indexed_chunks(bytes).last().unwrap();
    let mut at = end;
    while bytes[at] != 0x0F {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap());
        at += 9 + usize::try_from(len).unwrap();
    }
    at
}

/// Index on its channel of every message read, keyed by (topic, log time, nth at that time).
fn indices(msgs: &[BagMessage]) -> BTreeMap<(String, u64, u64), u64> {
    let mut seen: BTreeMap<(String, u64), u64> = BTreeMap::new();
    msgs.iter()
        .map(|m| {
            let n = seen
                .entry((m.channel.topic.clone(), m.log_time))
                .or_insert(0);
            *n += 1;
            (
                (m.channel.topic.clone(), m.log_time, *n),
                m.index_on_channel,
            )
        })
        .collect()
}

#[test]
fn a_file_cut_at_any_chunk_boundary_keeps_every_complete_chunk_and_says_it_was_not_finished() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mcap");
    write_bag(&path, 3000, Compression::Zstd, 8192);
    let bytes = std::fs::read(&path).unwrap();
    let chunks = indexed_chunks(&bytes);
    assert!(chunks.len() > 10);
    let mut cuts: Vec<(usize, u64)> = chunks
        .iter()
        .scan(0, |before, &(start, _, n)| {
            let cut = (start, *before);
            *before += n;
            Some(cut)
        })
        .collect();
    cuts.push((data_end(&bytes), chunks.iter().map(|c| c.2).sum()));
    for (cut, expected) in cuts {
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let (msgs, issues) = read_all(&path);
        assert_eq!(msgs.len() as u64, expected, "cut at byte {cut}");
        assert_eq!(
            issues,
            vec![ReadIssue::NoSummary {
                path: path.clone(),
                messages_read: expected
            }],
            "cut at byte {cut}"
        );
        assert!(
            issues[0].to_string().contains(&format!(
                "x.mcap: file ends without a summary: {expected} messages recovered"
            )),
            "{}",
            issues[0]
        );
    }
}

/// `bytes` with the length field of the record at `at` replaced by `len`.
fn with_length(bytes: &[u8], at: usize, len: u64) -> Vec<u8> {
    let mut out = bytes.to_vec();
    out[at + 1..at + 9].copy_from_slice(&len.to_le_bytes());
    out
}

#[test]
fn a_damaged_chunk_length_costs_only_that_chunk_with_or_without_the_summary() {
    for compression in [Compression::Zstd, Compression::Lz4, Compression::None] {
        damaged_chunk_length(compression);
    }
}

fn damaged_chunk_length(compression: Compression) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mcap");
    write_bag(&path, 3000, compression, 8192);
    let bytes = std::fs::read(&path).unwrap();
    let (good, _) = read_all(&path);
    let good_indices = indices(&good);
    let chunks = indexed_chunks(&bytes);
    let (start, _, lost) = chunks[3];
    let without_summary = &bytes[..data_end(&bytes)];
    for (case, damaged) in [
        ("all ones", with_length(&bytes, start, u64::MAX)),
        (
            "past the end",
            with_length(&bytes, start, bytes.len() as u64),
        ),
        (
            "all ones, no summary",
            with_length(without_summary, start, u64::MAX),
        ),
        ("zero, no summary", with_length(without_summary, start, 0)),
    ] {
        std::fs::write(&path, &damaged).unwrap();
        let (msgs, issues) = read_all(&path);
        let first = issues[0].to_string();
        assert!(
            first.contains(&format!("bytes {start}..")) || first.contains("chunk 4"),
            "{case}: {first}"
        );
        if compression == Compression::None && case.contains("no summary") {
            // The scan finds the uncompressed chunk's own records: its messages are kept.
            assert_eq!(msgs.len(), good.len(), "{compression:?} {case}: {issues:?}");
        } else {
            assert_eq!(
                msgs.len() as u64,
                good.len() as u64 - lost,
                "{compression:?} {case}: {issues:?}"
            );
            assert!(
                first.contains(&format!("its message index lists {lost} messages")),
                "{compression:?} {case}: {first}"
            );
        }
        assert_eq!(
            issues.len(),
            if case.contains("no summary") { 2 } else { 1 },
            "{case}: {issues:?}"
        );
        // Every message keeps the index on its channel a whole read gives it.
        for (key, index) in indices(&msgs) {
            assert_eq!(good_indices[&key], index, "{case}: {key:?}");
        }
    }
}

#[test]
fn garbage_between_chunks_is_skipped_and_reported_with_its_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mcap");
    write_bag(&path, 3000, Compression::Zstd, 8192);
    let bytes = std::fs::read(&path).unwrap();
    let (good, _) = read_all(&path);
    let (start, _, _) = indexed_chunks(&bytes)[5];
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let garbage: Vec<u8> = (0..1000)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state.to_le_bytes()[3]
        })
        .collect();
    let damaged = [&bytes[..start], &garbage, &bytes[start..]].concat();
    std::fs::write(&path, &damaged).unwrap();
    let (msgs, issues) = read_all(&path);
    assert_eq!(msgs.len(), good.len(), "{issues:?}");
    assert_eq!(issues.len(), 1, "{issues:?}");
    assert!(
        issues[0]
            .to_string()
            .contains(&format!("bytes {start}..{} are damaged", start + 1000)),
        "{}",
        issues[0]
    );
}

#[test]
fn corrupt_string_and_size_fields_cost_an_issue_not_an_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.mcap");
    write_bag(&path, 500, Compression::Zstd, 4096);
    let bytes = std::fs::read(&path).unwrap();
    let (good, _) = read_all(&path);
    // The header's profile length (a u32 right after the header's frame) says 4 GiB.
    let mut damaged = bytes.clone();
    damaged[17..21].copy_from_slice(&u32::MAX.to_le_bytes());
    std::fs::write(&path, &damaged).unwrap();
    let reader = BagReader::open(&path).unwrap();
    assert_eq!(reader.header(), None);
    let (msgs, _) = read_all(&path);
    assert_eq!(msgs.len(), good.len());
    // A chunk's uncompressed size says 900 MB: its zstd frame disagrees.
    let (start, _, lost) = indexed_chunks(&bytes)[1];
    let mut damaged = bytes.clone();
    damaged[start + 25..start + 33].copy_from_slice(&900_000_000u64.to_le_bytes());
    std::fs::write(&path, &damaged).unwrap();
    let (msgs, issues) = read_all(&path);
    assert_eq!(msgs.len() as u64, good.len() as u64 - lost);
    assert_eq!(issues.len(), 1, "{issues:?}");
    let issue = issues[0].to_string();
    assert!(
        issue.contains("chunk 2") && issue.contains("the chunk says 900000000"),
        "{issue}"
    );
}

/// The messages `messages_where(lo..=hi)` reads, and its issues.
fn read_window(reader: &BagReader, lo: u64, hi: u64) -> (Vec<BagMessage>, Vec<ReadIssue>) {
    let (mut msgs, mut issues) = (Vec::new(), Vec::new());
    for item in reader.messages_where(lo..=hi) {
        match item {
            Ok(m) => msgs.push(m),
            Err(i) => issues.push(i),
        }
    }
    (msgs, issues)
}

/// A full pass's messages logged in `lo..=hi`.
fn filtered(msgs: &[BagMessage], lo: u64, hi: u64) -> Vec<BagMessage> {
    msgs.iter()
        .filter(|m| (lo..=hi).contains(&m.log_time))
        .cloned()
        .collect()
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]
    /// A window reads what a full pass filtered by log time reads, indexes on their channels
    /// included, with and without the summary (which it uses to skip chunks).
    #[test]
    fn a_window_reads_the_messages_a_filtered_full_pass_reads(
        lo in 900u64..1_700,
        len in 0u64..400,
        zstd in proptest::bool::ANY,
    ) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.mcap");
        let compression = if zstd { Compression::Zstd } else { Compression::None };
        write_bag(&path, 600, compression, 1024);
        let hi = lo + len;
        let (all, _) = read_all(&path);
        let reader = BagReader::open(&path).unwrap();
        let (msgs, issues) = read_window(&reader, lo, hi);
        proptest::prop_assert!(issues.is_empty());
        proptest::prop_assert_eq!(&msgs, &filtered(&all, lo, hi));
        // Without its summary: the whole file is read, and it says it was not finished.
        let bytes = std::fs::read(&path).unwrap();
        let cut = dir.path().join("cut.mcap");
        std::fs::write(&cut, &bytes[..data_end(&bytes)]).unwrap();
        let (all_cut, _) = read_all(&cut);
        let (msgs, issues) = read_window(&BagReader::open(&cut).unwrap(), lo, hi);
        proptest::prop_assert_eq!(&msgs, &filtered(&all_cut, lo, hi));
        let unfinished = matches!(issues.as_slice(), [ReadIssue::NoSummary { .. }]);
        proptest::prop_assert!(unfinished);
    }
}

#[test]
fn a_window_skips_the_chunks_outside_it_undecompressed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.mcap");
    write_bag(&path, 600, Compression::Zstd, 1024);
    let mut bytes = std::fs::read(&path).unwrap();
    let chunks = indexed_chunks(&bytes);
    assert!(chunks.len() > 6, "{}", chunks.len());
    // Damage the records of the second chunk (its compressed bytes, near its end).
    let (_, end, _) = chunks[1];
    bytes[end - 8] ^= 0xff;
    bytes[end - 9] ^= 0xff;
    std::fs::write(&path, &bytes).unwrap();
    let (all, issues) = read_all(&path);
    assert_eq!(issues.len(), 1, "{issues:?}");
    let reader = BagReader::open(&path).unwrap();
    // A window over the last messages never opens the damaged chunk: no issue, and the same
    // messages (and indexes) as the full pass, which counted the lost chunk from its index.
    let (msgs, issues) = read_window(&reader, 1_500, 1_599);
    assert!(issues.is_empty(), "{issues:?}");
    assert_eq!(msgs.len(), 100 + 10);
    assert_eq!(msgs, filtered(&all, 1_500, 1_599));
    // A window over the damaged chunk reports it.
    let (_, issues) = read_window(&reader, 1_000, 1_599);
    assert!(
        matches!(
            issues.as_slice(),
            [ReadIssue::CorruptChunk { chunk: 2, .. }]
        ),
        "{issues:?}"
    );
}

/// One call of a writing session, for the property that the writer's own thread changes nothing.
#[derive(Debug, Clone)]
enum Call {
    /// A `Point` on `/a`.
    Point(u64),
    /// Raw bytes (`len` of them) on one of three topics, some far larger than a batch (and some
    /// larger than a batch kept for reuse).
    Raw {
        topic: u8,
        len: usize,
    },
    Metadata,
    Flush,
}

fn calls() -> impl proptest::strategy::Strategy<Value = Vec<Call>> {
    use proptest::prelude::*;
    let call = prop_oneof![
        8 => (0u64..1_000_000).prop_map(Call::Point),
        4 => (0u8..3, 0usize..3_000).prop_map(|(topic, len)| Call::Raw { topic, len }),
        1 => (0u8..3, 60_000usize..400_000).prop_map(|(topic, len)| Call::Raw { topic, len }),
        1 => Just(Call::Metadata),
        1 => Just(Call::Flush),
    ];
    proptest::collection::vec(call, 0..400)
}

/// Makes `calls` on a new bag at `path`; returns what finish says.
fn write_calls(path: &Path, config: WriteConfig, calls: &[Call]) -> BagStats {
    let mut w = BagWriter::create(path, config).unwrap();
    for (i, call) in calls.iter().enumerate() {
        let t = 1_000 + i as u64;
        match call {
            Call::Point(v) => w.write("/a", t, &point(*v)).unwrap(),
            Call::Raw { topic, len } => {
                #[expect(clippy::cast_possible_truncation, reason = "a test pattern")]
                let bytes: Vec<u8> = (0..*len).map(|k| (k * 7 + i) as u8).collect();
                let topic = format!("/raw{topic}");
                let definition = || "uint8[] data".to_string();
                w.write_raw(&topic, "test_msgs/msg/Bytes", definition, t, t + 1, &bytes)
                    .unwrap();
            }
            Call::Metadata => w
                .write_metadata("step", [("at".to_string(), i.to_string())].into())
                .unwrap(),
            Call::Flush => w.flush().unwrap(),
        }
    }
    w.finish().unwrap()
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]

    #[test]
    fn the_writer_thread_writes_the_same_bytes(
        calls in calls(),
        compression in proptest::sample::select(vec![Compression::Zstd, Compression::Lz4, Compression::None]),
        chunk_size_bytes in proptest::sample::select(vec![4096u64, 256 * 1024]),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let (here, thread) = (dir.path().join("here.mcap"), dir.path().join("thread.mcap"));
        let config = |writer_thread| WriteConfig { compression, chunk_size_bytes, writer_thread };
        let here_stats = write_calls(&here, config(false), &calls);
        let thread_stats = write_calls(&thread, config(true), &calls);
        proptest::prop_assert_eq!(here_stats, thread_stats);
        proptest::prop_assert!(std::fs::read(here).unwrap() == std::fs::read(thread).unwrap());
    }
}

/// A sink that refuses to grow past `limit` bytes, as a full disk does; or, with `panics`, panics
/// the first time (a bug below the writer) and refuses after (so that the `mcap` writer's drop,
/// which finishes the file, does not panic again while the thread unwinds).
struct FullDisk {
    inner: std::io::Cursor<Vec<u8>>,
    limit: u64,
    panics: bool,
}

impl FullDisk {
    fn new(limit: u64, panics: bool) -> FullDisk {
        FullDisk {
            inner: std::io::Cursor::new(Vec::new()),
            limit,
            panics,
        }
    }
}

impl Write for FullDisk {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.inner.position() + buf.len() as u64 > self.limit {
            assert!(!std::mem::take(&mut self.panics), "the sink's own bug");
            return Err(std::io::Error::new(
                std::io::ErrorKind::StorageFull,
                "no space left on device",
            ));
        }
        self.inner.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for FullDisk {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.inner.seek(pos)
    }
}

#[test]
fn a_full_disk_stops_the_writer_thread_early_with_the_file_named() {
    const MESSAGES: u64 = 200_000;
    for writer_thread in [false, true] {
        let config = WriteConfig {
            compression: Compression::None,
            chunk_size_bytes: 16 * 1024,
            writer_thread,
        };
        let sink = FullDisk::new(100 * 1024, false);
        let name = Path::new("out/full.mcap");
        let mut w = BagWriter::new(sink, name, config).unwrap();
        let refused = (0..MESSAGES).find_map(|i| w.write("/a", i, &point(i)).err().map(|e| (i, e)));
        let (at, err) = refused.expect("the full disk is reported");
        // About 2,000 messages fill 100 KiB; the thread's queue holds a few 64 KiB batches more.
        assert!(
            at < 30_000,
            "reported at message {at} (writer thread: {writer_thread})"
        );
        let text = format!(
            "{err}: {}",
            std::error::Error::source(&err)
                .map(ToString::to_string)
                .unwrap_or_default()
        );
        assert!(text.contains("out/full.mcap"), "{text}");
        assert!(matches!(err, McapIoError::Mcap { .. }), "{err:?}");
        // With the thread, every later call fails too; either way finishing says so.
        if writer_thread {
            assert!(w.write("/a", MESSAGES, &point(0)).is_err());
        }
        assert!(w.finish().is_err());
    }
}

#[test]
fn a_writer_thread_dropped_unfinished_closes_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dropped.mcap");
    let config = WriteConfig {
        writer_thread: true,
        ..WriteConfig::default()
    };
    let mut w = BagWriter::create(&path, config).unwrap();
    for i in 0..5_000 {
        w.write("/a", i, &point(i)).unwrap();
    }
    drop(w);
    // As an inline writer's drop does, the `mcap` writer ends the file on drop; by the time the
    // drop returns the thread has done so.
    let (msgs, issues) = read_all(&path);
    assert!(issues.is_empty(), "{issues:?}");
    assert_eq!(msgs.len(), 5_000);
}

#[test]
fn a_writer_thread_that_panics_becomes_an_error_for_the_producer() {
    let sink = FullDisk::new(50 * 1024, true);
    let config = WriteConfig {
        compression: Compression::None,
        chunk_size_bytes: 16 * 1024,
        writer_thread: true,
    };
    let mut w = BagWriter::new(sink, Path::new("out/panics.mcap"), config).unwrap();
    let refused = (0..200_000u64).find_map(|i| w.write("/a", i, &point(i)).err());
    let err = refused.expect("the thread's end is reported");
    let text = format!("{err}: {}", std::error::Error::source(&err).unwrap());
    assert!(
        text.contains("out/panics.mcap") && text.contains("panicked"),
        "{text}"
    );
    assert!(w.finish().is_err());
}
