//! Manual probe of `autoact::record::dds`: subscribes to ROS 2 topics for a while with
//! [`Recorder`] and prints one JSON line per received sample on stdout
//! (`topic`, `type`, `writer`, `seq`, `len`, `receive_nanos`, `source_nanos`, and with `--hex` the CDR
//! bytes incl. the encapsulation header). A summary line goes to stderr at the end
//! (`samples`, `rejected`, `first_sample_s`, `discovered`).
//!
//! Usage: `dds_record_probe [--seconds T] [--hex] [--until N] [--all] TOPIC=TYPE...`
//!   e.g. `dds_record_probe --seconds 5 /skeleton=autoact_msgs/msg/Skeleton3D`
//! `--until N` stops early once N samples arrived. `--all` also subscribes to every topic
//! [`Recorder::discovered`] reports while it runs (the discover-then-subscribe path of
//! `autoact record --all`). `--stall-ms M` sleeps M ms before each take instead of waiting for
//! data (a recorder falling behind: the keep-last history overflows and sequence numbers gap).
//! The domain comes from `ROS_DOMAIN_ID`.
//!
//! It starts DDS: run it only inside a network namespace (`tools/dds/netns.sh`).

#![expect(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a probe prints what it received"
)]

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};
use autoact::record::dds::{DdsConfig, Recorder};

fn main() -> anyhow::Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();

    let mut seconds = 5.0_f64;
    let mut hex = false;
    let mut all = false;
    let mut stall_ms = 0_u64;
    let mut until = usize::MAX;
    let mut topics = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--seconds" => {
                seconds = args.next().context("--seconds needs a value")?.parse()?;
            }
            "--until" => until = args.next().context("--until needs a value")?.parse()?,
            "--hex" => hex = true,
            "--all" => all = true,
            "--stall-ms" => stall_ms = args.next().context("--stall-ms needs a value")?.parse()?,
            _ => {
                let (topic, type_name) = arg
                    .split_once('=')
                    .with_context(|| format!("{arg:?} is not TOPIC=TYPE"))?;
                topics.push((topic.to_owned(), type_name.to_owned()));
            }
        }
    }
    if (topics.is_empty() && !all) || !(0.0..=3600.0).contains(&seconds) {
        bail!(
            "usage: dds_record_probe [--seconds T<=3600] [--hex] [--until N] [--all] [--stall-ms M] TOPIC=TYPE..."
        );
    }

    let start = Instant::now();
    let mut recorder = Recorder::new(&DdsConfig::from_env())?;
    for (topic, type_name) in &topics {
        recorder.subscribe(topic, type_name)?;
    }
    let deadline = start + Duration::from_secs_f64(seconds);
    let mut count = 0_usize;
    let mut first_sample_s = None;
    while count < until {
        let now = Instant::now();
        if now >= deadline {
            break;
        }
        if all {
            for (topic, type_name) in recorder.discovered() {
                if !topics.iter().any(|(t, _)| *t == topic) {
                    recorder.subscribe(&topic, &type_name)?;
                    eprintln!(
                        "{}",
                        serde_json::json!({
                            "subscribed": topic,
                            "type": type_name,
                            "after_s": start.elapsed().as_secs_f64(),
                        })
                    );
                    topics.push((topic, type_name));
                }
            }
        }
        if stall_ms > 0 {
            std::thread::sleep(Duration::from_millis(stall_ms).min(deadline - now));
        } else {
            recorder.wait((deadline - now).min(Duration::from_millis(if all { 10 } else { 100 })));
        }
        for s in recorder.take() {
            first_sample_s.get_or_insert_with(|| start.elapsed().as_secs_f64());
            count += 1;
            let mut line = serde_json::json!({
                "topic": s.topic,
                "type": s.type_name,
                "writer": s.writer.iter().fold(String::new(), |mut h, b| {
                    let _ = write!(h, "{b:02x}");
                    h
                }),
                "seq": s.sequence_number,
                "len": s.cdr.len(),
                "receive_ns": s.receive_time_nanos,
                "source_ns": s.source_time_nanos,
            });
            if hex {
                line["cdr"] = s
                    .cdr
                    .iter()
                    .fold(String::new(), |mut h, b| {
                        let _ = write!(h, "{b:02x}");
                        h
                    })
                    .into();
            }
            println!("{line}");
        }
    }
    eprintln!(
        "{}",
        serde_json::json!({
            "samples": count,
            "rejected": recorder.rejected(),
            "first_sample_s": first_sample_s,
            "elapsed_s": start.elapsed().as_secs_f64(),
            "discovered": recorder.discovered(),
        })
    );
    Ok(())
}
