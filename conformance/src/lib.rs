//! # pmacwd: where the reference model meets the world
//!
//! [`check`] runs the model checker over the configurations of `specs/check.yaml` and prints
//! its report; the `pmacwd` binary is its command line.

pub mod check;
