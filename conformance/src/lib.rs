//! # pmacwd-conformance: where implementations meet the reference model
//!
//! [`subject::Subject`] is what an implementation under test provides; [`lockstep`] drives it
//! and the model with the same events and compares every observation; [`runner`] runs a trace
//! (the format is the `pmacwd-trace` crate) on the model or a subject; [`generate`] makes
//! shrinking random traces; [`product`] explores model and core together exhaustively;
//! [`coverage`] reports what a run exercised; [`check`] plans and runs the model checks of
//! `specs/check.yaml`; [`path_trace`] turns a checker's path into a trace. Captures of real
//! cards are judged in `pmacwd-capture`. The `pmacwd` binary is `pmacwd-cli`.

pub mod check;
pub mod coverage;
pub mod generate;
pub mod lockstep;
pub mod path_trace;
pub mod product;
pub mod runner;
pub mod subject;
