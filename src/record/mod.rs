//! Recording live ROS 2 topics (`autoact record`).
//!
//! [`dds`] is the transport layer: it joins a DDS domain, finds ROS 2 topics by discovery and
//! subscribes to them *without* knowing their Rust types, handing back each sample's raw CDR bytes
//! (with the 4-byte encapsulation header a ROS 2 MCAP `cdr` message needs) plus the RTPS writer
//! GUID and sequence number. [`session`] is the file side: MCAP writing, splits, timed flushes
//! and the per-topic counts of what was lost. [`run`] is the session: discovery, subscriptions,
//! the status line, stopping on a signal or a limit, and finishing the files.
//! [`threads`] is the watchdog that notices when a RustDDS thread has ended.

pub mod dds;
pub mod run;
pub mod session;
pub mod threads;
