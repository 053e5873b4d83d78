//! # pmacwd: where the reference model meets the world
//!
//! [`check`] runs the model checker over the configurations of `specs/check.yaml` and prints
//! its report; [`trace`] is the trace format and [`runner`] runs a trace on the model; the
//! `pmacwd` binary is the command line.

pub mod check;
pub mod coverage;
pub mod decode;
pub mod generate;
pub mod import;
pub mod lockstep;
pub mod product;
pub mod replay;
pub mod runner;
pub mod subject;
