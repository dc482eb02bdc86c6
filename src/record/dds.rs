//! Type-agnostic ROS 2 subscriptions over DDS (RustDDS via `ros2-client`), for recording.
//!
//! A recorder must store topics whose Rust types it does not know, byte for byte. ros2-client has
//! no untyped subscription, so [`Recorder`] goes one level down: it takes the RustDDS
//! `DomainParticipant` out of a `ros2_client::Context` and creates a plain no-key DDS reader per
//! topic with a deserializer adapter that does not decode at all: it keeps the serialized payload
//! and its representation identifier. [`RawSample::cdr`] then re-prefixes the 4-byte
//! encapsulation header, which is exactly what a ROS 2 MCAP message with encoding `cdr` holds.
//!
//! Names: ROS 2 maps topic `/skeleton` to DDS topic `rt/skeleton` and type
//! `autoact_msgs/msg/Skeleton3D` to DDS type `autoact_msgs::msg::dds_::Skeleton3D_`; see
//! [`ros_to_dds_topic`], [`ros_to_dds_type`] and their inverses.
//!
//! Every sample carries the RTPS writer GUID and the writer's sequence number. A writer numbers
//! its samples 1, 2, 3, ... so a gap between two samples of the same writer is a drop (for
//! example the reader history overflowed because the recorder fell behind).
//!
//! Starting a [`Recorder`] sends DDS discovery traffic (multicast) on every multicast-capable
//! interface. Tests run it only inside a network namespace (`tools/dds/netns.sh`), never in
//! `cargo test`.

use std::collections::BTreeSet;
use std::convert::Infallible;
use std::path::Path;
use std::time::Duration;

use ros2_client::dds::rustdds::{
    self, DomainParticipant, DomainParticipantBuilder, QosPolicies, QosPolicyBuilder,
    RepresentationIdentifier, Subscriber, Timestamp, TopicKind, mio1, no_key, policy,
};

use super::threads::{PROC_SELF_TASK, RUSTDDS_THREADS, TaskSnapshot, ThreadWatch};

/// DDS reliability requested by the recorder's readers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reliability {
    /// Lost samples are resent. Matches only reliable writers (the ROS 2 default for topics).
    Reliable,
    /// No resends. Matches every writer, reliable or best-effort (e.g. sensor-data QoS).
    BestEffort,
}

/// DDS durability requested by the recorder's readers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Durability {
    /// Only samples published after the match. Matches volatile and transient-local writers.
    Volatile,
    /// Also the writer's retained history at match time. Matches only transient-local writers.
    TransientLocal,
}

/// How the recorder joins DDS: the domain and the QoS of every reader it creates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DdsConfig {
    /// DDS domain id (`ROS_DOMAIN_ID`).
    pub domain_id: u16,
    /// Reader reliability.
    pub reliability: Reliability,
    /// Reader durability.
    pub durability: Durability,
    /// Reader history: keep-last depth (samples held per topic until [`Recorder::take`]), or
    /// `None` for [`default_history_depth`] of each topic's type.
    pub history_depth: Option<i32>,
}

impl Default for DdsConfig {
    /// Domain 0, reliable, volatile, keep-last by type (see [`DdsConfig::from_env`]).
    fn default() -> Self {
        Self {
            domain_id: 0,
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            history_depth: None,
        }
    }
}

/// The recorder's keep-last depth for a topic of ROS type `type_name`, when `--depth` is not
/// given: 1,000 samples (10 s of a 100 Hz topic), or 100 for images, compressed video and point
/// clouds.
///
/// RustDDS's topic cache keeps the last `depth` samples whether or not they were taken, so the
/// depth is both the memory a topic holds and the backlog the recorder absorbs when it falls
/// behind (a Ctrl-Z and `fg`, a slow disk): what a backlog pushes out of it before it is taken
/// is lost, and counted as dropped. Skeletons, markers and transforms are a few KB, so 1,000 of
/// them cost a few MB; a 640×480 rgb8 image is 0.9 MB, so 100 of them already hold 90 MB. At
/// 100 for every type, a 3 s stop of a 50 Hz topic lost the 50 oldest samples of its backlog
/// in every run; at 1,000, none (`tools/dds/check_record.sh sigstop`).
#[must_use]
pub fn default_history_depth(type_name: &str) -> i32 {
    if LARGE_SAMPLE_TYPES.contains(&type_name) {
        LARGE_SAMPLE_DEPTH
    } else {
        SMALL_SAMPLE_DEPTH
    }
}

/// Types whose samples are large (images, video, point clouds): [`LARGE_SAMPLE_DEPTH`].
const LARGE_SAMPLE_TYPES: [&str; 4] = [
    "sensor_msgs/msg/Image",
    "sensor_msgs/msg/CompressedImage",
    "sensor_msgs/msg/PointCloud2",
    "foxglove_msgs/msg/CompressedVideo",
];
const LARGE_SAMPLE_DEPTH: i32 = 100;
const SMALL_SAMPLE_DEPTH: i32 = 1000;

/// The keep-last depth `--depth` gave, or the per-type rule, as text (for the bag's metadata).
#[must_use]
pub fn describe_depth(history_depth: Option<i32>) -> String {
    history_depth.map_or_else(
        || {
            format!(
                "{SMALL_SAMPLE_DEPTH} ({LARGE_SAMPLE_DEPTH} for {})",
                LARGE_SAMPLE_TYPES.join(", ")
            )
        },
        |d| d.to_string(),
    )
}

/// Largest domain id ROS 2 / DDS port mapping allows (7400 + 250 * id must fit the port range).
const MAX_DOMAIN_ID: u16 = 232;

impl DdsConfig {
    /// The recorder's defaults, with the domain from `ROS_DOMAIN_ID` (unset or empty: 0).
    ///
    /// - **Reliable**: a recorder should not lose samples to the network; reliable is the ROS 2
    ///   default for publishers. (A reliable reader does not match a best-effort writer: record
    ///   sensor-data topics with [`Reliability::BestEffort`].)
    /// - **Volatile**: a volatile reader matches both volatile and transient-local writers,
    ///   whereas a transient-local reader would not match the (default) volatile writers at all.
    /// - **Keep-last by type** ([`default_history_depth`]): bounds memory per topic, and gives
    ///   the recorder 10 s of slack at 100 Hz on pose, marker and transform topics (1 s on
    ///   images) before the oldest samples are overwritten (which then shows up as a
    ///   sequence-number gap).
    ///
    /// An invalid `ROS_DOMAIN_ID` is logged (`tracing::warn`) and domain 0 is used; use
    /// [`parse_domain_id`] to reject it instead.
    #[must_use]
    pub fn from_env() -> DdsConfig {
        let value = std::env::var("ROS_DOMAIN_ID").ok();
        let domain_id = parse_domain_id(value.as_deref()).unwrap_or_else(|e| {
            tracing::warn!("{e}; using domain 0");
            0
        });
        DdsConfig {
            domain_id,
            ..DdsConfig::default()
        }
    }

    /// The keep-last depth of a topic of ROS type `type_name`: `--depth`, or its type's default.
    #[must_use]
    pub fn depth_for(&self, type_name: &str) -> i32 {
        self.history_depth
            .unwrap_or_else(|| default_history_depth(type_name))
            .max(1)
    }

    /// The QoS of a reader (and its topic) keeping the last `depth` samples.
    fn qos(self, depth: i32) -> QosPolicies {
        let builder = QosPolicyBuilder::new()
            .durability(match self.durability {
                Durability::Volatile => policy::Durability::Volatile,
                Durability::TransientLocal => policy::Durability::TransientLocal,
            })
            .history(policy::History::KeepLast {
                depth: depth.max(1),
            });
        match self.reliability {
            Reliability::Reliable => builder.reliable(rustdds::Duration::from_millis(100)),
            Reliability::BestEffort => builder.best_effort(),
        }
        .build()
    }
}

/// Parses a `ROS_DOMAIN_ID` value: `None` or blank is domain 0; otherwise an integer 0..=232.
///
/// # Errors
/// [`DdsError::DomainId`] naming the value if it is not such an integer.
pub fn parse_domain_id(value: Option<&str>) -> Result<u16, DdsError> {
    let Some(text) = value.map(str::trim).filter(|t| !t.is_empty()) else {
        return Ok(0);
    };
    text.parse::<u16>()
        .ok()
        .filter(|id| *id <= MAX_DOMAIN_ID)
        .ok_or_else(|| DdsError::DomainId {
            value: text.to_owned(),
        })
}

/// Errors of the DDS layer; each names the domain, topic or type concerned.
#[derive(thiserror::Error, Debug)]
pub enum DdsError {
    /// `ROS_DOMAIN_ID` is not an integer in 0..=232.
    #[error("ROS_DOMAIN_ID={value:?} is not a DDS domain id (an integer 0..=232)")]
    DomainId {
        /// The rejected value.
        value: String,
    },
    /// The DDS participant (or its ROS 2 context) could not be created.
    #[error("cannot join DDS domain {domain_id}")]
    Participant {
        /// Domain that was joined.
        domain_id: u16,
        /// RustDDS / ros2-client error.
        #[source]
        source: ros2_client::error::CreateError,
    },
    /// The ROS topic name is not usable (empty, or a DDS name).
    #[error("{topic:?} is not a ROS 2 topic name (expected e.g. \"/skeleton\")")]
    TopicName {
        /// The rejected name.
        topic: String,
    },
    /// The ROS type name is not `package/msg/Type`.
    #[error("{type_name:?} (topic {topic}) is not a ROS 2 type name (expected package/msg/Type)")]
    TypeName {
        /// Topic it was requested for.
        topic: String,
        /// The rejected type name.
        type_name: String,
    },
    /// The topic is already subscribed with another type.
    #[error(
        "topic {topic} is already recorded as {existing}, cannot also record it as {requested}"
    )]
    TypeConflict {
        /// The topic.
        topic: String,
        /// Type of the existing subscription.
        existing: String,
        /// Type asked for now.
        requested: String,
    },
    /// Creating the DDS topic or reader failed.
    #[error("cannot subscribe to {topic} ({type_name}) in DDS domain {domain_id}")]
    Subscribe {
        /// The ROS topic.
        topic: String,
        /// The ROS type.
        type_name: String,
        /// Domain of the participant.
        domain_id: u16,
        /// RustDDS error.
        #[source]
        source: ros2_client::error::CreateError,
    },
    /// Registering a reader with the poller failed.
    #[error("cannot poll the DDS reader of {topic}")]
    Poll {
        /// The ROS topic.
        topic: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A RustDDS thread ended: nothing more can be received (RustDDS's log above says why).
    #[error(
        "the RustDDS {role} of the participant in DDS domain {domain_id} has ended \
         (thread {prefix:?}: {running} of {started} running); nothing more can be received"
    )]
    ThreadEnded {
        /// What the thread did.
        role: String,
        /// Its name prefix in `/proc/self/task/*/comm`.
        prefix: String,
        /// Domain of the participant.
        domain_id: u16,
        /// Threads of that name when the recorder started.
        started: usize,
        /// Threads of that name now.
        running: usize,
    },
}

/// One sample as received: raw CDR plus what a recorder needs to place and check it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawSample {
    /// ROS topic, e.g. `/skeleton`.
    pub topic: String,
    /// ROS type, e.g. `autoact_msgs/msg/Skeleton3D`.
    pub type_name: String,
    /// Encapsulation header (`00 01 00 00` CDR little-endian, `00 00 00 00` big-endian) + payload:
    /// the bytes of a ROS 2 MCAP message with encoding `cdr`.
    pub cdr: Vec<u8>,
    /// Wall-clock time the DDS layer received the sample, ns since the UNIX epoch.
    pub receive_time_nanos: u64,
    /// The writer's source timestamp, ns since the UNIX epoch, if it sent one.
    pub source_time_nanos: Option<u64>,
    /// RTPS GUID of the writer (participant prefix + entity id).
    pub writer: [u8; 16],
    /// RTPS sequence number of the sample within its writer (1, 2, 3, ...; gaps are drops).
    pub sequence_number: i64,
}

/// DDS topic of a ROS topic: `/skeleton` → `rt/skeleton` (a missing leading `/` is assumed).
#[must_use]
pub fn ros_to_dds_topic(topic: &str) -> String {
    format!("rt/{}", topic.trim_start_matches('/'))
}

/// ROS topic of a DDS topic: `rt/skeleton` → `/skeleton`; `None` for non-topic DDS names
/// (services `rq/`/`rr/`, `ros_discovery_info`, ...).
#[must_use]
pub fn dds_to_ros_topic(dds_topic: &str) -> Option<String> {
    dds_topic
        .strip_prefix("rt/")
        .filter(|rest| !rest.is_empty())
        .map(|rest| format!("/{rest}"))
}

/// DDS type of a ROS type: `autoact_msgs/msg/Skeleton3D` →
/// `autoact_msgs::msg::dds_::Skeleton3D_`; `None` unless it is `package/kind/Name`.
#[must_use]
pub fn ros_to_dds_type(type_name: &str) -> Option<String> {
    let parts: Vec<&str> = type_name.split('/').collect();
    match parts.as_slice() {
        [package, kind, name] if [package, kind, name].iter().all(|p| is_identifier(p)) => {
            Some(format!("{package}::{kind}::dds_::{name}_"))
        }
        _ => None,
    }
}

/// ROS type of a DDS type: `autoact_msgs::msg::dds_::Skeleton3D_` →
/// `autoact_msgs/msg/Skeleton3D`; `None` for types not named the ROS 2 way.
#[must_use]
pub fn dds_to_ros_type(dds_type: &str) -> Option<String> {
    let parts: Vec<&str> = dds_type.split("::").collect();
    match parts.as_slice() {
        [package, kind, "dds_", name_] => {
            let name = name_.strip_suffix('_')?;
            [package, kind, name]
                .iter()
                .all(|p| is_identifier(p))
                .then(|| format!("{package}/{kind}/{name}"))
        }
        _ => None,
    }
}

fn is_identifier(part: &str) -> bool {
    !part.is_empty() && part.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// ROS 2 topics that are infrastructure, not data worth recording by default.
fn is_infrastructure_topic(ros_topic: &str) -> bool {
    ros_topic == "/rosout"
        || ros_topic == "/parameter_events"
        || ros_topic.ends_with("/_action/status")
        || ros_topic.ends_with("/_action/feedback")
}

/// The encapsulation header + payload of a ROS 2 `cdr` message: representation id (2 bytes),
/// options `00 00` (RustDDS does not expose the received options), then the payload.
#[must_use]
pub fn with_encapsulation_header(representation: [u8; 2], payload: &[u8]) -> Vec<u8> {
    let mut cdr = Vec::with_capacity(4 + payload.len());
    cdr.extend_from_slice(&representation);
    cdr.extend_from_slice(&[0, 0]);
    cdr.extend_from_slice(payload);
    cdr
}

/// RTPS time (NTP-style 32.32 fixed point, UNIX epoch) → ns since the UNIX epoch.
#[must_use]
pub fn rtps_ticks_to_nanos(ticks: u64) -> u64 {
    let seconds = ticks >> 32;
    let fraction = ticks & 0xFFFF_FFFF;
    seconds * 1_000_000_000 + ((fraction * 1_000_000_000) >> 32)
}

fn timestamp_nanos(t: Timestamp) -> Option<u64> {
    (t != Timestamp::INVALID && t != Timestamp::INFINITE && t != Timestamp::ZERO)
        .then(|| rtps_ticks_to_nanos(t.to_ticks()))
}

/// A received sample before naming: representation id and payload (no header).
struct RawPayload {
    representation: [u8; 2],
    payload: Vec<u8>,
}

/// RustDDS deserializer adapter that keeps the bytes. Plain CDR only: ROS 2 MCAP `cdr` means
/// XCDR1, so XCDR2 / parameter-list payloads are refused (RustDDS reports them as errors).
struct RawAdapter;

const RAW_ENCODINGS: [RepresentationIdentifier; 2] = [
    RepresentationIdentifier::CDR_LE,
    RepresentationIdentifier::CDR_BE,
];

impl no_key::DeserializerAdapter<RawPayload> for RawAdapter {
    type Error = Infallible;
    type Decoded = RawPayload;

    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &RAW_ENCODINGS
    }

    fn transform_decoded(decoded: RawPayload) -> RawPayload {
        decoded
    }
}

/// The adapter's decoder: copies the payload out of RustDDS's buffer.
#[derive(Clone, Copy)]
struct RawDecoder;

impl<'de> no_key::Decode<'de, RawPayload> for RawDecoder {
    type Error = Infallible;

    fn decode_bytes(
        self,
        input_bytes: &'de [u8],
        encoding: RepresentationIdentifier,
    ) -> Result<RawPayload, Infallible> {
        Ok(RawPayload {
            representation: encoding.to_bytes(),
            payload: input_bytes.to_vec(),
        })
    }
}

impl no_key::DefaultDecoder<RawPayload> for RawAdapter {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

struct Subscription {
    topic: String,
    type_name: String,
    reader: no_key::SimpleDataReader<RawPayload, RawAdapter>,
}

/// One DDS participant that records ROS 2 topics as raw CDR.
///
/// Fields drop in declaration order: readers before their subscriber before the participant, so
/// RustDDS can still deregister each reader.
pub struct Recorder {
    subscriptions: Vec<Subscription>,
    poll: mio1::Poll,
    events: mio1::Events,
    subscriber: Subscriber,
    participant: DomainParticipant,
    /// Keeps the ROS 2 context (which owns the participant) alive.
    _context: ros2_client::Context,
    config: DdsConfig,
    domain_id: u16,
    rejected: u64,
    threads: ThreadWatch,
}

impl Recorder {
    /// Joins DDS domain `config.domain_id` with one participant.
    ///
    /// # Errors
    /// [`DdsError::Participant`] if RustDDS cannot create the participant or its subscriber.
    pub fn new(config: &DdsConfig) -> Result<Recorder, DdsError> {
        let domain_id = config.domain_id;
        let err = |source| DdsError::Participant { domain_id, source };
        // RustDDS's threads start while the participant is built: the watchdog takes those.
        let before = TaskSnapshot::now(Path::new(PROC_SELF_TASK));
        let participant = DomainParticipantBuilder::new(domain_id)
            .build()
            .map_err(|e| err(e.into()))?;
        let context = ros2_client::Context::from_domain_participant(participant).map_err(err)?;
        let participant = context.domain_participant();
        // Every reader gets its own QoS (its depth depends on its type): the subscriber's history
        // is overridden by each.
        let subscriber = participant
            .create_subscriber(&config.qos(1))
            .map_err(|e| err(e.into()))?;
        let poll = mio1::Poll::new().map_err(|source| DdsError::Poll {
            topic: "(none)".to_owned(),
            source,
        })?;
        let threads =
            ThreadWatch::started_since(Path::new(PROC_SELF_TASK), &before, &RUSTDDS_THREADS);
        for prefix in threads.unwatched() {
            tracing::warn!(
                "cannot watch the RustDDS thread {prefix:?} in {PROC_SELF_TASK}: \
                 if it ended, the recording would not notice"
            );
        }
        Ok(Recorder {
            threads,
            _context: context,
            participant,
            subscriber,
            config: *config,
            domain_id,
            subscriptions: Vec::new(),
            poll,
            events: mio1::Events::with_capacity(64),
            rejected: 0,
        })
    }

    /// The DDS domain joined.
    #[must_use]
    pub fn domain_id(&self) -> u16 {
        self.domain_id
    }

    /// ROS topics (e.g. `/skeleton`) and ROS type names (e.g. `autoact_msgs/msg/Skeleton3D`)
    /// that remote writers (or announced topics) have shown so far, sorted and deduplicated.
    /// Services, actions' internal topics, `/rosout` and `/parameter_events` are skipped, as are
    /// names that are not ROS 2 names.
    #[must_use]
    pub fn discovered(&self) -> Vec<(String, String)> {
        let writers = self.participant.discovered_writers().into_iter().map(|w| {
            (
                w.publication_topic_data.topic_name,
                w.publication_topic_data.type_name,
            )
        });
        let topics = self
            .participant
            .discovered_topics()
            .into_iter()
            .map(|t| (t.topic_name().clone(), t.type_name().clone()));
        writers
            .chain(topics)
            .filter_map(|(topic, type_name)| {
                let topic = dds_to_ros_topic(&topic)?;
                let type_name = dds_to_ros_type(&type_name)?;
                (!is_infrastructure_topic(&topic)).then_some((topic, type_name))
            })
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect()
    }

    /// Subscribes to ROS topic `topic` of ROS type `type_name`, raw (no Rust type needed).
    /// Subscribing again with the same type does nothing.
    ///
    /// # Errors
    /// [`DdsError::TopicName`] / [`DdsError::TypeName`] for malformed names,
    /// [`DdsError::TypeConflict`] if the topic is already recorded as another type,
    /// [`DdsError::Subscribe`] / [`DdsError::Poll`] if RustDDS or the poller refuse.
    pub fn subscribe(&mut self, topic: &str, type_name: &str) -> Result<(), DdsError> {
        let bare = topic.trim_start_matches('/');
        if bare.is_empty() || bare.starts_with("rt/") || topic.contains(char::is_whitespace) {
            return Err(DdsError::TopicName {
                topic: topic.to_owned(),
            });
        }
        let ros_topic = format!("/{bare}");
        let dds_type = ros_to_dds_type(type_name).ok_or_else(|| DdsError::TypeName {
            topic: ros_topic.clone(),
            type_name: type_name.to_owned(),
        })?;
        if let Some(existing) = self.subscriptions.iter().find(|s| s.topic == ros_topic) {
            return if existing.type_name == type_name {
                Ok(())
            } else {
                Err(DdsError::TypeConflict {
                    topic: ros_topic,
                    existing: existing.type_name.clone(),
                    requested: type_name.to_owned(),
                })
            };
        }
        let err = |source: rustdds::dds::CreateError| DdsError::Subscribe {
            topic: ros_topic.clone(),
            type_name: type_name.to_owned(),
            domain_id: self.domain_id,
            source: source.into(),
        };
        let depth = self.config.depth_for(type_name);
        let qos = self.config.qos(depth);
        let dds_topic = self
            .participant
            .create_topic(
                ros_to_dds_topic(&ros_topic),
                dds_type,
                &qos,
                TopicKind::NoKey,
            )
            .map_err(err)?;
        // Adapt to what the publishers offer: a reliable reader never matches a best-effort
        // writer (sensor-data QoS), so a topic with one gets a best-effort reader.
        let dds_name = ros_to_dds_topic(&ros_topic);
        let best_effort_writer = self.participant.discovered_writers().iter().any(|w| {
            w.publication_topic_data.topic_name == dds_name
                && matches!(
                    w.publication_topic_data.reliability,
                    Some(policy::Reliability::BestEffort)
                )
        });
        let reader_qos = if best_effort_writer && self.config.reliability == Reliability::Reliable {
            tracing::info!(
                "{ros_topic}: a publisher offers best-effort only; recording it best-effort"
            );
            DdsConfig {
                reliability: Reliability::BestEffort,
                ..self.config
            }
            .qos(depth)
        } else {
            qos
        };
        let mut reader = self
            .subscriber
            .create_simple_datareader_no_key::<RawPayload, RawAdapter>(&dds_topic, Some(reader_qos))
            .map_err(err)?;
        self.poll
            .registry()
            .register(
                &mut reader,
                mio1::Token(self.subscriptions.len()),
                mio1::Interest::READABLE,
            )
            .map_err(|source| DdsError::Poll {
                topic: ros_topic.clone(),
                source,
            })?;
        tracing::debug!(topic = %ros_topic, type_name, "subscribed");
        self.subscriptions.push(Subscription {
            topic: ros_topic,
            type_name: type_name.to_owned(),
            reader,
        });
        Ok(())
    }

    /// Takes every sample received so far on every subscription (non-blocking), in arrival order
    /// per topic, topics in subscription order.
    ///
    /// Samples RustDDS cannot hand over (e.g. a writer using XCDR2, which a ROS 2 `cdr` MCAP
    /// cannot hold) are skipped with a warning and counted in [`Recorder::rejected`].
    pub fn take(&mut self) -> Vec<RawSample> {
        let mut out = Vec::new();
        for sub in &self.subscriptions {
            sub.reader.drain_read_notifications();
            loop {
                match sub.reader.try_take_one() {
                    Ok(Some(change)) => out.push(RawSample {
                        topic: sub.topic.clone(),
                        type_name: sub.type_name.clone(),
                        cdr: with_encapsulation_header(
                            change.sample.representation,
                            &change.sample.payload,
                        ),
                        receive_time_nanos: timestamp_nanos(change.receive_instant)
                            .unwrap_or_else(now_nanos),
                        source_time_nanos: change
                            .write_options
                            .source_timestamp()
                            .and_then(timestamp_nanos),
                        writer: change.writer_guid.to_bytes(),
                        sequence_number: change.sequence_number.into(),
                    }),
                    Ok(None) => break,
                    Err(rustdds::dds::ReadError::Deserialization { reason }) => {
                        // RustDDS has advanced past the sample; keep reading.
                        self.rejected += 1;
                        tracing::warn!(topic = %sub.topic, "sample not recorded: {reason}");
                    }
                    Err(e) => {
                        tracing::warn!(topic = %sub.topic, "reading stopped: {e}");
                        break;
                    }
                }
            }
        }
        out
    }

    /// Samples skipped so far because they were not plain CDR (see [`Recorder::take`]).
    #[must_use]
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// Whether RustDDS can still receive: its event loop and discovery threads still run (see
    /// [`super::threads`]; on Linux, where `/proc/self/task` lists them).
    ///
    /// # Errors
    /// [`DdsError::ThreadEnded`] naming the first thread that has ended since [`Recorder::new`].
    pub fn check_alive(&self) -> Result<(), DdsError> {
        match self.threads.check() {
            None => Ok(()),
            Some(ended) => Err(DdsError::ThreadEnded {
                role: ended.role,
                prefix: ended.prefix,
                domain_id: self.domain_id,
                started: ended.started,
                running: ended.running,
            }),
        }
    }

    /// Blocks up to `timeout` until a reader signals new data; returns whether anything may be
    /// ready for [`Recorder::take`] (spurious `true` is possible, `false` means timeout).
    pub fn wait(&mut self, timeout: Duration) -> bool {
        if self.subscriptions.is_empty() {
            std::thread::sleep(timeout);
            return false;
        }
        match self.poll.poll(&mut self.events, Some(timeout)) {
            Ok(()) => !self.events.is_empty(),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => true,
            Err(e) => {
                tracing::warn!("DDS poll failed: {e}");
                std::thread::sleep(timeout.min(Duration::from_millis(10)));
                true
            }
        }
    }
}

fn now_nanos() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topic_names_round_trip() {
        assert_eq!(ros_to_dds_topic("/skeleton"), "rt/skeleton");
        assert_eq!(ros_to_dds_topic("skeleton/markers"), "rt/skeleton/markers");
        assert_eq!(ros_to_dds_topic("/ns/a/b"), "rt/ns/a/b");
        assert_eq!(
            dds_to_ros_topic("rt/skeleton").as_deref(),
            Some("/skeleton")
        );
        assert_eq!(
            dds_to_ros_topic("rt/skeleton/markers").as_deref(),
            Some("/skeleton/markers")
        );
        for t in ["/skeleton", "/skeleton/markers", "/a_b/c1"] {
            assert_eq!(dds_to_ros_topic(&ros_to_dds_topic(t)).as_deref(), Some(t));
        }
    }

    #[test]
    fn non_topic_dds_names_are_not_ros_topics() {
        for name in [
            "ros_discovery_info",
            "rq/add_two_intsRequest",
            "rr/xReply",
            "rt/",
            "skeleton",
        ] {
            assert_eq!(dds_to_ros_topic(name), None, "{name}");
        }
    }

    #[test]
    fn type_names_round_trip() {
        assert_eq!(
            ros_to_dds_type("autoact_msgs/msg/Skeleton3D").as_deref(),
            Some("autoact_msgs::msg::dds_::Skeleton3D_")
        );
        assert_eq!(
            dds_to_ros_type("visualization_msgs::msg::dds_::MarkerArray_").as_deref(),
            Some("visualization_msgs/msg/MarkerArray")
        );
        for t in [
            "std_msgs/msg/String",
            "example_interfaces/srv/AddTwoInts_Request",
        ] {
            assert_eq!(
                dds_to_ros_type(&ros_to_dds_type(t).unwrap_or_default()).as_deref(),
                Some(t)
            );
        }
    }

    #[test]
    fn malformed_type_names_are_refused() {
        for t in [
            "Skeleton3D",
            "autoact_msgs/Skeleton3D",
            "a/msg/B/C",
            "a//B",
            "a/msg/B C",
        ] {
            assert_eq!(ros_to_dds_type(t), None, "{t}");
        }
        for t in [
            "autoact_msgs::msg::Skeleton3D_",
            "autoact_msgs::msg::dds_::Skeleton3D",
            "DCPSParticipant",
            "rmw_dds_common::msg::dds_::_",
        ] {
            assert_eq!(dds_to_ros_type(t), None, "{t}");
        }
    }

    #[test]
    fn infrastructure_topics_are_recognised() {
        assert!(is_infrastructure_topic("/rosout"));
        assert!(is_infrastructure_topic("/parameter_events"));
        assert!(is_infrastructure_topic("/fibonacci/_action/status"));
        assert!(!is_infrastructure_topic("/skeleton"));
    }

    #[test]
    fn encapsulation_header_is_rebuilt() {
        let le = with_encapsulation_header(RepresentationIdentifier::CDR_LE.to_bytes(), &[7, 8]);
        assert_eq!(le, [0x00, 0x01, 0x00, 0x00, 7, 8]);
        let be = with_encapsulation_header(RepresentationIdentifier::CDR_BE.to_bytes(), &[]);
        assert_eq!(be, [0x00, 0x00, 0x00, 0x00]);
    }

    #[test]
    fn adapter_keeps_bytes_and_representation() {
        use no_key::DeserializerAdapter as _;
        // std_msgs/String "hi": u32 length 3, "hi\0".
        let payload = [3, 0, 0, 0, b'h', b'i', 0];
        let Ok(raw) = RawAdapter::from_bytes(&payload, RepresentationIdentifier::CDR_LE);
        assert_eq!(raw.representation, [0, 1]);
        assert_eq!(raw.payload, payload);
        let cdr = with_encapsulation_header(raw.representation, &raw.payload);
        let (text, used) = cdr_encoding::from_bytes::<String, byteorder::LittleEndian>(&cdr[4..])
            .unwrap_or_default();
        assert_eq!((text.as_str(), used), ("hi", payload.len()));
        assert!(!RawAdapter::supported_encodings().contains(&RepresentationIdentifier::XCDR2_LE));
    }

    #[test]
    fn rtps_time_converts_to_unix_nanos() {
        assert_eq!(rtps_ticks_to_nanos(0), 0);
        assert_eq!(rtps_ticks_to_nanos(5 << 32), 5_000_000_000);
        assert_eq!(rtps_ticks_to_nanos((1 << 32) | (1 << 31)), 1_500_000_000);
        // A realistic instant: 2026-01-01T00:00:00.25Z.
        assert_eq!(
            rtps_ticks_to_nanos((1_767_225_600 << 32) | (1 << 30)),
            1_767_225_600_250_000_000
        );
        assert_eq!(timestamp_nanos(Timestamp::INVALID), None);
    }

    #[test]
    fn domain_id_parsing() {
        assert_eq!(parse_domain_id(None).ok(), Some(0));
        assert_eq!(parse_domain_id(Some("")).ok(), Some(0));
        assert_eq!(parse_domain_id(Some(" 42 ")).ok(), Some(42));
        assert_eq!(parse_domain_id(Some("232")).ok(), Some(232));
        for bad in ["233", "-1", "x", "70000"] {
            let e = parse_domain_id(Some(bad)).err().map(|e| e.to_string());
            assert!(e.is_some_and(|m| m.contains(bad)), "{bad}");
        }
    }

    #[test]
    fn default_qos_is_reliable_volatile_keep_last_by_type() {
        let c = DdsConfig::default();
        assert_eq!(
            (c.reliability, c.durability, c.history_depth),
            (Reliability::Reliable, Durability::Volatile, None)
        );
        assert_eq!(c.depth_for("autoact_msgs/msg/Skeleton3D"), 1000);
        assert_eq!(c.depth_for("tf2_msgs/msg/TFMessage"), 1000);
        assert_eq!(c.depth_for("sensor_msgs/msg/Image"), 100);
        assert_eq!(c.depth_for("sensor_msgs/msg/PointCloud2"), 100);
        let given = DdsConfig {
            history_depth: Some(7),
            ..c
        };
        assert_eq!(given.depth_for("autoact_msgs/msg/Skeleton3D"), 7);
        assert_eq!(given.depth_for("sensor_msgs/msg/Image"), 7);
        assert_eq!(describe_depth(Some(7)), "7");
        assert!(describe_depth(None).starts_with("1000 (100 for sensor_msgs/msg/Image, "));
        let qos = c.qos(c.depth_for("sensor_msgs/msg/Image"));
        assert_eq!(
            qos.history(),
            Some(policy::History::KeepLast { depth: 100 })
        );
        assert_eq!(qos.durability(), Some(policy::Durability::Volatile));
        assert!(matches!(
            qos.reliability(),
            Some(policy::Reliability::Reliable { .. })
        ));
    }
}
