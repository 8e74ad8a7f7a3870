//! The image tools as whole programs: `mixmc-composite`, `mixmc-diff` and `mixmc-merge` run on
//! synthetic inputs and tiny renders, cross-checked against NumPy / NVIDIA FLIP in
//! `tools/metrics_reference.py`. One test binary, each test in its own temporary directory.

#[path = "../util/mod.rs"]
mod shared;

mod composite;
mod diff;
mod merge;
mod util;
