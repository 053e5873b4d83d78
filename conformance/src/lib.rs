//! # pmacwd-conformance: where implementations and captures meet the reference model
//!
//! [`subject::Subject`] is what an implementation under test provides; [`lockstep`] drives it
//! and the model with the same events and compares every observation; [`runner`] runs a trace
//! (the format is the `pmacwd-trace` crate) on the model or a subject; [`generate`] makes
//! shrinking random traces; [`product`] explores model and core together exhaustively;
//! [`coverage`] reports what a run exercised; [`replay`] judges captures from real cards;
//! [`decode`] explains a `???` reply; [`import`] turns host logs into traces; [`check`] plans
//! and runs the model checks of `specs/check.yaml`. The `pmacwd` binary is `pmacwd-cli`.

pub mod check;
pub mod coverage;
pub mod decode;
pub mod explain;
pub mod generate;
pub mod import;
pub mod lockstep;
pub mod margin;
pub mod path_trace;
pub mod product;
pub mod replay;
pub mod runner;
pub mod subject;
pub mod timeline;
