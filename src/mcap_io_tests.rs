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
