//! The `raytree` command's tests, in one test binary: commands, outputs and
//! errors (`commands`), bad and extreme input (`field`), the stackless
//! paper's workload (`paper`), the HTML report in headless Chromium
//! (`report_browser`) and `--device gpu` (`gpu`). The peers' tests (`tests/peers.rs`) stay apart, so
//! that CI can build them with Embree alone.

#[path = "../../../tests/core/common.rs"]
mod common;
mod support;

mod commands;
mod field;
mod gpu;
mod paper;
mod report_browser;
mod saved;
