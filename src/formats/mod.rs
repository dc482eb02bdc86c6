//! Readers for the motion-capture and skeleton file formats autoact imports.
//!
//! Each reader is its own module with its own error type; errors name the file and the line,
//! frame or field that was wrong. Readers produce [`crate::pose::PoseSequence`]s in the autoact
//! frame (converting axes once, through [`crate::frames::SourceAxes`]) and in metres.

pub mod bvh;
pub mod bvh_map;
pub mod h36m_expmap;
pub mod mmpose_json;
pub mod ntu;
pub mod zed_mat;
