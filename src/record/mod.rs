//! `autoact record`: live ROS 2 topics into MCAP.

pub mod session;
