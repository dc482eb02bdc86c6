//! The four bag kinds, one module each; each owns its topics, its writer and its reader.
//!
//! | bag | suffix | written by | read by |
//! |---|---|---|---|
//! | [`pose`] | `.pose.mcap` | `import`, `record`, any ROS 2 recorder | `convert` |
//! | [`animation`] | `.anim.mcap` | `convert` | `export`, `convert --spec` |
//! | [`capture`] | `.capture.mcap` | `convert --spec` | `render`, `trim`, `export` |
//! | [`render`] | `.render.mcap` | `render` | `trim` |
//!
//! The MCAP layer under all four (chunks, schemas, metadata, recovery) is [`crate::mcap_io`];
//! [`output`] opens the file a command writes one bag into (bare `.mcap` or rosbag2 directory).

pub mod animation;
pub mod capture;
pub mod output;
pub mod pose;
pub mod render;
