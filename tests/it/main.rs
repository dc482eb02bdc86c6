//! The integration tests, as one test binary (`cargo test --test it`): one link of the library
//! instead of one per file, and one place for the helpers they share.
//!
//! Each module is one area, run through the library or the `autoact` binary. The `*_real_data`
//! modules read recordings from `../shared/data`, which is not part of the crate; their tests are
//! `#[ignore]`d and `.ci/run` runs them with `cargo test -- --ignored` when the data
//! exists. Run one area with a filter on its module, e.g. `cargo test --test it trim::`.

mod common;

mod bvh_axes;
mod bvh_real_data;
mod cli;
mod cli_args;
mod cli_bags;
mod dataset;
mod dsi_real_data;
mod export;
mod fuzzing;
mod generate;
mod h36m_real_data;
mod labels;
mod outputs;
mod randomise;
mod readers_real_data;
mod render;
mod roundtrip_real_data;
mod trim;
mod video;
