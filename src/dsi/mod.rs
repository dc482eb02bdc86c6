//! Dynamic Skeletal Interpolation (DSI): smoothing and interpolating joint-angle curves.

pub mod supersmoother;
